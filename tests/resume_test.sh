#!/usr/bin/env bash
# A shear run stopped (at a chosen time, and by SIGTERM at an arbitrary moment) and resumed ends
# in exactly the same state as the same run done in one go.
# Usage: resume_test.sh CDSHEAR PACKING WORKDIR
set -euo pipefail
exe=$1; packing=$2; work=$3
rm -rf "$work"; mkdir -p "$work"
common=(-q --packing "$packing" --set shear.duration=6 --set output.checkpoint_interval=0.5
        --set output.snapshot_interval=1)

"$exe" run "${common[@]}" -o "$work/straight" > /dev/null

# Stopped at t = 1.2 (between checkpoints: the stop itself writes one), then resumed.
"$exe" run "${common[@]}" --stop-at 1.2 -o "$work/stopped" > /dev/null
test -f "$work/stopped/interrupted_state.json"
"$exe" run -q --resume "$work/stopped" > /dev/null

# Killed with SIGTERM at whatever step it has reached after 2 s, then resumed.
"$exe" run "${common[@]}" -o "$work/killed" > /dev/null & pid=$!
sleep 2; kill -TERM $pid 2>/dev/null || true
wait $pid || true
"$exe" run -q --resume "$work/killed" > /dev/null

status=0
for run in stopped killed; do
  for f in final_state.json timeseries.csv; do
    if ! cmp -s "$work/straight/$f" "$work/$run/$f"; then
      echo "FAIL: $run/$f differs from the uninterrupted run"; status=1
    fi
  done
  if ! diff -r -q "$work/straight/snapshots" "$work/$run/snapshots"; then
    echo "FAIL: $run/snapshots differ from the uninterrupted run"; status=1
  fi
done
[ $status -eq 0 ] && echo "resume_test: stopped and killed runs resumed bit-identically"
exit $status
