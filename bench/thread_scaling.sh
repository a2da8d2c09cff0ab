#!/usr/bin/env bash
# Thread scaling from a checkpoint (docs/benchmarks.md, "Threads"): resumes copies of a
# run's checkpoint for DURATION time units on each thread count in turn, REPEATS rounds, and
# prints each run's wall time and state hash, then the median wall time per thread count and its
# speed-up against the first count. Every copy starts from the same state, so the runs do the
# same work; the hashes must all be equal (results do not depend on the thread count).
#
#   bench/thread_scaling.sh RUN_DIR DURATION REPEATS THREADS...
#
# Environment: CDSHEAR [build/cdshear]; extra variables (OMP_PROC_BIND, ...) pass through.
# Example (system 7's slow phase, 3 t, one to eight threads, three rounds):
#   bench/thread_scaling.sh runs/s7 3 3 1 2 4 8
set -euo pipefail

if [[ $# -lt 4 || "$1" == -h || "$1" == --help ]]; then
  sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//'
  exit 2
fi
run=$1 duration=$2 repeats=$3
shift 3
counts=("$@")
repo=$(cd "$(dirname "$0")/.." && pwd)
source "$repo/scripts/checkpoint_copy.sh"
cdshear=$(checkpoint_cdshear)
require_checkpoint_run "$run"
[[ "$repeats" =~ ^[1-9][0-9]*$ ]] || { echo "error: REPEATS '$repeats': expected a positive integer" >&2; exit 2; }
for t in "${counts[@]}"; do
  [[ "$t" =~ ^[1-9][0-9]*$ ]] || { echo "error: THREADS '$t': expected a positive integer" >&2; exit 2; }
done

scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
copy() {
  rm -rf "$scratch/copy"
  mkdir "$scratch/copy"
  copy_checkpoint "$run" "$scratch/copy"
}
copy
start=$(checkpoint_time "$cdshear" "$scratch/copy" "$run")
stop=$(/usr/bin/python3 -c "print($start + $duration)")

echo "# $run from t = $start to $stop; $(nproc) processors; $cdshear"
echo "round threads wall_s state_hash"
walls="$scratch/walls"
: > "$walls"
for ((round = 1; round <= repeats; ++round)); do
  for t in "${counts[@]}"; do
    copy
    t0=$(date +%s%N)
    "$cdshear" run --resume "$scratch/copy" --threads "$t" --no-analyze -q \
      --set shear.duration="$stop" --stop-at "$stop" > "$scratch/log" 2>&1 ||
      { echo "error: the run on $t threads failed:" >&2; tail -n 5 "$scratch/log" >&2; exit 1; }
    t1=$(date +%s%N)
    hash=$(grep -ho '"state_hash": *"[0-9a-f]*"' "$scratch"/copy/run_info_resume*.json |
           grep -o '[0-9a-f]\{16\}' | tail -1)
    wall=$(/usr/bin/python3 -c "print(f'{($t1 - $t0) / 1e9:.2f}')")
    echo "$round $t $wall $hash" | tee -a "$walls"
  done
done
/usr/bin/python3 - "$walls" "${counts[0]}" <<'EOF'
import statistics, sys
rows = [line.split() for line in open(sys.argv[1])]
walls, hashes = {}, set()
for _, threads, wall, state_hash in rows:
    walls.setdefault(int(threads), []).append(float(wall))
    hashes.add(state_hash)
base = statistics.median(walls[int(sys.argv[2])])
print("threads median_wall_s speed_up")
for threads, w in walls.items():
    print(f"{threads} {statistics.median(w):.2f} {base / statistics.median(w):.2f}")
print("state hashes:", "all equal" if len(hashes) == 1 else f"DIFFER ({len(hashes)})")
sys.exit(0 if len(hashes) == 1 else 1)
EOF
