#!/usr/bin/env bash
# Accuracy study of the solver settings (docs/accuracy.md): runs one case with one setting changed
# at a time, and a reference with the tightest settings, analyses each run, then tabulates and
# plots them against the reference (python3 -m cdshear_analysis study).
#
#   scripts/accuracy_study.sh OUT_DIR [PARAMETER...]
#
# PARAMETER: cap, alpha, dt, order, or all (default). Environment (defaults in brackets):
#   SYSTEM [1]  V [0.5]  DURATION [400] time units per run  THREADS [1]
#   CDSHEAR [build/cdshear]  PACKING [prepared and cached in packings/ by the first run]
#   JOBS [1] runs at the same time (each on THREADS threads)
# A run folder that already holds a finished run is kept (rerun the script to complete a study);
# delete it to run it again.
set -euo pipefail

if [[ $# -lt 1 || "$1" == -h || "$1" == --help ]]; then
  sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'
  exit 2
fi
out=$1
shift
params=("$@")
[[ ${#params[@]} -eq 0 ]] && params=(all)

repo=$(cd "$(dirname "$0")/.." && pwd)
cdshear=${CDSHEAR:-$repo/build/cdshear}
system=${SYSTEM:-1}
velocity=${V:-0.5}
duration=${DURATION:-400}
threads=${THREADS:-1}
jobs=${JOBS:-1}
[[ -x "$cdshear" ]] || { echo "error: $cdshear: not built (scripts/setup.sh)" >&2; exit 2; }
mkdir -p "$out"

# The settings of each parameter (docs/accuracy.md says why these). dt is set through the wall
# displacement per step, 0.001 d to 0.02 d (dt = displacement / V).
settings=()
add() { settings+=("$1"); }
for p in "${params[@]}"; do
  case $p in
    cap | all)
      for s in 25 50 100 200 400 1000; do add "solver.max_sweeps=$s"; done ;;&
    alpha | all)
      for a in 1e-4 1e-5 1e-6 1e-7 1e-8; do add "solver.alpha=$a"; done ;;&
    dt | all)
      for d in 0.001 0.002 0.005 0.01 0.02; do
        add "step.dt=$(awk -v d="$d" -v v="$velocity" 'BEGIN { printf "%.6g", d / v }')"
      done ;;&
    order | all)
      for o in random sequential coloured; do add "solver.order=\"$o\""; done ;;
    cap | alpha | dt) ;;
    *) echo "error: unknown parameter '$p' (cap, alpha, dt, order, all)" >&2; exit 2 ;;
  esac
done

# Reference: no practical cap and a tight tolerance on every force-carrying contact.
reference=(--set solver.max_sweeps=5000 --set solver.alpha=1e-9 --set solver.converged_fraction=1.0)

# Every run of a study starts from the same packing: a given PACKING is copied into OUT_DIR once
# (a test fixture or cache rebuilt meanwhile cannot change it under a running study); without
# one, the first run prepares and caches it, and its copy is used from then on.
packing_args=()
if [[ -f "$out/packing.json" ]]; then
  packing_args=(--packing "$out/packing.json")
elif [[ -n "${PACKING:-}" ]]; then
  cp "$PACKING" "$out/packing.json"
  packing_args=(--packing "$out/packing.json")
fi

run_one() {  # folder, then --set arguments
  local dir=$1
  shift
  if [[ -f "$dir/run_info.json" ]] && grep -q '"outcome": "finished"' "$dir/run_info.json"; then
    echo "kept $dir"
  else
    rm -rf "$dir"
    echo "running $dir"
    "$cdshear" run --system "$system" -V "$velocity" --set "shear.duration=$duration" \
      "${packing_args[@]}" --threads "$threads" --no-analyze -q -o "$dir" "$@" >"$dir.log" 2>&1 ||
      { echo "error: $dir failed, see $dir.log" >&2; return 1; }
  fi
  "$cdshear" analyze "$dir" >/dev/null
}

run_one "$out/reference" "${reference[@]}"
if [[ ${#packing_args[@]} -eq 0 ]]; then  # the reference prepared it: keep a copy
  used=$(sed -n 's/^ *"packing": "\(.*\)",$/\1/p' "$out/reference/run_info.json")
  cp "$used" "$out/packing.json"
  packing_args=(--packing "$out/packing.json")
fi
pids=()
for s in "${settings[@]}"; do
  name=${s//\"/}
  run_one "$out/$name" --set "$s" &
  pids+=($!)
  if [[ ${#pids[@]} -ge $jobs ]]; then
    wait "${pids[0]}"
    pids=("${pids[@]:1}")
  fi
done
for pid in "${pids[@]}"; do wait "$pid"; done

PYTHONPATH="$repo/python" /usr/bin/python3 -m cdshear_analysis study "$out"
