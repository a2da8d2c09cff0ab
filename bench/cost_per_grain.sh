#!/usr/bin/env bash
# Cost per grain against the cell's height (docs/benchmarks.md, "Cost per grain and the cell's
# height"): for each wall speed, each round shears each system's prepared packing for DURATION
# time units on one thread with the shear defaults (whole `cdshear run`s, measurements off), and
# prints the core-seconds per time unit and grain (run_info.json's summary.wall_seconds /
# DURATION / grains), the mean sweeps per step and the candidates per grain; then, per speed, each
# system's median over the rounds and the median of its ratios to the first system's run of the
# same round (pairs, which hold on a machine whose speed drifts). Runs of one system and
# speed do the same work: their state hashes must be equal. Extra `cdshear run` options (after
# --) apply to every run, e.g. `-- --set solver.alpha=1e-7`.
#
#   bench/cost_per_grain.sh PACKING_DIR "SYSTEMS" "SPEEDS" DURATION ROUNDS [-- RUN_OPTIONS]
#
# DURATION is one value for all systems or one per system in the order of SYSTEMS ("100 20": the
# small system runs longer, for a time that a start-up does not weigh on). PACKING_DIR holds
# systemK.json for each system K; a missing one is prepared with `cdshear prepare --system K`
# (system 7: about ten minutes on two cores).
# A speed written rate=R shears each system at V = R times its packing's nominal height (the
# `height` of the packing file, the study's L_y): the same shear rate V / L_y in every cell.
# Environment: CDSHEAR [build/cdshear], CDSHEAR_BENCH [build/bench/cdshear_bench].
# Example (systems 1 and 7 at V = 0.5 and 0.05, 20 t, three rounds):
#   bench/cost_per_grain.sh packings/study "1 7" "0.5 0.05" 20 3
# (the same shear rate, V / L_y = 0.0025, in systems 1, 5 and 7: V = 0.05, 0.2 and 0.5)
#   bench/cost_per_grain.sh packings/study "1 5 7" rate=0.0025 20 3
set -euo pipefail

if [[ $# -lt 5 || "$1" == -h || "$1" == --help ]]; then
  sed -n '2,20p' "$0" | sed 's/^# \{0,1\}//'
  exit 2
fi
dir=$1 systems=$2 speeds=$3 duration_arg=$4 durations=($4) rounds=$5
shift 5
[[ $# -gt 0 && "$1" == -- ]] && shift
extra=("$@")
source "$(dirname "$0")/binaries.sh"
[[ "$rounds" =~ ^[1-9][0-9]*$ ]] || { echo "error: ROUNDS '$rounds': expected a positive integer" >&2; exit 2; }
for v in $speeds; do
  [[ "$v" != rate=* || "${v#rate=}" =~ ^[0-9]*\.?[0-9]+([eE][-+]?[0-9]+)?$ ]] \
    || { echo "error: speed '$v': expected rate=R with R a positive number" >&2; exit 2; }
done
[[ -n "${systems// /}" ]] || { echo "error: SYSTEMS: expected at least one system" >&2; exit 2; }
system_list=($systems)
if [[ ${#durations[@]} -eq 1 ]]; then
  for ((i = 1; i < ${#system_list[@]}; ++i)); do durations+=("${durations[0]}"); done
fi
[[ ${#durations[@]} -eq ${#system_list[@]} ]] \
  || { echo "error: DURATION '$duration_arg': expected one value or one per system (${#system_list[@]})" >&2; exit 2; }
declare -A duration_of
for ((i = 0; i < ${#system_list[@]}; ++i)); do duration_of[${system_list[i]}]=${durations[i]}; done
mkdir -p "$dir"
for k in $systems; do prepare_packing "$dir" "$k"; done

scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
table=$scratch/table
: > "$table"

echo "# ${durations[*]} t per run (systems $systems), one thread, $rounds rounds; $cdshear ${extra[*]}"
echo "round system V core_s_per_t_grain mean_sweeps candidates_per_grain wall_s state_hash"
for ((round = 1; round <= rounds; ++round)); do
  for v in $speeds; do
    for k in $systems; do
      duration=${duration_of[$k]}
      out=$scratch/run
      rm -rf "$out"
      speed=$v
      if [[ "$v" == rate=* ]]; then
        speed=$(/usr/bin/python3 -c 'import json, sys
print(repr(float(sys.argv[1]) * json.load(open(sys.argv[2]))["height"]))' "${v#rate=}" \
          "$dir/system$k.json")
      fi
      "$cdshear" run --system "$k" -V "$speed" --packing "$dir/system$k.json" \
        --set shear.duration="$duration" --set measure.enabled=false --threads 1 -q --no-analyze \
        "${extra[@]}" -o "$out" > "$scratch/log" 2>&1 \
        || { echo "error: system $k at V = $speed failed:" >&2; tail -n 5 "$scratch/log" >&2; exit 1; }
      /usr/bin/python3 - "$round" "$k" "$v" "$duration" "$dir/system$k.json" "$out/run_info.json" \
        <<'EOF' | tee -a "$table"
import json, sys
round_, system, v, duration, packing, info = sys.argv[1:]
grains = json.load(open(packing))["n"]
run = json.load(open(info))
s = run["summary"]
cost = s["wall_seconds"] / float(duration) / grains
print(f"{round_} {system} {v} {cost:.4e} {s['mean_sweeps']:.1f} {s['mean_contacts'] / grains:.3f} "
      f"{s['wall_seconds']:.2f} {run['state_hash']}")
EOF
    done
  done
done

/usr/bin/python3 - "$table" "$systems" "$speeds" <<'EOF'
import statistics, sys
rows = [line.split() for line in open(sys.argv[1])]
systems, speeds = sys.argv[2].split(), sys.argv[3].split()
cost = {(r[0], r[1], r[2]): float(r[3]) for r in rows}
rounds = sorted({r[0] for r in rows}, key=int)
ok = True
for v in speeds:
    for k in systems:
        mine = [cost[(n, k, v)] for n in rounds]
        # each round's ratio to the first system's run of that round: pairs that hold on a
        # machine whose speed drifts between rounds
        ratios = [cost[(n, k, v)] / cost[(n, systems[0], v)] for n in rounds]
        hashes = {r[7] for r in rows if r[1] == k and r[2] == v}
        ok = ok and len(hashes) == 1
        label = f"V / L_y = {v[5:]}" if v.startswith("rate=") else f"V = {v}"
        print(f"{label}: system {k} {statistics.median(mine):.4e} core-s per t and grain "
              f"(median; {min(mine):.4e} to {max(mine):.4e}), {statistics.median(ratios):.2f} "
              f"times system {systems[0]}'s (median of the rounds' ratios; {min(ratios):.2f} to "
              f"{max(ratios):.2f}); {'same hash' if len(hashes) == 1 else 'HASHES DIFFER'}")
print("state hashes:", "equal within each system and speed" if ok else "DIFFER")
sys.exit(0 if ok else 1)
EOF
