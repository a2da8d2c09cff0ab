#!/usr/bin/env bash
# Paired check of two executables or two settings from the same states (docs/accuracy-methods.md,
# "Paired copies"; uses in docs/accuracy.md, "Builds" and "System 5, V = 0.1"): for each run
# folder given, copies its checkpoint twice, resumes one copy as side A and the other as side B
# for DURATION time units, and prints, over all the runs, the mean difference B - A of each
# series' mean after the checkpoint, with its standard error from the runs' scatter. Both copies
# start from one state, so the difference is the sides' own (a build, an instruction set, a code
# change, a setting), free of the state-to-state scatter that dominates ensembles of whole runs;
# the flows diverge after a few time units, which the pairing over many runs averages out.
#
#   CDSHEAR_A=old/cdshear CDSHEAR_B=new/cdshear scripts/paired_check.sh OUT_DIR DURATION RUN_DIR...
#   SET_B="solver.newton_iterations=16" scripts/paired_check.sh OUT_DIR DURATION RUN_DIR...
#
# OUT_DIR/<k>_<run>/{a,b}: the resumed copies (a folder already done is kept: rerun to finish
# an interrupted check). Each RUN_DIR once. Environment: CDSHEAR_A, CDSHEAR_B [both $CDSHEAR,
# else build/cdshear]; SET_A, SET_B [none]: case settings set on that side's resume, KEY=VALUE
# words separated by spaces (a value without spaces; not shear.duration, which DURATION sets);
# THREADS [1]. A side already done with another executable, other settings or another DURATION
# is an error: give a new OUT_DIR.
set -euo pipefail

if [[ $# -lt 3 || "$1" == -h || "$1" == --help ]]; then
  sed -n '2,/^set -euo/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'
  exit 2
fi
out=$1 duration=$2
shift 2
repo=$(cd "$(dirname "$0")/.." && pwd)
source "$repo/scripts/checkpoint_copy.sh"
declare -A bin
sets_A=() sets_B=()
for side in A B; do
  var=CDSHEAR_$side
  if [[ -n "${!var:-}" ]]; then
    [[ -x "${!var}" ]] || { echo "error: $var=${!var}: not an executable" >&2; exit 2; }
    bin[$side]=${!var}
  else
    bin[$side]=$(checkpoint_cdshear)
  fi
  var=SET_$side
  read -ra words <<< "${!var:-}"
  for kv in "${words[@]}"; do
    [[ "$kv" == ?*=* ]] || { echo "error: $var: '$kv': expected KEY=VALUE" >&2; exit 2; }
    [[ "$kv" != shear.duration=* ]] ||
      { echo "error: $var: '$kv': DURATION sets shear.duration" >&2; exit 2; }
    if [[ $side == A ]]; then sets_A+=(--set "$kv"); else sets_B+=(--set "$kv"); fi
  done
done
if [[ "${bin[A]}" -ef "${bin[B]}" && "${sets_A[*]}" == "${sets_B[*]}" ]]; then
  echo "error: sides A and B are the same executable with the same settings" >&2; exit 2
fi
declare -A given
for run in "$@"; do
  require_checkpoint_run "$run"
  where=$(CDPATH='' cd -- "$run" && pwd -P)
  [[ -z "${given[$where]:-}" ]] ||
    { echo "error: $run: given twice (as ${given[$where]}): each run pairs once" >&2; exit 2; }
  given[$where]=$run
done
mkdir -p "$out"

k=0
for run in "$@"; do
  k=$((k + 1))
  pair="$out/${k}_$(basename "$(CDPATH='' cd -- "$run" && pwd)")"
  for side in A B; do
    dir="$pair/${side,,}"
    if [[ $side == A ]]; then sets=("${sets_A[@]}"); else sets=("${sets_B[@]}"); fi
    made_with="${bin[$side]} ${sets[*]}"
    if [[ -f "$dir/paired_check.done" ]]; then
      [[ ! -f "$dir/paired_check.side" || "$(cat "$dir/paired_check.side")" == "$made_with" ]] ||
        { echo "error: $dir: made by $(cat "$dir/paired_check.side"), not $made_with" >&2; exit 2; }
      [[ ! -f "$dir/paired_check.duration" ]] ||
        awk -v made="$(cat "$dir/paired_check.duration")" -v asked="$duration" \
          'BEGIN { exit !(made + 0 == asked + 0) }' ||
        { echo "error: $dir: made for DURATION $(cat "$dir/paired_check.duration"), not" \
            "$duration: give a new OUT_DIR" >&2; exit 2; }
      continue
    fi
    rm -rf "$dir" && mkdir -p "$dir"
    copy_checkpoint "$run" "$dir"
    start=$(checkpoint_time "${bin[$side]}" "$dir" "$run")
    stop=$(/usr/bin/python3 -c "print($start + $duration)")
    "${bin[$side]}" run --resume "$dir" --threads "${THREADS:-1}" --no-analyze -q \
      --set shear.duration="$stop" "${sets[@]}" --stop-at "$stop" > "$dir/paired_check.log" 2>&1 ||
      { echo "error: $dir: the resume failed (see $dir/paired_check.log)" >&2; exit 1; }
    echo "$start" > "$dir/paired_check.start"
    echo "$made_with" > "$dir/paired_check.side"
    echo "$duration" > "$dir/paired_check.duration"
    touch "$dir/paired_check.done"
  done
  echo "$pair: done"
done
PYTHONPATH="$repo/python" /usr/bin/python3 -m cdshear_analysis series-pairs "$out"
