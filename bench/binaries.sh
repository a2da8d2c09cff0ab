# Shared by the bench/*.sh scripts that run the binaries (sourced, not run): sets
# `cdshear` and `bench` to the binaries they run (CDSHEAR [build/cdshear], CDSHEAR_BENCH
# [build/bench/cdshear_bench]) and exits 2 unless both are built; defines prepare_packing.
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cdshear=${CDSHEAR:-$repo/build/cdshear}
bench=${CDSHEAR_BENCH:-$repo/build/bench/cdshear_bench}
for exe in "$cdshear" "$bench"; do
  [[ -x "$exe" ]] || { echo "error: $exe: not built (scripts/setup.sh)" >&2; exit 2; }
done

# prepare_packing DIR K: DIR/systemK.json, prepared with `cdshear prepare --system K` unless it
# is there already (not empty); exits 1 if the preparation fails.
prepare_packing() {
  local packing=$1/system$2.json
  [[ -s "$packing" ]] && return 0
  echo "# preparing $packing (cdshear prepare --system $2)" >&2
  "$cdshear" prepare -q --system "$2" -o "$packing" >&2 \
    || { echo "error: preparing system $2 failed" >&2; exit 1; }
}
