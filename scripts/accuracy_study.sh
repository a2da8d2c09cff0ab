#!/usr/bin/env bash
# Accuracy study of the solver settings (docs/accuracy.md): runs one case with one setting changed
# at a time, and a reference with the tightest settings, analyses each run, then tabulates and
# plots them against the reference (python3 -m cdshear_analysis study).
#
#   scripts/accuracy_study.sh OUT_DIR [PARAMETER...]
#
# PARAMETER: cap, alpha, dt, order, seed, or all (default). Environment (defaults in
# brackets):
#   SYSTEM [1]  V [0.5]  DURATION [400] time units per run  THREADS [1]
#   CDSHEAR [build/cdshear]  PACKING [prepared and cached in packings/ by the first run]
#   JOBS [1] runs at the same time (each on THREADS threads)
#   REALIZATIONS [1] reference runs, each with its own solver seed (combined by the study)
#   WALL [unset] seconds: each run stops (with a checkpoint) after this much wall time instead
#     of at DURATION, and ends at the time it reached; equal wall time, unequal durations
# A run folder that already holds a finished run is kept (rerun the script to complete a study);
# delete it to run it again. One setting can change several keys: KEY=VALUE,KEY=VALUE.
set -euo pipefail

if [[ $# -lt 1 || "$1" == -h || "$1" == --help ]]; then
  sed -n '2,17p' "$0" | sed 's/^# \{0,1\}//'
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
      for o in random coloured; do add "solver.order=\"$o\""; done
      add "solver.skip_dormant=false" ;;&
    seed | all)  # the default settings with another solver seed: the scatter of realizations
      add "solver.seed=2" ;;
    cap | alpha | dt | order) ;;
    *) echo "error: unknown parameter '$p' (cap, alpha, dt, order, seed, all)" >&2
      exit 2 ;;
  esac
done

# Reference: no practical cap and a tight tolerance on every force-carrying contact.
reference="solver.max_sweeps=5000,solver.alpha=1e-9,solver.converged_fraction=1.0"
reference+=",solver.skip_dormant=false"

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

sets() {  # KEY=VALUE[,KEY=VALUE...] -> --set KEY=VALUE ...
  local IFS=,
  for kv in $1; do printf '%s\n' --set "$kv"; done
}

finished() { grep -qs '"outcome": "finished"' "$1"/run_info*.json; }

run_one() {  # folder, then --set arguments
  local dir=$1
  shift
  if finished "$dir"; then
    echo "kept $dir"
  elif [[ -z "${WALL:-}" ]]; then
    rm -rf "$dir"
    echo "running $dir"
    "$cdshear" run --system "$system" -V "$velocity" --set "shear.duration=$duration" \
      "${packing_args[@]}" --threads "$threads" --no-analyze -q -o "$dir" "$@" >"$dir.log" 2>&1 ||
      { echo "error: $dir failed, see $dir.log" >&2; return 1; }
  else
    # Started (or resumed) toward a duration it will not reach, stopped by SIGTERM after WALL
    # seconds (a checkpoint is written), then ended at the time it reached.
    echo "running $dir for ${WALL} s"
    if [[ -f "$dir/checkpoint.cbor" ]]; then
      timeout -s TERM "$WALL" "$cdshear" run --resume "$dir" --threads "$threads" --no-analyze \
        -q >>"$dir.log" 2>&1 || true  # exit 130 when stopped: expected
    else
      rm -rf "$dir"
      timeout -s TERM "$WALL" "$cdshear" run --system "$system" -V "$velocity" \
        --set "shear.duration=1e6" "${packing_args[@]}" --threads "$threads" --no-analyze -q \
        -o "$dir" "$@" >"$dir.log" 2>&1 || true
    fi
    local reached
    reached=$(sed -n 's/.*stopped at step [0-9]* (t \([0-9.]*\)).*/\1/p' "$dir.log" | tail -1)
    [[ -n "$reached" ]] || { echo "error: $dir did not stop as planned, see $dir.log" >&2; return 1; }
    "$cdshear" run --resume "$dir" --set "shear.duration=$(awk -v t="$reached" \
      'BEGIN { printf "%d", t + 1 }')" --threads "$threads" --no-analyze -q >>"$dir.log" 2>&1 ||
      { echo "error: $dir failed, see $dir.log" >&2; return 1; }
  fi
  "$cdshear" analyze "$dir" >/dev/null
}


if [[ ${#packing_args[@]} -eq 0 ]]; then  # the first reference prepares it: keep a copy
  mapfile -t args < <(sets "$reference")
  run_one "$out/reference" "${args[@]}"
  used=$(sed -n 's/^ *"packing": "\(.*\)",$/\1/p' "$out/reference/run_info.json")
  cp "$used" "$out/packing.json"
  packing_args=(--packing "$out/packing.json")
fi
# Every run is one job: "folder|KEY=VALUE,..." (the references first: they take longest).
jobs_list=("reference|$reference")
for ((k = 2; k <= ${REALIZATIONS:-1}; k++)); do
  jobs_list+=("reference_seed$k|$reference,solver.seed=$k")
done
for s in "${settings[@]}"; do jobs_list+=("${s//\"/}|$s"); done
pids=()
failed=0
for job in "${jobs_list[@]}"; do
  mapfile -t args < <(sets "${job#*|}")
  run_one "$out/${job%%|*}" "${args[@]}" &
  pids+=($!)
  if [[ ${#pids[@]} -ge $jobs ]]; then
    wait "${pids[0]}" || failed=1
    pids=("${pids[@]:1}")
  fi
done
for pid in "${pids[@]}"; do wait "$pid" || failed=1; done

PYTHONPATH="$repo/python" /usr/bin/python3 -m cdshear_analysis study "$out"
exit $failed
