#!/usr/bin/env bash
# cdshear_bench --state goes on from a shear run's checkpoint: it reads the run's disks and wall
# speed, and --newton-history lists each refinement iteration of a sample, as many as the sample
# reports, the residual it returns being the lowest of its entry's and the iterations'.
# --state-jitter solves each sample again from the state moved by up to EPS: it prints how far
# that moves the reference, a distance above 0 that a 1e-7 d move keeps below 10% in the impulses
# and the top wall force and below 1% of V in the velocities, and refuses a jitter out of range
# by name. --dt steps with the time step given instead of the rule's, and refuses one that is not
# positive. A file that is not a checkpoint, options out of range and a missing packing are
# refused by name (exit 2), as is a --save=PATH whose folder does not exist.
# Usage: bench_state_test.sh CDSHEAR CDSHEAR_BENCH PACKING WORKDIR
set -uo pipefail
exe=$1; bench=$2; packing=$3; work=$4
rm -rf "$work"; mkdir -p "$work"; cd "$work"
fails=0
if ! "$exe" run -q --no-analyze --packing "$packing" --system 1 -V 0.3 \
     --set shear.duration=0.5 --set output.checkpoint_interval=0.25 -o run > run.out 2>&1; then
  echo "FAIL: the shear run failed"; cat run.out; exit 1
fi
if ! "$bench" --state run/checkpoint.cbor --steps 2 --warmup 0 --newton 6 --newton-history \
     --step-error 2 --step-error-spacing 1 > state.csv 2> state.txt; then
  echo "FAIL: cdshear_bench --state failed"; cat state.txt; exit 1
fi
disks=$(/usr/bin/python3 -c "import json, sys; print(len(json.load(open(sys.argv[1]))['disks_xyr']))" \
          "$packing")
if ! grep -qE "checkpoint.cbor: $disks disks, .* t = 0.5, sheared at V = 0.3\$" state.txt; then
  echo "FAIL: expected the run's $disks disks at t = 0.5 and V = 0.3"; head -3 state.txt
  fails=$((fails + 1))
fi
/usr/bin/python3 - state.txt <<'PY' || fails=$((fails + 1))
import re, sys
samples = []
for line in open(sys.argv[1]):
    m = re.search(r"newton (\d+) it .* residual (\S+) -> (\S+)$", line)
    if m:
        samples.append([int(m[1]), float(m[2]), float(m[3]), []])
        continue
    m = re.search(r"^ +it +\d+: .* residual (\S+)$", line)
    if m:
        samples[-1][3].append(float(m[1]))
assert len(samples) == 2, f"FAIL: expected 2 samples with a refinement line, got {len(samples)}"
for iterations, entry, returned, history in samples:
    assert len(history) == iterations, f"FAIL: {iterations} iterations, {len(history)} listed"
    lowest = min([entry] + history)
    assert abs(returned - lowest) <= 0.01 * lowest, f"FAIL: returned {returned}, lowest {lowest}"
PY
if ! "$bench" --state run/checkpoint.cbor --steps 1 --warmup 0 --step-error 2 \
     --step-error-spacing 1 --state-jitter 1e-7 > jitter.csv 2> jitter.txt; then
  echo "FAIL: cdshear_bench --state-jitter failed"; cat jitter.txt; exit 1
fi
/usr/bin/python3 - jitter.txt <<'PY' || fails=$((fails + 1))
import re, sys
moved = [[float(x) for x in m.groups()] for m in re.finditer(
    r"state moved by up to 1\.0e-07: reference moved by (\S+) \(impulses\), (\S+) \(top wall\), "
    r"(\S+) \(velocities / V\)", open(sys.argv[1]).read())]
assert len(moved) == 2, f"FAIL: expected 2 samples with the jittered reference, got {len(moved)}"
for impulses, wall, velocities in moved:
    assert impulses > 0.0, "FAIL: the jitter did not move the reference's impulses"
    # contacts unmatched between the two solves would count their whole impulse
    assert impulses < 0.1 and wall < 0.1, f"FAIL: a 1e-7 move changed impulses by {impulses}, " \
        f"the top wall force by {wall}"
    assert velocities < 1e-2, f"FAIL: a 1e-7 move changed velocities by {velocities} V"
PY
if "$bench" --state run/checkpoint.cbor --steps 1 --step-error 1 --state-jitter 0.5 \
     > bad.csv 2> bad.txt || ! grep -qF -- "--state-jitter" bad.txt; then
  echo "FAIL: --state-jitter 0.5 was not refused by name"; cat bad.txt
  fails=$((fails + 1))
fi
if ! "$bench" --state run/checkpoint.cbor --steps 1 --warmup 0 --dt 0.0025 > dt.csv 2> dt.txt; then
  echo "FAIL: cdshear_bench --dt failed"; cat dt.txt; exit 1
fi
/usr/bin/python3 - dt.csv <<'PY' || fails=$((fails + 1))
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
assert len(rows) == 1, f"FAIL: expected one case with --dt, got {len(rows)}"
# The rule gives min(0.005, 0.002 / 0.3) = 0.005 at this state's V = 0.3.
assert rows[0]["dt"] == "0.0025", f"FAIL: --dt 0.0025 stepped with dt = {rows[0]['dt']}"
PY
if "$bench" --state run/checkpoint.cbor --steps 1 --dt 0 > bad.csv 2> bad.txt ||
   ! grep -qF -- "--dt" bad.txt; then
  echo "FAIL: --dt 0 was not refused by name"; cat bad.txt
  fails=$((fails + 1))
fi
if "$bench" --state "$packing" --steps 1 > bad.csv 2> bad.txt ||
   ! grep -qF "$packing" bad.txt; then
  echo "FAIL: a packing file as --state was not refused by name"; cat bad.txt
  fails=$((fails + 1))
fi
# A negative or malformed number is bad input (exit 2), not wrapped around.
for bad in "--sizes -5" "--steps -1" "--alpha 1e-5x"; do
  "$bench" $bad > /dev/null 2> bad.txt; rc=$?
  if [ $rc -ne 2 ] || ! grep -qF -- "${bad%% *}: '${bad#* }'" bad.txt; then
    echo "FAIL: cdshear_bench $bad: exit $rc"; cat bad.txt; fails=$((fails + 1))
  fi
done
# Values out of range are refused by name (exit 2): no disks, more than `cdshear` takes, a width,
# a time or a sample count below zero; so is a packing that is not there.
for bad in "--sizes 0" "--sizes 100000000" "--width -3" "--seconds -1" "--step-error -1" \
           "--packing /nonexistent/p.json"; do
  timeout 60 "$bench" $bad --steps 1 > /dev/null 2> bad.txt; rc=$?
  named=${bad%% *}; [ "$named" = --packing ] && named=${bad#* }
  if [ $rc -ne 2 ] || ! grep -qF -- "$named" bad.txt; then
    echo "FAIL: cdshear_bench $bad: exit $rc"; cat bad.txt; fails=$((fails + 1))
  fi
done
# --save=PATH creates no folder, and a folder in the file's place is refused: both before a step.
for bad in "$work/no_such_folder/x.csv" "$work/run"; do
  timeout 60 "$bench" --save="$bad" --sizes 100 --steps 1 > /dev/null 2> bad.txt; rc=$?
  if [ $rc -ne 2 ] || ! grep -qF -- "--save=$bad" bad.txt || [ -e "$work/no_such_folder" ]; then
    echo "FAIL: cdshear_bench --save=$bad: exit $rc"; cat bad.txt; fails=$((fails + 1))
  fi
done
echo "bench_state_test: $fails failures"
exit $((fails > 0))
