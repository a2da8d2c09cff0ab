#!/usr/bin/env bash
# Two threads against the machine's own parallel capacity (docs/benchmarks.md, "Threads"). Each
# round shears the packing for DURATION time units four ways, in turn: one thread alone, two
# threads, two one-thread copies side by side, and one thread alone again. The one-thread time is
# the faster of the two alone runs, so that a slow moment of a shared machine does not inflate the
# speed-up. The capacity is what two independent processes get from the machine, 2 x (one alone) /
# (the slower of the pair); the share is the two-thread speed-up over that capacity. A capacity
# above 2 means the machine's speed changed within the round: such a round is flagged. Every run
# does the same work: the state hashes must all be equal.
# Before and after the two-thread run, `cdshear_bench --core-round-trip` times a cache line's round
# trip between the cores: on a virtual machine it changes with where the host places the two
# processors (about 100 or about 450 ns on the 2-core machines of docs/benchmarks.md), and the
# two-thread speed with it.
#
#   bench/thread_capacity.sh PACKING SYSTEM VELOCITY DURATION ROUNDS [-- RUN_OPTIONS]
#
# Extra `cdshear run` options (after --) apply to every run, e.g. `-- --set
# solver.normal_compliance=0.01`.
# Environment: CDSHEAR [build/cdshear], CDSHEAR_BENCH [build/bench/cdshear_bench]; extra variables (OMP_PROC_BIND, ...) pass through.
# Example (system 5, 20 t at V = 0.5, three rounds):
#   bench/thread_capacity.sh campaigns/validation/packings/s5_seed1.json 5 0.5 20 3
set -euo pipefail

if [[ $# -lt 5 || "$1" == -h || "$1" == --help ]]; then
  sed -n '2,21p' "$0" | sed 's/^# \{0,1\}//'
  exit 2
fi
packing=$1 system=$2 velocity=$3 duration=$4 rounds=$5
shift 5
[[ $# -gt 0 && "$1" == -- ]] && shift
extra=("$@")
source "$(dirname "$0")/binaries.sh"
[[ -f "$packing" ]] || { echo "error: PACKING '$packing': no such file" >&2; exit 2; }
[[ "$rounds" =~ ^[1-9][0-9]*$ ]] || { echo "error: ROUNDS '$rounds': expected a positive integer" >&2; exit 2; }

scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT

# One run in folder $1 on $2 threads; its state hash to $1/hash.
shear() {
  rm -rf "$1"
  "$cdshear" run --packing "$packing" --system "$system" -V "$velocity" --threads "$2" \
    --set shear.duration="$duration" --set measure.enabled=false --no-analyze -q -o "$1" \
    "${extra[@]}" > "$1.log" 2>&1 || { echo "error: the run on $2 threads failed:" >&2; tail -n 5 "$1.log" >&2; exit 1; }
  grep -o '"state_hash": *"[0-9a-f]*"' "$1/run_info.json" | grep -o '[0-9a-f]\{16\}' > "$1/hash"
}
seconds_since() { /usr/bin/python3 -c "import sys; print(f'{(int(sys.argv[2]) - int(sys.argv[1])) / 1e9:.2f}')" "$1" "$(date +%s%N)"; }

echo "# system $system, $packing, V = $velocity, $duration t; $(nproc) processors; $cdshear ${extra[*]}"
echo "round one_thread_s one_again_s two_threads_s pair_s pair_s speed_up capacity share hashes round_trip_ns"
table="$scratch/table"
: > "$table"
for ((round = 1; round <= rounds; ++round)); do
  t0=$(date +%s%N); shear "$scratch/one" 1; one=$(seconds_since "$t0")
  trip_before=$("$bench" --core-round-trip | grep -o '[0-9]* ns' | grep -o '[0-9]*')
  t0=$(date +%s%N); shear "$scratch/two" 2; two=$(seconds_since "$t0")
  trip_after=$("$bench" --core-round-trip | grep -o '[0-9]* ns' | grep -o '[0-9]*')
  t0=$(date +%s%N)
  (t=$(date +%s%N); shear "$scratch/a" 1; seconds_since "$t" > "$scratch/a.s") &
  (t=$(date +%s%N); shear "$scratch/b" 1; seconds_since "$t" > "$scratch/b.s") &
  wait
  pair_a=$(cat "$scratch/a.s") pair_b=$(cat "$scratch/b.s")
  t0=$(date +%s%N); shear "$scratch/again" 1; again=$(seconds_since "$t0")
  hashes=$(cat "$scratch"/{one,two,a,b,again}/hash | sort -u | wc -l)
  /usr/bin/python3 - "$round" "$one" "$again" "$two" "$pair_a" "$pair_b" "$hashes" \
    "$trip_before/$trip_after" <<'EOF' | tee -a "$table"
import sys
r, (first, again, two, a, b), hashes, trips = sys.argv[1], map(float, sys.argv[2:7]), \
    int(sys.argv[7]), sys.argv[8]
one = min(first, again)
speed_up, capacity = one / two, 2 * one / max(a, b)
flag = " capacity-above-2" if capacity > 2.0 else ""
print(f"{r} {first:.2f} {again:.2f} {two:.2f} {a:.2f} {b:.2f} {speed_up:.3f} {capacity:.3f} "
      f"{speed_up / capacity:.3f} {'same-hash' if hashes == 1 else 'HASHES-DIFFER'} {trips}{flag}")
EOF
done
/usr/bin/python3 - "$table" <<'EOF'
import statistics, sys
rows = [line.split() for line in open(sys.argv[1])]
col = lambda k: [float(r[k]) for r in rows]
print(f"median: speed-up {statistics.median(col(6)):.3f}, capacity {statistics.median(col(7)):.3f}, "
      f"share {statistics.median(col(8)):.3f}")
flagged = sum(len(r) > 11 for r in rows)
if flagged:
    print(f"{flagged} of {len(rows)} rounds with a capacity above 2: the machine's speed changed")
same = all(r[9] == "same-hash" for r in rows)
print("state hashes:", "all equal" if same else "DIFFER")
sys.exit(0 if same else 1)
EOF
