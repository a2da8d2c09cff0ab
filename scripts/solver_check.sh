#!/usr/bin/env bash
# Solver check from a checkpoint (docs/accuracy-methods.md, "Checkpoint copies"; its use on tall
# cells in docs/step-error.md, "Tall cells"): copies a run's checkpoint, resumes the copy for
# DURATION time units with solver keys set (--set) and prints the means of its series over them
# (force-carrying contacts, sweeps, capped steps). Copies of the same checkpoint with different
# settings start from the same state, so their means compare the settings (the flows diverge after
# a while: use a few time units).
#
#   scripts/solver_check.sh RUN_DIR OUT_DIR DURATION [KEY=VALUE...]
#
# KEY: a key of the [solver] table (alpha, max_sweeps, converged_fraction,
# slab_correction_period, ...). Environment: CDSHEAR [build/cdshear], THREADS [1].
# Example (a solve run to convergence, then the defaults, from the same checkpoint):
#   scripts/solver_check.sh runs/s7 /tmp/tight 5 alpha=1e-9 max_sweeps=3000
#   scripts/solver_check.sh runs/s7 /tmp/default 5
set -euo pipefail

if [[ $# -lt 3 || "$1" == -h || "$1" == --help ]]; then
  sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//'
  exit 2
fi
run=$1 out=$2 duration=$3
shift 3
repo=$(cd "$(dirname "$0")/.." && pwd)
source "$repo/scripts/checkpoint_copy.sh"
cdshear=$(checkpoint_cdshear)
require_checkpoint_run "$run"
[[ -e "$out" ]] && { echo "error: $out: exists (give a new folder)" >&2; exit 2; }
mkdir -p "$out"
copy_checkpoint "$run" "$out"

sets=()
for kv in "$@"; do
  [[ "$kv" == ?*=* ]] || { echo "error: '$kv': expected KEY=VALUE" >&2; exit 2; }
  sets+=(--set "solver.$kv")
done

start=$(checkpoint_time "$cdshear" "$out")
stop=$(/usr/bin/python3 -c "print($start + $duration)")
"$cdshear" run --resume "$out" --threads "${THREADS:-1}" --no-analyze -q \
  --set shear.duration="$stop" --stop-at "$stop" "${sets[@]}" > "$out/solver_check.log" 2>&1
tail -n 2 "$out/solver_check.log" | head -1
PYTHONPATH="$repo/python" /usr/bin/python3 -m cdshear_analysis series-means "$out" --after "$start"
