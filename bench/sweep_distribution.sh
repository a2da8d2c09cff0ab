#!/usr/bin/env bash
# Sweeps per step of the solver's shear defaults on the study's cells: for each system and wall
# speed, cdshear_bench shears the system's prepared packing (one thread), WARMUP steps untimed,
# then SECONDS measured, and prints the distribution of the sweeps per step (p10, p50, p90, p99,
# max), the capped share, the steps per second and the mean sweeps. Extra cdshear_bench options
# (after --) apply to every case, e.g. `-- --newton 4` or `-- --step-error 4`.
#
#   bench/sweep_distribution.sh PACKING_DIR "SYSTEMS" "SPEEDS" WARMUP SECONDS [-- BENCH_OPTIONS]
#
# PACKING_DIR holds systemK.json for each system K; a missing one is prepared with
# `cdshear prepare --system K` (system 7: about ten minutes on two cores).
# Environment: CDSHEAR [build/cdshear], CDSHEAR_BENCH [build/bench/cdshear_bench].
# Example (systems 1, 5 and 7 at V = 0.5 and 0.05):
#   bench/sweep_distribution.sh packings/study "1 5 7" "0.5 0.05" 2000 10
set -euo pipefail

if [[ $# -lt 5 || "$1" == -h || "$1" == --help ]]; then
  sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'
  exit 2
fi
dir=$1 systems=$2 speeds=$3 warmup=$4 seconds=$5
shift 5
[[ $# -gt 0 && "$1" == -- ]] && shift
extra=("$@")
source "$(dirname "$0")/binaries.sh"
[[ "$warmup" =~ ^[0-9]+$ ]] || { echo "error: WARMUP '$warmup': expected a whole number" >&2; exit 2; }
mkdir -p "$dir"
printf '%-6s %-6s %-44s %-8s %-9s %s\n' system V "sweeps per step" capped "steps/s" "mean sweeps"
for k in $systems; do
  prepare_packing "$dir" "$k"
  packing=$dir/system$k.json
  for v in $speeds; do
    log=$("$bench" --packing "$packing" --velocity "$v" --warmup "$warmup" --seconds "$seconds" \
          "${extra[@]}" 2>&1 >/dev/null)
    dist=$(sed -n 's/^  sweeps per step: \(.*\); capped \([0-9.]*%\).*$/\1|\2/p' <<<"$log")
    rate=$(sed -n 's/.*\.\.\. [0-9]* steps, \([0-9.]*\) steps\/s, [0-9.]* ns\/update, \([0-9.]*\) sweeps.*/\1|\2/p' <<<"$log")
    printf '%-6s %-6s %-44s %-8s %-9s %s\n' "$k" "$v" "${dist%%|*}" "${dist##*|}" "${rate%%|*}" \
           "${rate##*|}"
    grep -E "median impulse error" <<<"$log" | sed 's/^ */         /' || true
  done
done
