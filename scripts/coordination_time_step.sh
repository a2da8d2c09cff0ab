#!/usr/bin/env bash
# Z against the time step (docs/measurements.md, "Coordination number"): shears one packing at
# V with three time steps and prints, per dt, the bulk Z (closed contacts, gap <= CONTACT_GAP)
# and the bulk count of contacts carrying force at the sampled steps, each as the mean and
# standard error over the windows that start at t >= SKIP.
#
#   scripts/coordination_time_step.sh OUT_DIR [DT...]
#
# DT defaults to 0.0016 0.004 0.01 (the default rule's 0.004 at V = 0.5, 2.5 times smaller and
# larger). Environment: CDSHEAR [build/cdshear], PACKING [the system-1 packing of packings/],
# V [0.5], DURATION [200], WINDOW [20], SKIP [40], CONTACT_GAP [1e-4], THREADS [1].
set -euo pipefail

if [[ $# -lt 1 || "$1" == -h || "$1" == --help ]]; then
  sed -n '2,11p' "$0" | sed 's/^# \{0,1\}//'
  exit 2
fi
repo=$(cd "$(dirname "$0")/.." && pwd)
out=$1
shift
steps=("$@")
[[ ${#steps[@]} -gt 0 ]] || steps=(0.0016 0.004 0.01)
cdshear=${CDSHEAR:-$repo/build/cdshear}
packing=${PACKING:-$repo/packings/n511_h20_d0.8-1_seed1_s0.25_ecd48f39.json}
[[ -e "$out" ]] && { echo "error: $out: exists (give a new folder)" >&2; exit 2; }
mkdir -p "$out"
for dt in "${steps[@]}"; do
  "$cdshear" run --packing "$packing" --system 1 -V "${V:-0.5}" --threads "${THREADS:-1}" \
    --set shear.duration="${DURATION:-200}" --set step.dt="$dt" \
    --set measure.window="${WINDOW:-20}" --set measure.contact_gap="${CONTACT_GAP:-1e-4}" \
    --no-analyze -q -o "$out/dt$dt" > "$out/dt$dt.log" 2>&1
done
PYTHONPATH="$repo/python" /usr/bin/python3 - "$out" "${SKIP:-40}" "${steps[@]}" <<'PY'
import sys
import numpy as np
from cdshear_analysis.rundata import load_run

out, skip, steps = sys.argv[1], float(sys.argv[2]), sys.argv[3:]
print(f"{'dt':>8} {'h':>4} {'windows':>7} {'Z (closed)':>18} {'force-carrying':>18}")
for dt in steps:
    run = load_run(f"{out}/dt{dt}")
    region = list(run["regions"].values())[-1]
    keep = np.asarray(run["windows"]["t_start"]) >= skip

    def pm(name):
        x = np.asarray(region[name], dtype=float)[keep]
        err = x.std(ddof=1) / np.sqrt(len(x)) if len(x) > 1 else np.nan
        return f"{x.mean():.3f} ± {err:.3f}"
    print(f"{dt:>8} {region['h']:>4g} {int(keep.sum()):>7} {pm('bulk_coordination'):>18} "
          f"{pm('bulk_force_carrying_coordination'):>18}")
PY
