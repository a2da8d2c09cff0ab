#!/usr/bin/env bash
# A shear run stopped (at a chosen time, and by SIGTERM at an arbitrary moment) and resumed ends
# in exactly the same state, with the same run.h5 (series, windows, snapshot), as the same run
# done in one go, and so does an extension stopped and ended at its stop; and a run without the measurement observers ends in the same state. Its
# progress.json follows the stop and the resume, and its steps meet the shear defaults'
# contact-law bound. With the active-set refinement on, run_info.json counts the steps it
# brought to round-off.
# Usage: resume_test.sh CDSHEAR PACKING WORKDIR
set -euo pipefail
exe=$1; packing=$2; work=$3
python_dir="$(cd "$(dirname "$0")/../python" && pwd)"
rm -rf "$work"; mkdir -p "$work"
# Short measurement windows so that windows close before and after each interruption.
# 12 t (about 0.9 s): the SIGTERM below lands at most about 0.2 s after the first checkpoint.
common=(-q --no-analyze --packing "$packing" --set shear.duration=12
        --set output.checkpoint_interval=0.5 --set output.snapshot_interval=1
        --set measure.window=0.8 --set measure.sample_interval=0.1)

"$exe" run "${common[@]}" -o "$work/straight" > "$work/straight.out"
# The shear defaults' contact-law bound (solver.residual_tolerance "auto", printed on the first
# line as e dt in d): every step that ended off the cap met it.
/usr/bin/python3 - "$work/straight.out" "$work/straight/run_info.json" <<'PY' ||
import json, re, sys
line = open(sys.argv[1]).readline()
dt = float(re.search(r" dt ([0-9.eE+-]+),", line).group(1))
tolerance = float(re.search(r"residual tolerance ([0-9.eE+-]+) d", line).group(1))
s = json.load(open(sys.argv[2]))["summary"]
assert tolerance > 0, line
assert s["held_back_steps"] >= 0 and s["steps"] > s["capped_steps"], s
worst = s["velocity_residual"]["rms_largest_off_cap"] * dt
assert 0 < worst <= tolerance * (1 + 1e-9), (worst, tolerance)
# the closing lines say it too, with the bound over dt
said = re.search(r"^contact laws: RMS violation per step at most (\S+) d/t off the cap, (\S+) of "
                 r"the bound (\S+)", open(sys.argv[1]).read(), re.M)
assert said, "the run's closing lines do not give the contact-law check"
assert abs(float(said[1]) * dt / worst - 1) < 1e-2, (said[0], worst)
assert abs(float(said[3]) * dt / tolerance - 1) < 1e-2, (said[0], tolerance)
assert abs(float(said[2]) - worst / tolerance) < 1e-2, (said[0], worst / tolerance)
PY
  { echo "FAIL: a step of the default run ended off the cap above its contact-law bound"; exit 1; }

# The refinement's account (run_info.json summary.refinement): every step refined, most of this
# system's to its tolerance, each iteration counted; a run without it has no such entry.
"$exe" run "${common[@]}" --set shear.duration=0.5 --set solver.newton_iterations=4 \
  -o "$work/refined" > "$work/refined.out"
/usr/bin/python3 - "$work/refined/run_info.json" "$work/straight/run_info.json" \
  "$work/refined.out" <<'PY' ||
import json, re, sys
s = json.load(open(sys.argv[1]))["summary"]
r = s["refinement"]
assert r["steps"] == s["steps"] > 0, (r, s["steps"])
assert s["steps"] / 2 < r["steps_to_tolerance"] <= s["steps"], r
# a step solved to round-off meets the contact-law bound: only the others can be undone, and
# the bound holds off the cap with the refinement as without it
assert 0 <= r["steps_undone"] <= r["steps"] - r["steps_to_tolerance"], r
first = open(sys.argv[3]).readline()
dt = float(re.search(r" dt ([0-9.eE+-]+),", first).group(1))
tolerance = float(re.search(r"residual tolerance ([0-9.eE+-]+) d", first).group(1))
assert s["velocity_residual"]["rms_largest_off_cap"] * dt <= tolerance * (1 + 1e-9), s
assert 0 < r["mean_iterations"] <= 4 and r["largest_residual"] > 0, r
# every step at the tolerance (1e-12) exactly when the largest residual left is within it
assert (r["steps_to_tolerance"] == r["steps"]) == (r["largest_residual"] <= 1e-12), r
assert "refinement" not in json.load(open(sys.argv[2]))["summary"]
line = re.search(r"^refinement: (\d+) of (\d+) steps to its tolerance, ([0-9.]+) iterations",
                 open(sys.argv[3]).read(), re.M)
assert line, "the run's last lines do not report the refinement"
assert (int(line[1]), int(line[2])) == (r["steps_to_tolerance"], r["steps"]), (line[0], r)
assert abs(float(line[3]) - r["mean_iterations"]) < 0.01, (line[0], r)
PY
  { echo "FAIL: run_info.json's refinement summary"; exit 1; }

# Stopped at t = 1.2 (between checkpoints: the stop itself writes one), then resumed.
"$exe" run "${common[@]}" --stop-at 1.2 -o "$work/stopped" > /dev/null
test -f "$work/stopped/interrupted_state.json"
grep -q '"outcome": "stopped"' "$work/stopped/run_info.json" ||
  { echo "FAIL: a run ended by --stop-at must say outcome \"stopped\", not finished"; exit 1; }
# progress.json says where it stopped, and after the resume where the resume began and that it
# finished (docs/shear-cell.md, "Outputs of a run").
progress() {  # progress FOLDER: "state time sitting_start_time duration" from progress.json
  /usr/bin/python3 -c 'import json, sys; p = json.load(open(sys.argv[1]))
assert p["format"] == "cdshear-progress" and p["version"] == 1, p
print(p["state"], round(p["time"], 6), round(p["sitting_start_time"], 6), p["duration"])' \
    "$1/progress.json"
}
[ "$(progress "$work/stopped")" = "stopped 1.2 0.0 12.0" ] ||
  { echo "FAIL: progress.json after --stop-at 1.2: $(progress "$work/stopped")"; exit 1; }
# A measured run goes on measuring: a case.toml edited to measure nothing is refused by key,
# the folder left as it was.
cp -r "$work/stopped" "$work/unmeasured"
sed -i 's/^enabled = true$/enabled = false/' "$work/unmeasured/case.toml"
grep -q '^enabled = false$' "$work/unmeasured/case.toml" || { echo "FAIL: case.toml not edited"; exit 1; }
before=$(md5sum "$work/unmeasured/run.h5" "$work/unmeasured/checkpoint.cbor")
if "$exe" run -q --no-analyze --resume "$work/unmeasured" > /dev/null 2> "$work/unmeasured.err"; then
  echo "FAIL: a measured run resumed without its measurement"; exit 1
fi
grep -q "case.toml: key 'measure.enabled': is false, but the run was measured" \
  "$work/unmeasured.err" || { echo "FAIL: $(cat "$work/unmeasured.err")"; exit 1; }
[ "$before" = "$(md5sum "$work/unmeasured/run.h5" "$work/unmeasured/checkpoint.cbor")" ] ||
  { echo "FAIL: the refused resume changed the run's files"; exit 1; }
# Any other [measure] key edited is refused naming that key in case.toml, with both values
# (the edited stripes would otherwise be blamed on checkpoint.cbor, the rest on run.h5).
for edit in "window|0.8|0.4|is 0.4, but the run was measured with 0.8" \
  "stripe_thickness|1.0|2.0|is 2, but the run was measured with 1"; do
  IFS='|' read -r key was now says <<< "$edit"
  rm -rf "$work/edited" && cp -r "$work/stopped" "$work/edited"
  sed -i "s/^$key = $was$/$key = $now/" "$work/edited/case.toml"
  grep -q "^$key = $now$" "$work/edited/case.toml" || { echo "FAIL: $key not edited"; exit 1; }
  if "$exe" run -q --no-analyze --resume "$work/edited" > /dev/null 2> "$work/edited.err"; then
    echo "FAIL: a resume with measure.$key edited went on"; exit 1
  fi
  grep -q "edited/case.toml: key 'measure.$key': $says" "$work/edited.err" ||
    { echo "FAIL: measure.$key edited: $(cat "$work/edited.err")"; exit 1; }
done
"$exe" run -q --no-analyze --resume "$work/stopped" > /dev/null
[ "$(progress "$work/stopped")" = "finished 12.0 1.2 12.0" ] ||
  { echo "FAIL: progress.json after the resume: $(progress "$work/stopped")"; exit 1; }

# Killed with SIGTERM at whatever step it has reached 0 to 0.15 s after its first checkpoint
# (t = 0.5 of 12: a fixed sleep from the start would miss a fast run), then resumed.
"$exe" run "${common[@]}" -o "$work/killed" > /dev/null & pid=$!
for _ in $(seq 400); do [[ -f "$work/killed/checkpoint.cbor" ]] && break; sleep 0.05; done
sleep "$(printf '0.%02d' $((RANDOM % 4 * 5)))"; kill -TERM $pid 2>/dev/null || true
wait $pid || true
# The kill must have landed mid-run, or this part tests nothing.
test -f "$work/killed/interrupted_state.json" ||
  { echo "FAIL: the SIGTERM did not interrupt the run (it had finished)"; exit 1; }
# A --stop-at past a duration that ends where the run stands blames the duration, not the time.
cp -r "$work/killed" "$work/killed_at_end"
reached=$(/usr/bin/python3 -c 'import json, sys; print(repr(json.load(open(sys.argv[1]))["time"]))' \
  "$work/killed_at_end/progress.json")
if "$exe" run -q --no-analyze --resume "$work/killed_at_end" --set shear.duration="$reached" \
     --stop-at 100 > /dev/null 2> "$work/at_end.txt" ||
   ! grep -q "is past the run's end, shear.duration = .*nothing to do" "$work/at_end.txt"; then
  echo "FAIL: --stop-at past a duration at the run's time: $(cat "$work/at_end.txt")"; exit 1
fi
"$exe" run -q --no-analyze --resume "$work/killed" > /dev/null

# The observers only read the state: without them the run ends in the same state.
"$exe" run "${common[@]}" --set measure.enabled=false -o "$work/unobserved" > /dev/null

# Killed after its last checkpoint, before its end's files (final_state.json, run_info.json) and
# inside an atomic write: the resume has no step left and writes them; the write's leftover goes.
cp -r "$work/straight" "$work/ended"
rm "$work/ended/final_state.json" "$work/ended/run_info.json"
echo partial > "$work/ended/final_state.json.tmp.12345"
echo partial > "$work/ended/snapshots/particles.pvd.tmp.12345"   # compared with snapshots/ below
"$exe" run -q --no-analyze --resume "$work/ended" > /dev/null ||
  { echo "FAIL: a run killed before its end's files could not be resumed"; exit 1; }
test ! -e "$work/ended/final_state.json.tmp.12345" ||
  { echo "FAIL: the resume left a killed write's temporary file"; exit 1; }
if "$exe" run -q --no-analyze --resume "$work/ended" > /dev/null 2>&1; then
  echo "FAIL: a finished run resumed with nothing to do"; exit 1
fi
# A refused resume changes nothing: a killed write's temporary (where a failed rename leaves the
# newest data) stays for the user.
echo partial > "$work/ended/run.h5.tmp.12345"
if "$exe" run -q --no-analyze --resume "$work/ended" --set measure.window=2 > /dev/null 2>&1; then
  echo "FAIL: a resume changing measure.window was accepted"; exit 1
fi
test -e "$work/ended/run.h5.tmp.12345" ||
  { echo "FAIL: a refused resume removed a killed write's temporary file"; exit 1; }
rm "$work/ended/run.h5.tmp.12345"

# An extension stopped by --stop-at ends there when resumed with its stop as the duration: its
# final_state.json is still of the earlier end, not of the step it stopped at.
cp -r "$work/straight" "$work/extended"
"$exe" run -q --no-analyze --resume "$work/extended" --set shear.duration=14 --stop-at 13 \
  > /dev/null
"$exe" run -q --no-analyze --resume "$work/extended" --set shear.duration=13 > /dev/null ||
  { echo "FAIL: a stopped extension could not end at its stop"; exit 1; }
"$exe" run "${common[@]}" --set shear.duration=13 -o "$work/straight13" > /dev/null

status=0
if ! cmp -s "$work/straight13/final_state.json" "$work/extended/final_state.json"; then
  echo "FAIL: the extension ended at its stop differs from the run asked for 13 t"; status=1
fi
for run in stopped killed ended; do
  if ! cmp -s "$work/straight/final_state.json" "$work/$run/final_state.json"; then
    echo "FAIL: $run/final_state.json differs from the uninterrupted run"; status=1
  fi
  if ! PYTHONPATH="$python_dir" /usr/bin/python3 -m cdshear_analysis.compare \
       "$work/straight/run.h5" "$work/$run/run.h5"; then
    echo "FAIL: $run/run.h5 differs from the uninterrupted run"; status=1
  fi
  # Byte for byte too: run.h5 stores no creation or modification times.
  if ! cmp -s "$work/straight/run.h5" "$work/$run/run.h5"; then
    echo "FAIL: $run/run.h5 is not byte-identical to the uninterrupted run's"; status=1
  fi
  if ! diff -r -q "$work/straight/snapshots" "$work/$run/snapshots"; then
    echo "FAIL: $run/snapshots differ from the uninterrupted run"; status=1
  fi
done
if ! cmp -s "$work/straight/final_state.json" "$work/unobserved/final_state.json"; then
  echo "FAIL: the run without measurement observers ends in another state"; status=1
fi
# The analysis of a run as it stood at time t (`campaign-compare --until`) is that of the same
# run stopped at t, every figure alike (the run's length and state aside).
"$exe" run "${common[@]:2}" -q --set shear.duration=2.4 -o "$work/short" > /dev/null
if ! PYTHONPATH="$python_dir" /usr/bin/python3 - "$work/straight" "$work/short" << 'EOF_PY'
import sys
from cdshear_analysis.report import read_summary, summary_until
until, why = summary_until(sys.argv[1], 2.4)
assert until is not None, why
stopped = read_summary(sys.argv[2])
assert stopped["steady_windows"] > 0, "no averaging window in 2.4 t: the test compares nothing"
for s in (until, stopped):
    s.pop("run_dir")
    s["case"].pop("duration"), s["case"].pop("finished")
assert until == stopped, [k for k in until if until[k] != stopped.get(k)]
assert summary_until(sys.argv[1], 12.5)[0] is None   # a time the run has not reached
EOF_PY
then
  echo "FAIL: the straight run analysed as it stood at t = 2.4 is not the run stopped there"
  status=1
fi
# A case.toml written before a parameter existed: the resume says which parameter today's
# default fills in, and with what value (the run then writes the complete case.toml).
"$exe" run "${common[@]}" --stop-at 0.4 -o "$work/older" > /dev/null
sed -i '/^\[solver\]/,/^\[/{/^relaxation = /d}' "$work/older/case.toml"
! grep -q '^relaxation = 1.6' "$work/older/case.toml" ||
  { echo "FAIL: the test could not remove solver.relaxation from case.toml"; exit 1; }
warning=$("$exe" run -q --no-analyze --resume "$work/older" 2>&1 >/dev/null)
if ! grep -q "case.toml does not set solver.relaxation (written by an earlier cdshear): this resume runs with today's value 1.6" <<<"$warning"; then
  echo "FAIL: resuming a case.toml without solver.relaxation gave no warning: $warning"; status=1
fi
# Resumed with another snapshot interval, particles.pvd still lists the snapshots of the
# earlier interval, at their times, beside those of the new one.
"$exe" run "${common[@]}" --set shear.duration=5 --stop-at 3.2 -o "$work/regrid" > /dev/null
"$exe" run -q --no-analyze --resume "$work/regrid" --set output.snapshot_interval=1.5 > /dev/null
listed=$(grep -o 'timestep="[^"]*" file="particles_[0-9]*.vtp"' \
  "$work/regrid/snapshots/particles.pvd" | sed 's/timestep="\([^"]*\)".*/\1/' | tr '\n' ' ')
on_disk=$(ls "$work/regrid/snapshots" | grep -c '^particles_[0-9]*\.vtp$')
if [ "$listed" != "1 2 3 4.5 " ] || [ "$on_disk" -ne 4 ]; then
  echo "FAIL: particles.pvd after a resume with another snapshot interval lists '$listed' of" \
    "$on_disk files"
  status=1
fi
[ $status -eq 0 ] && echo "resume_test: stopped and killed runs resumed bit-identically"
exit $status
