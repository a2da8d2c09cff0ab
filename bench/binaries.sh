# Shared by the bench/*.sh scripts that run the binaries (sourced, not run): sets
# `cdshear` and `bench` to the binaries they run (CDSHEAR [build/cdshear], CDSHEAR_BENCH
# [build/bench/cdshear_bench]) and exits 2 unless both are built.
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cdshear=${CDSHEAR:-$repo/build/cdshear}
bench=${CDSHEAR_BENCH:-$repo/build/bench/cdshear_bench}
for exe in "$cdshear" "$bench"; do
  [[ -x "$exe" ]] || { echo "error: $exe: not built (scripts/setup.sh)" >&2; exit 2; }
done
