#!/usr/bin/env bash
# `cdshear run` and `cdshear prepare` reject bad input with a message naming the file or option,
# the key and the problem, and a non-zero exit status, before simulating anything.
# Usage: cli_errors_test.sh CDSHEAR PACKING WORKDIR
set -uo pipefail
exe=$1; packing=$2; work=$3
scene="$(cd "$(dirname "$0")/../scenes" && pwd)/box_settle.toml"
data="$(cd "$(dirname "$0")/data" && pwd)"
rm -rf "$work"; mkdir -p "$work"; cd "$work"
fails=0; checks=0
expect_error() {  # expect_error "words in the message" command...
  local words=$1; shift
  checks=$((checks + 1))
  if "$@" > out.txt 2> err.txt; then
    echo "FAIL: succeeded: $*"; fails=$((fails + 1)); return
  fi
  if ! grep -qF -- "$words" err.txt; then
    echo "FAIL: '$words' not in the error of: $*"; cat err.txt; fails=$((fails + 1))
  fi
}
expect_error "key 'shear.velocity': must be > 0, got -1" "$exe" run -q -V -1 --packing "$packing"
expect_error "key 'system.n': must be between 1 and 1000000, got 0" "$exe" run -q --set system.n=0
expect_error "key 'system.height'" "$exe" run -q --set system.height=0.5
expect_error "/nonexistent/p.json: packing file not found" "$exe" run -q --packing /nonexistent/p.json
expect_error "key 'n': packing has 511 disks" "$exe" run -q --set system.n=100 --packing "$packing"
expect_error "key 'shear.duraton': unknown key" "$exe" run -q --set shear.duraton=5
expect_error "key 'shear.duration': the integer 9007199254740993, beyond 2^53" "$exe" run -q --set shear.duration=9007199254740993
expect_error "--set sheer.velocity=0.4: key 'sheer': unknown key" "$exe" run -q --set sheer.velocity=0.4
expect_error "--set shear.velocity.x=1: key 'shear.velocity'" "$exe" run -q --set shear.velocity.x=1
expect_error "missing.toml: file not found" "$exe" run -q missing.toml
expect_error "--system: system must be 1..7" "$exe" run -q --system 9
expect_error "key 'solver.normal_compliance': must be >= 0 and < 1, got 1" "$exe" run -q --set solver.normal_compliance=1 --packing "$packing"
sed 's/^\[solver\]$/[solver]\nnormal_compliance = 1.5/' "$scene" > compliant_scene.toml
expect_error "compliant_scene.toml: key 'solver.normal_compliance': must be >= 0 and < 1, got 1.5" "$exe" scene compliant_scene.toml -o never
expect_error "--set material.density=1e-320: key 'random_disks[0].diameter_min': radius 0.4" "$exe" scene "$scene" --set material.density=1e-320 -o never
# An array of tables is the file's: no --set empties, replaces or adds to it.
expect_error "--set walls=[]: key 'walls': an array of tables" "$exe" scene "$scene" --set 'walls=[]' -o never
expect_error "key 'disks': an array of tables" "$exe" scene "$scene" --set 'disks=[{position=[1,1],radius=0.5}]' -o never
expect_error "key 'walls.normal': an array of tables ([[walls]])" "$exe" scene "$scene" --set 'walls.normal={x=0.0,y=1.0}' -o never
expect_error "key 'walls.friction': an array of tables ([[walls]])" "$exe" scene "$scene" --set walls.friction=0.3 -o never
expect_error "--set domain.periodic_x=true: key 'domain.length_x': is required with domain.periodic_x" \
  "$exe" scene "$scene" --set domain.periodic_x=true -o never
# A place in a periodic x beyond a million periods (its wrap would lose it).
printf '[run]\nduration=0.05\n[domain]\nperiodic_x=true\nlength_x=10\n[[disks]]\nposition=[1e20,2]\nradius=1\n' > far_scene.toml
expect_error "far_scene.toml: key 'disks[0].position': x = 1e+20 is more than a million periods" "$exe" scene far_scene.toml -o never
expect_error "not a cdshear run folder" "$exe" run -q --resume "$work"
expect_error "--resume $work/absent: no such folder" "$exe" run -q --resume "$work/absent"
ln -sfn "$work/absent" "$work/to_nothing"
expect_error "--resume $work/to_nothing: a link to nothing: no such folder" \
  "$exe" run -q --resume "$work/to_nothing"
rm -f "$work/pipe" && mkfifo "$work/pipe"
expect_error "--resume $work/pipe: is not a folder" "$exe" run -q --resume "$work/pipe"

# A finished run folder is not overwritten, and --resume accepts only numerics/output changes.
"$exe" run -q --no-analyze --packing "$packing" --set shear.duration=0.2 -o done > /dev/null
expect_error "already holds results (case.toml, checkpoint.cbor" "$exe" run -q --packing "$packing" --set shear.duration=0.2 -o done
expect_error "cannot be changed on --resume" "$exe" run -q --resume done --set shear.velocity=2
expect_error "cannot be combined with --resume" "$exe" run -q --resume done -V 2
expect_error "is a file: --resume takes the run's folder (done)" "$exe" run -q --resume done/case.toml
# A run folder without its checkpoint is called one: a clone keeps a finished run's summary, a
# run killed before its first checkpoint only its case.toml.
mkdir cloned stopped && cp done/case.toml cloned/ && cp done/case.toml stopped/
echo '{}' > cloned/summary.json
expect_error "cloned: a finished run without its checkpoint.cbor" "$exe" run -q --resume cloned
expect_error "stopped: a run folder without checkpoint.cbor: the run stopped" "$exe" run -q --resume stopped
# --force replaces what cdshear wrote and nothing else: the user's notes and own figures stay.
mkdir -p done/figures done/snapshots
echo "mine" > done/run_info_notes.txt
echo "mine" > done/figures/my_plot.png
echo "mine" > done/snapshots/particles_final.vtp
touch done/figures/snapshot.png done/run_info_resume_12.json
"$exe" run -q --no-analyze --packing "$packing" --set shear.duration=0.2 -o done --force \
  > /dev/null ||
  { echo "FAIL: --force did not overwrite"; fails=$((fails + 1)); }
checks=$((checks + 1))
for f in done/run_info_notes.txt done/figures/my_plot.png done/snapshots/particles_final.vtp; do
  checks=$((checks + 1))
  test -f "$f" || { echo "FAIL: --force removed the user's $f"; fails=$((fails + 1)); }
done
for f in done/figures/snapshot.png done/run_info_resume_12.json; do
  checks=$((checks + 1))
  test ! -e "$f" || { echo "FAIL: --force left cdshear's $f"; fails=$((fails + 1)); }
done
checks=$((checks + 1))
test -f done/run_info.json || { echo "FAIL: the forced run wrote no run_info.json"; fails=$((fails + 1)); }

# A case or scene file of the user's own kept in the output folder is never written over, --force
# or not; a run folder's own case.toml (written by cdshear) runs again there with --force.
mkdir -p own_case own_scene
printf '# my case\n[shear]\nduration = 0.2\n' > own_case/case.toml
cp "$scene" own_scene/scene.toml
for force in "" --force; do
  expect_error "own_case/case.toml: was not written by cdshear" \
    "$exe" run -q --no-analyze own_case/case.toml --packing "$packing" -o own_case $force
  expect_error "own_scene/scene.toml: was not written by cdshear" \
    "$exe" scene -q own_scene/scene.toml --set run.duration=0.2 -o own_scene $force
done
checks=$((checks + 1))
grep -q "# my case" own_case/case.toml && cmp -s "$scene" own_scene/scene.toml &&
  [ "$(ls own_case own_scene)" = "$(printf 'own_case:\ncase.toml\n\nown_scene:\nscene.toml')" ] ||
  { echo "FAIL: a refused run touched the user's own case or scene file"; fails=$((fails + 1)); }
checks=$((checks + 1))
"$exe" run -q --no-analyze done/case.toml -o done --force > /dev/null 2>&1 &&
  head -1 done/case.toml | grep -q "^# Resolved case written by cdshear" ||
  { echo "FAIL: a run folder's own case.toml did not run again in it"; fails=$((fails + 1)); }

# An output folder that cannot be made is refused before any packing is prepared (a case without
# a cached packing would otherwise prepare one first), and nothing is left behind.
expect_error "/proc/cdshear_x: cannot create the output folder" \
  "$exe" run -q --set system.n=37 --set system.height=6 -o /proc/cdshear_x
checks=$((checks + 1))
[ ! -e packings ] || { echo "FAIL: a packing was prepared for an unusable -o"; fails=$((fails + 1)); }
# A --force that is refused (no such packing) loses nothing: the earlier run is still there.
expect_error "nowhere.json: packing file not found" \
  "$exe" run -q --packing nowhere.json -o done --force
checks=$((checks + 1))
[ -f done/run_info.json ] && [ -f done/checkpoint.cbor ] ||
  { echo "FAIL: a refused --force removed the earlier run's files"; fails=$((fails + 1)); }
# A run that fails after its folder was made (no such packing) leaves no empty run folder.
expect_error "nowhere.json: packing file not found" "$exe" run -q --packing nowhere.json -o fresh
checks=$((checks + 1))
[ ! -e fresh ] || { echo "FAIL: a failed run left its folder"; fails=$((fails + 1)); }

# A run's files belong together: another run's run.h5 (same dt, other V) copied into a stopped
# run's folder is refused on resume, naming the file and the key.
for V in 0.1 0.2; do
  "$exe" run -q --no-analyze --packing "$packing" -V $V --set shear.duration=1 --stop-at 0.5 \
    -o "mixed_$V" > /dev/null
done
cp mixed_0.2/run.h5 mixed_0.1/run.h5
expect_error "run.h5: key 'velocity': the data are of a run with velocity = 0.2, case.toml says 0.1" \
  "$exe" run -q --no-analyze --resume mixed_0.1
# and another realization's (same case, other solver seed)
for seed in 1 2; do
  "$exe" run -q --no-analyze --packing "$packing" -V 0.1 --set shear.duration=1 --stop-at 0.5 \
    --set solver.seed=$seed -o "mixed_seed$seed" > /dev/null
done
cp mixed_seed2/run.h5 mixed_seed1/run.h5
expect_error "run.h5: key 'solver_seed': the data are of a run with solver_seed = 2, case.toml says 1" \
  "$exe" run -q --no-analyze --resume mixed_seed1

# One writer per run folder: while a run is going, a resume of its folder and a new run forced
# into it are refused naming the holder; once it has stopped, the resume goes on.
"$exe" run -q --no-analyze --threads 1 --packing "$packing" --set shear.duration=500 \
  --set output.checkpoint_interval=0.1 -o busy > /dev/null 2>&1 & busy_pid=$!
for _ in $(seq 600); do [ -f busy/checkpoint.cbor ] && break; sleep 0.05; done
expect_error "another cdshear is writing this folder (pid $busy_pid on " "$exe" run -q --resume busy
expect_error "another cdshear is writing this folder (pid $busy_pid on " \
  "$exe" run -q --no-analyze --packing "$packing" --set shear.duration=0.2 -o busy --force
kill -TERM $busy_pid; wait $busy_pid 2> /dev/null
checks=$((checks + 1))
stop=$(/usr/bin/python3 -c 'import json; print(json.load(open("busy/progress.json"))["time"] + 0.2)')
"$exe" run -q --no-analyze --resume busy --stop-at "$stop" > /dev/null 2> err.txt ||
  { echo "FAIL: the resume after the holder stopped: $(cat err.txt)"; fails=$((fails + 1)); }

# Before its first checkpoint too: a resume names the run still going, not a stopped one.
"$exe" run -q --no-analyze --threads 1 --packing "$packing" --set shear.duration=500 \
  --set output.checkpoint_interval=0 -o early > /dev/null 2>&1 & early_pid=$!
for _ in $(seq 600); do [ -f early/case.toml ] && break; sleep 0.05; done
expect_error "another cdshear is writing this folder (pid $early_pid on " "$exe" run -q --resume early
kill -TERM $early_pid; wait $early_pid 2> /dev/null

# A scene stopped by a signal writes its state, exits 130 and says that it does not resume.
printf '[run]\nduration=1e6\n[[walls]]\npoint=[0,0]\nnormal=[0,1]\n' > endless_scene.toml
printf '[[disks]]\nposition=[0,5]\nradius=1\n' >> endless_scene.toml
"$exe" scene -q endless_scene.toml -o endless > scene_out.txt 2>&1 & scene_pid=$!
for _ in $(seq 600); do [ -f endless/timeseries.csv ] && break; sleep 0.05; done
sleep 0.2
kill -TERM $scene_pid; wait $scene_pid; rc=$?
checks=$((checks + 1))
if [ $rc -ne 130 ] || [ ! -f endless/interrupted_state.json ] ||
  ! grep -qF "a scene does not resume: run it again with --force" scene_out.txt; then
  echo "FAIL: a stopped scene: exit $rc:"; cat scene_out.txt; fails=$((fails + 1))
fi

# analyze and plot: a folder that is not a run, an empty and a truncated run.h5 give a clear
# error naming the file, with exit status 2.
expect_status2() {  # expect_status2 "words in the message" command...
  local words=$1; shift
  checks=$((checks + 1))
  "$@" > out.txt 2> err.txt; local rc=$?
  if [ $rc -ne 2 ] || ! grep -qF -- "$words" err.txt || grep -q Traceback err.txt; then
    echo "FAIL: exit $rc, or '$words' not in the error of: $*"; cat err.txt; fails=$((fails + 1))
  fi
}
mkdir -p notarun empty truncated
expect_status2 "notarun" "$exe" analyze notarun
# An analysis that dies inside a library (HDF5 on a damaged file) is named by its parent, exit 2.
printf '#!/bin/sh\nkill -SEGV $$\n' > crash.sh; chmod +x crash.sh
expect_status2 "done: the analysis (\`analyze\`) died of signal 11" \
  env CDSHEAR_PYTHON="$work/crash.sh" "$exe" analyze done
# A stop request sent to cdshear alone (`kill PID`) during its analysis is passed on to the
# analysis: exit 130 with a message at once, and `--plot` does not go on. The stand-in analysis
# signals its parent, then waits for a minute unless stopped.
printf '#!/bin/sh\nkill -TERM $PPID\nexec sleep 60\n' > stop_parent.sh; chmod +x stop_parent.sh
checks=$((checks + 1))
started=$(date +%s)
env CDSHEAR_PYTHON="$work/stop_parent.sh" "$exe" analyze --plot done > out.txt 2> err.txt; rc=$?
if [ $rc -ne 130 ] || [ $(($(date +%s) - started)) -ge 30 ] ||
  ! grep -qF "done: \`analyze\` was interrupted" err.txt || grep -qF "plot" err.txt; then
  echo "FAIL: a stopped analysis: exit $rc after $(($(date +%s) - started)) s:"; cat err.txt
  fails=$((fails + 1))
fi
# The analysis gets the package's folder ahead of the caller's PYTHONPATH, and the rest of the
# environment as it was.
printf '#!/bin/sh\nprintf "%%s|%%s\\n" "$PYTHONPATH" "$CDSHEAR_TEST_MARK" > "$0.env"\n' > env.sh
chmod +x env.sh
checks=$((checks + 1))
env PYTHONPATH=/caller/path CDSHEAR_TEST_MARK=kept CDSHEAR_PYTHON="$work/env.sh" \
  "$exe" analyze done > out.txt 2> err.txt; rc=$?
if [ $rc -ne 0 ] || ! grep -qE '^/[^|]+:/caller/path\|kept$' env.sh.env ||
  [ "$(grep -o /caller/path env.sh.env | wc -l)" -ne 1 ]; then
  echo "FAIL: the analysis's environment (exit $rc):"; cat env.sh.env err.txt; fails=$((fails + 1))
fi
# An interpreter that the system cannot execute: its path and the reason, exit 127.
printf 'not a program\n' > noexec.bin; chmod +x noexec.bin
checks=$((checks + 1))
env CDSHEAR_PYTHON="$work/noexec.bin" "$exe" analyze done > out.txt 2> err.txt; rc=$?
if [ $rc -ne 127 ] || ! grep -qF "error: cannot start $work/noexec.bin: Exec format error" err.txt
then
  echo "FAIL: an interpreter that cannot be executed: exit $rc:"; cat err.txt
  fails=$((fails + 1))
fi
expect_status2 "notarun" "$exe" plot notarun
# Relative folders named like options reach the analysis as "./-x", the output folder too.
printf '#!/bin/sh\nprintf "%%s\\n" "$@" > "$0.args"\n' > args.sh; chmod +x args.sh
for verb in plot report; do
  checks=$((checks + 1))
  env CDSHEAR_PYTHON="$work/args.sh" "$exe" $verb -o -out -- -in > out.txt 2> err.txt; rc=$?
  if [ $rc -ne 0 ] || [ "$(tail -n 4 args.sh.args | tr '\n' ' ')" != "$verb ./-in -o ./-out " ]
  then
    echo "FAIL: $verb's folders named like options (exit $rc):"; cat args.sh.args err.txt
    fails=$((fails + 1))
  fi
done
expect_status2 "nowhere" "$exe" analyze nowhere
: > empty/run.h5
expect_status2 "empty/run.h5" "$exe" analyze empty
expect_status2 "empty/run.h5" "$exe" plot empty
head -c 3000 done/run.h5 > truncated/run.h5
expect_status2 "truncated/run.h5" "$exe" analyze truncated
expect_status2 "truncated/run.h5" "$exe" plot truncated
# A cdshear whose analysis package is not where it was built (source tree moved or removed).
expect_error "/nowhere/cdshear_analysis: the analysis package is not there (from CDSHEAR_ANALYSIS_DIR)" \
  env CDSHEAR_ANALYSIS_DIR=/nowhere "$exe" analyze done
# report: not a campaign folder, an unreadable summary.json or campaign.toml
expect_status2 "nowhere: no such folder" "$exe" report nowhere
touch report_file
expect_status2 "report_file: is a file, not a campaign folder" "$exe" report report_file
expect_status2 "report_file: -o: is a file, not a folder" "$exe" report -o report_file badcampaign
expect_status2 "notarun/runs: no run folders" "$exe" report notarun
mkdir -p badcampaign/runs/s1_seed1_V1
echo "{" > badcampaign/runs/s1_seed1_V1/summary.json
expect_status2 "left out s1_seed1_V1: summary.json: cannot read" "$exe" report badcampaign
echo "[campaign" > badcampaign/campaign.toml
expect_status2 "badcampaign/campaign.toml: cannot read" "$exe" report badcampaign
expect_error "key 'output.sample_interval': moved to measure.sample_interval" \
  "$exe" run -q --set output.sample_interval=0.1
expect_error "key 'measure.boundary_thickness'" "$exe" run -q --set "measure.boundary_thickness=[-1.0]"
expect_error "cannot be changed on --resume" "$exe" run -q --resume done --set measure.window=5
expect_error "a resumed run keeps its time step" \
  "$exe" run -q --no-analyze --resume done --set step.dt=0.001 --set shear.duration=0.3
expect_error "--set step.dt_max=0.001: key 'step.dt_max': changes the time step" \
  "$exe" run -q --no-analyze --resume done --set step.dt_max=0.001 --set shear.duration=0.3
expect_error "lists h = 5 twice" "$exe" run -q --set "measure.boundary_thickness=[5.0, 5.0]"
# Nor a time step edited into case.toml, by less than half a step too (an unmeasured run: no
# run.h5 to check it against).
"$exe" run -q --no-analyze --packing "$packing" --set measure.enabled=false \
  --set shear.duration=0.4 --stop-at 0.2 -o unmeasured > /dev/null
sed -i 's/^dt = "auto"$/dt = 0.004001/' unmeasured/case.toml
expect_error "(was the time step changed?): not a state of the run unmeasured/case.toml describes" \
  "$exe" run -q --no-analyze --resume unmeasured
# A folder whose name holds a line break is resumed (case.toml's comment names it escaped); a
# path that is not UTF-8, which case.toml and run_info.json could not record, is refused.
"$exe" run -q --no-analyze --packing "$packing" --set measure.enabled=false \
  --set shear.duration=0.2 -o $'line\nbreak' > /dev/null
checks=$((checks + 1))
"$exe" run -q --no-analyze --resume $'line\nbreak' --set shear.duration=0.3 > /dev/null 2> err.txt ||
  { echo "FAIL: a folder named with a line break: $(cat err.txt)"; fails=$((fails + 1)); }
cp "$packing" $'packing\xff.json'
for option in --packing --output; do
  if [ $option = --packing ]; then given=("$PWD/"$'packing\xff.json' -o not_utf8)
  else given=("$packing" -o $'out\xff'); fi
  expect_status2 "is not UTF-8 text" "$exe" run -q --no-analyze --set shear.duration=0.2 \
    --packing "${given[@]}"
  grep -q "^error: $option: '" err.txt || { echo "FAIL: not named: $(cat err.txt)"; fails=$((fails + 1)); }
done

# Runaway sizes, zero-step runs and numbers that do not fit are refused before anything is
# prepared or written (docs/reliability.md).
expect_error "key 'step.dt': shear.duration = 240 in steps of 1e-90 is more than the limit" "$exe" run -q --set step.dt=1e-90
expect_error "key 'shear.duration': shear.duration = 1e+30 in steps of 0.004 is more than" "$exe" run -q --set shear.duration=1e30
expect_error "key 'shear.velocity': V = 1e+308 sets the time step to 2e-311" "$exe" run -q -V 1e308
expect_error "key 'shear.duration': shear.duration = 1e+30 in steps of" "$exe" settings --set shear.duration=1e30
# A NUL in a string is refused by name (it would end a path); other control characters in a value
# are shown escaped (an escape would act on the terminal).
expect_error "key 'shear.initial_velocity': holds a NUL character" "$exe" settings --set 'shear.initial_velocity="lin\u0000ear"'
expect_error "got 'lin\x1b[31mear'" "$exe" settings --set 'shear.initial_velocity="lin\u001b[31mear"'
# The key given on the command line is the one named, not the built-in speed beside it.
expect_error "--set shear.duration=1e7: key 'shear.duration': shear.duration = 1e+07 in steps of 0.004" \
  "$exe" settings --set shear.duration=1e7
expect_error "--set step.dt_max=1e-12: key 'step.dt_max': the longest run the step limit allows" \
  "$exe" settings --set step.dt_max=1e-12
expect_error "key 'shear.velocity': V = 0.5 sets the time step to 2e-12" \
  "$exe" settings --set shear.duration=240 --set step.displacement_per_step=1e-12
expect_error "more than the limit" "$exe" run -q -V 1e300
expect_error "the run would do nothing" "$exe" run -q --set shear.duration=1e-9 \
  --set measure.enabled=false
expect_error "key 'measure.sample_interval': is longer than shear.duration (1e-09)" \
  "$exe" run -q --set shear.duration=1e-9
expect_error "key 'solver.max_sweeps': must be between 1 and 1000000, got 4294967296" \
  "$exe" run -q --set solver.max_sweeps=4294967296
expect_error "exceed the limit of 1e+07" "$exe" run -q --set measure.sample_interval=1e-5 \
  --set shear.duration=1000
expect_error "exceed the limit of 1e+07 profile points" "$exe" run -q \
  --set measure.stripe_thickness=1e-9
expect_error "exceed the limit of 1e+07 profile points" "$exe" run -q \
  --set measure.stripe_thickness=1e-300
expect_error "key 'measure.sample_interval': 1e+08 samples" "$exe" settings \
  --set measure.sample_interval=1e-8 --set shear.duration=1
# A condition between two keys is blamed on the command line's --set of either, not on the file
# that holds the other key.
expect_error "--set step.contact_margin=1e-4: key 'measure.contact_gap': must be at most half" \
  "$exe" settings --set step.contact_margin=1e-4
printf '[measure]\ncontact_gap = 0.01\n' > gap.toml
expect_error "--set step.contact_margin=0.01: key 'measure.contact_gap': must be at most half" \
  "$exe" settings gap.toml --set step.contact_margin=0.01
expect_error "--set measure.contact_gap=0.01: key 'measure.contact_gap': must be at most half" \
  "$exe" settings gap.toml --set step.contact_margin=0.01 --set measure.contact_gap=0.01
printf '[step]\ncontact_margin = 1e-5\n' > margin.toml
# A setting that changes nothing under the others is read and named in a warning; a default is not.
checks=$((checks + 1))
"$exe" settings --set 'solver.order="random"' --set solver.slab_correction_period=4 \
  > out.txt 2> err.txt && grep -qF "warning: solver.slab_correction_period = 4 has no effect: the \
slab correction runs in the coloured order only" err.txt ||
  { echo "FAIL: no warning of a setting without effect: $(cat err.txt)"; fails=$((fails + 1)); }
checks=$((checks + 1))
"$exe" settings --set 'solver.order="random"' > out.txt 2> err.txt && ! grep -q warning err.txt ||
  { echo "FAIL: a default named as without effect: $(cat err.txt)"; fails=$((fails + 1)); }
checks=$((checks + 1))
"$exe" scene "$scene" --set solver.anderson_period=3 --set run.duration=0.01 \
  --set run.sample_every=1 -q -o no_mix \
  > out.txt 2> err.txt &&
  grep -qF "warning: solver.anderson_period = 3 has no effect: solver.anderson_depth = 0" err.txt ||
  { echo "FAIL: a scene's setting without effect: $(cat err.txt)"; fails=$((fails + 1)); }
expect_error "margin.toml: key 'measure.contact_gap': must be at most half" \
  "$exe" settings margin.toml --set shear.duration=10
expect_error "--set system.diameter_min=3: key 'system.diameter_max': must be >= diameter_min" \
  "$exe" settings --set system.diameter_min=3
expect_error "--set run.duration=1e30: key 'run.duration': duration 1e+30 with dt" \
  "$exe" scene "$scene" --set run.duration=1e30 -o never
expect_error "--set step.dt=1e-30: key 'run.duration': duration" \
  "$exe" scene "$scene" --set step.dt=1e-30 -o never
# Numbers the engine inverts: a mass or a disk so small (or large) that its inverse is no normal
# number is refused by key, not run into NaN.
expect_error "key 'shear.wall_mass': must be >= 1e-100, got 9.99989e-321" \
  "$exe" run -q --set shear.wall_mass=1e-320
expect_error "key 'preparation.piston_mass': must be > 0 with an inverse that is a normal" \
  "$exe" prepare --set preparation.piston_mass=1e308 -o never.json
expect_error "key 'system.diameter_min': a disk of this diameter cannot move" \
  "$exe" prepare --set system.diameter_min=1e-300 -o never.json
expect_error "--system: system must be 1..7, got 0" "$exe" run -q --system 0
expect_error "--stop-at: must be a time > 0" "$exe" run -q --stop-at -5
expect_error "--threads: must be a whole number from 1 to 1024, got 0" "$exe" run -q --threads 0
expect_error "error: Could not convert: --threads = abc" "$exe" run -q --threads abc
expect_error "--threads: must be a whole number from 1 to 1024, got -2" "$exe" scene "$scene" --threads -2 -o never
# A packing's destination is checked before the preparation: a FIFO, a device or a folder in
# its place is left as it is, a name ending in a slash is refused.
mkfifo fifo.json
expect_error "fifo.json: exists and is not a regular file" "$exe" prepare -q -o fifo.json
[[ -p fifo.json ]] || { echo "FAIL: prepare -o replaced a FIFO"; fails=$((fails + 1)); }
mkdir -p a_folder
expect_error "a_folder: exists and is not a regular file" "$exe" prepare -q -o a_folder
expect_error "new/: names a folder" "$exe" prepare -q -o new/
expect_error "key 'shear': a table value would replace every key" "$exe" run -q \
  --set 'shear={velocity=0.4}'
# A malformed command line is bad input: exit status 2, like every other.
checks=$((checks + 1))
"$exe" run -q --threads abc > /dev/null 2>&1
rc=$?
[[ $rc -eq 2 ]] || { echo "FAIL: --threads abc exited $rc, not 2"; fails=$((fails + 1)); }
expect_error "unknown command 'frobnicate'" "$exe" frobnicate
expect_error "already reached t = 0.2" "$exe" run -q --no-analyze --resume done
[ -e runs ] && { echo "FAIL: a refused run left a folder behind: $(ls -R runs)"; fails=$((fails + 1)); }
checks=$((checks + 1))

# Empty numbers are refused, not read as 0; a --stop-at at the run's own time, an unknown key on
# --resume and an emptied case.toml are named as what they are.
expect_status2 "--stop-at: is empty" "$exe" run -q --resume done --stop-at ''
expect_status2 "--velocity: is empty" "$exe" run -q -V ''
expect_status2 "--threads: is empty" "$exe" run -q --threads ''
expect_error "key 'shear.velocty': unknown key" "$exe" run -q --resume done --set shear.velocty=0.3
expect_error "--stop-at: 0.2 is not later than the run's time 0.2 (step 50" \
  "$exe" run -q --no-analyze --resume done --set shear.duration=1 --stop-at 0.2
# The same at the start of a run: a time within half a step of 0 is not rounded up to one step.
expect_error "--stop-at: 0.0001 is not later than the run's time 0 (step 0" \
  "$exe" run -q --no-analyze --packing "$packing" --stop-at 0.0001 -o stop_refused
checks=$((checks + 1))
test ! -e stop_refused ||
  { echo "FAIL: a refused --stop-at left its folder: $(ls -A stop_refused)"; fails=$((fails + 1)); }
# Spaces around a number are dropped on both sides alike (` 1` was taken, `1 ` refused).
for value in " 0.25" "0.25 "; do
  checks=$((checks + 1))
  "$exe" settings -V "$value" --system " 1 " > settings.txt 2> err.txt &&
    grep -q "^velocity = 0.25" settings.txt ||
    { echo "FAIL: -V '$value' not read as 0.25: $(cat err.txt)"; fails=$((fails + 1)); }
done
cp -r done piped && rm piped/run.h5 && mkfifo piped/run.h5
expect_status2 "piped/run.h5: is not a regular file" \
  timeout 60 "$exe" run -q --no-analyze --resume piped --set shear.duration=0.3
cp -r done emptied && : > emptied/case.toml
expect_error "emptied/case.toml: is empty" "$exe" run -q --no-analyze --resume emptied

# A damaged or foreign packing is refused naming its key, in a run and in a campaign's dry run.
sed 's/"version": 1/"version": 7/' "$packing" > v7.json
expect_error "v7.json: key 'version': is 7; this cdshear reads version 1" \
  "$exe" run -q --packing v7.json
sed 's/"n": 511,/"n": 40,/' "$packing" > n40.json
expect_error "n40.json: key 'n': is 40, but disks_xyr lists 511 disks" \
  "$exe" run -q --packing n40.json
sed 's/"length_x": [0-9.e+-]*,/"length_x": 1000.0,/' "$packing" > wide.json
expect_error "wide.json: key 'length_x': the disks fill a fraction" "$exe" run -q --packing wide.json
sed '0,/{/s/{/{"height": 5.0,/' "$packing" > twice.json
expect_error "twice.json: key 'height': is given twice" "$exe" run -q --packing twice.json
/usr/bin/python3 - "$packing" << 'EOF_PY'
import json, sys
p = json.load(open(sys.argv[1]))
p["disks_xyr"][3] = p["disks_xyr"][3] + [1.0]
json.dump(p, open("four.json", "w"))
EOF_PY
expect_error "four.json: key 'disks_xyr[3]': must be [x, y, r], three numbers" \
  "$exe" run -q --packing four.json
# A disk outside the diameters the packing declares (and the case is checked against), and
# metadata that no preparation writes.
/usr/bin/python3 - "$packing" << 'EOF_PY'
import json, sys
p = json.load(open(sys.argv[1]))
p["disks_xyr"][5][2] = 0.6 * p["diameter_max"]
json.dump(p, open("big.json", "w"))
p = json.load(open(sys.argv[1]))
p["piston_stress"] = -0.25
json.dump(p, open("pull.json", "w"))
p = json.load(open(sys.argv[1]))
p["diameter_min"] = 0.0
json.dump(p, open("dmin0.json", "w"))
EOF_PY
expect_error "big.json: key 'disks_xyr[5]': diameter 1.2 outside the packing's diameter_min" \
  "$exe" run -q --packing big.json
expect_error "pull.json: key 'piston_stress': must be a finite number > 0" \
  "$exe" run -q --packing pull.json
expect_error "dmin0.json: key 'diameter_min': diameters must be finite numbers > 0" \
  "$exe" run -q --packing dmin0.json
/usr/bin/python3 -c 'import json, sys; p = json.load(open(sys.argv[1])); p["build"] = 3
json.dump(p, open("build3.json", "w"))' "$packing"
expect_error "build3.json: key 'build': must be a string" "$exe" run -q --packing build3.json
/usr/bin/python3 -c 'import json, sys; p = json.load(open(sys.argv[1])); p["seed"] = 2**64 - 1
json.dump(p, open("seed_max.json", "w"))' "$packing"
expect_error "seed_max.json: key 'seed': must be a whole number from 0 to 9223372036854775807" \
  "$exe" run -q --packing seed_max.json
expect_error "key 'diameter_max': packing diameters [0.8, 1] differ from the case's [0.8, 1.2]" \
  "$exe" run -q --packing "$packing" --set system.diameter_max=1.2
# A count written -0 is a whole number >= 0 (the JSON library reads it as a signed 0).
/usr/bin/python3 -c 'import json, sys; t = json.dumps(json.load(open(sys.argv[1])))
open("minus0.json", "w").write(t.replace("\"displacement_warnings\": 0", "\"displacement_warnings\": -0"))' "$packing"
checks=$((checks + 1))
if ! grep -q '"displacement_warnings": -0' minus0.json ||
   ! "$exe" run -q --packing minus0.json --set shear.duration=0.2 --no-analyze -o minus0 > out.txt 2>&1; then
  echo "FAIL: a packing with a count written -0 refused:"; cat out.txt; fails=$((fails + 1))
fi
# A cut JSON file: where it ends, in words of the program's messages (no library tag).
head -c 2000 "$packing" > cut.json
expect_error "cut.json: not valid JSON: parse error at line" "$exe" run -q --packing cut.json
if grep -q "json.exception" err.txt; then
  echo "FAIL: the JSON library's tag in: $(cat err.txt)"; fails=$((fails + 1))
fi

# What a killed write of a packing left (NAME.tmp.PID) is removed when the packing is written
# again, unless its process still runs (4194305 is above any process number Linux gives); a
# number too long for any process is not a writer's, and is left.
mkdir -p litter && : > litter/p.json.tmp.4194305 && : > "litter/p.json.tmp.$$"
: > litter/p.json.tmp.12345678901234567890123
checks=$((checks + 1))
if ! "$exe" prepare -q --set system.n=37 --set system.height=6 -o litter/p.json > /dev/null \
  2> err.txt || [ -e litter/p.json.tmp.4194305 ] || [ ! -e "litter/p.json.tmp.$$" ] ||
  [ ! -e litter/p.json.tmp.12345678901234567890123 ] || [ ! -s litter/p.json ]; then
  echo "FAIL: a dead writer's packing temporary: $(ls litter) $(cat err.txt)"; fails=$((fails + 1))
fi

# The packing cache (`packings/`, named by the preparation's settings) says when another build
# prepared the packing it reuses, and is silent when this build did.
small=(run -q --no-analyze --set system.n=37 --set system.height=6 --set shear.duration=0.1 --threads 1)
mkdir cache && (cd cache && "$exe" "${small[@]}" -o first > /dev/null && "$exe" "${small[@]}" -o same > same.txt)
status=$?
checks=$((checks + 1))
if [ $status -ne 0 ] || grep -q "prepared by" cache/same.txt; then
  echo "FAIL: the cache's own build was reported as another's"; cat cache/same.txt; fails=$((fails + 1))
fi
/usr/bin/python3 - cache/packings/*.json << 'EOF_PY'
import json, sys
p = json.load(open(sys.argv[1]))
p["build"] = "cdshear 0.0.1 (commit 000000000000; Release build, instruction set none)"
json.dump(p, open(sys.argv[1], "w"))
EOF_PY
(cd cache && "$exe" "${small[@]}" -o other > other.txt)
checks=$((checks + 1))
grep -qF "prepared by cdshear 0.0.1 (commit 000000000000" cache/other.txt ||
  { echo "FAIL: a packing of another build reused without a word"; cat cache/other.txt; fails=$((fails + 1)); }
# A packing that records no build (written before packings named theirs) is not called another's.
/usr/bin/python3 - cache/packings/*.json << 'EOF_PY'
import json, sys
p = json.load(open(sys.argv[1]))
del p["build"]
json.dump(p, open(sys.argv[1], "w"))
EOF_PY
(cd cache && "$exe" "${small[@]}" -o unrecorded > unrecorded.txt)
status=$?
checks=$((checks + 1))
if [ $status -ne 0 ] || grep -q "prepared by\|reusing" cache/unrecorded.txt; then
  echo "FAIL: a packing without a build was called another build's, or named under -q"
  cat cache/unrecorded.txt; fails=$((fails + 1))
fi
printf '[campaign]\nname = "w"\nsystems = [1]\nvelocities = [0.5]\nseeds = [1]\nduration = 1.0\n[campaign.packing]\n1 = "%s"\n' \
  "$work/v7.json" > foreign.toml
expect_status2 "foreign.toml: key 'campaign.packing.1': $work/v7.json: key 'version'" \
  "$exe" sweep --dry-run foreign.toml

# Errors name their true source: the --set that gave the value, never the case file.
expect_error "--set shear.velocity=abc: key 'shear.velocity': must be a number" \
  "$exe" run -q --set shear.velocity=abc
expect_error "'0.5.3' is not a TOML value" "$exe" run -q --set shear.velocity=0.5.3
expect_error "the value holds a line break" "$exe" run -q --set $'shear.velocity=0.5\nshear.duration=3'
expect_error "is a directory, not a TOML file" "$exe" run -q "$work"
mkfifo fifo.toml && expect_error "is not a regular file" "$exe" run -q fifo.toml
expect_error "must be > 0 and <= 1e+100, got -1e+300" "$exe" run -q --set shear.normal_stress=-1e300

# A checkpoint copied from another run (other V) is refused, naming what differs.
"$exe" run -q --no-analyze --packing "$packing" -V 1 --set shear.duration=0.2 -o other > /dev/null
cp done/checkpoint.cbor other/checkpoint.cbor
expect_error "key 'case.velocity': the checkpoint is of a run with velocity = 0.5" \
  "$exe" run -q --no-analyze --resume other --set shear.duration=0.4
# So is a case.toml whose initial velocity was edited after the run started from another one.
cp -r done started_linear
sed -i "s/^initial_velocity = .*/initial_velocity = 'rest'/" started_linear/case.toml
expect_error "key 'case.initial_velocity': the checkpoint is of a run with initial_velocity = \"linear\"" \
  "$exe" run -q --no-analyze --resume started_linear --set shear.duration=0.4

# One rule for every command that writes a folder: a folder holding anything is refused.
mkdir -p mine && echo "my notes" > mine/notes.txt
expect_error "mine: already holds results (notes.txt)" "$exe" run -q --no-analyze \
  --packing "$packing" --set shear.duration=0.2 -o mine
expect_error "done: already holds results" "$exe" scene "$scene" -o done
"$exe" scene -q "$scene" -o done --force > /dev/null 2>&1 || true
test -f mine/notes.txt || { echo "FAIL: a refused run touched mine/"; fails=$((fails + 1)); }
checks=$((checks + 1))
# An empty folder, or one holding only the lock file a killed preparation leaves, is free.
mkdir -p empty_dir lock_only && touch lock_only/.cdshear.lock
for d in empty_dir lock_only; do
  checks=$((checks + 1))
  "$exe" run -q --no-analyze --packing "$packing" --set shear.duration=0.2 -o "$d" > out.txt 2>&1 ||
    { echo "FAIL: a run refused the free folder $d"; cat out.txt; fails=$((fails + 1)); }
done

# An empty file or folder argument (an unset shell variable) is refused, never read as the
# option's absence (which would start the default job instead of a resume).
# (timeout: a regression would start the default job or preparation, minutes long)
expect_status2 "--resume: is empty" timeout 60 "$exe" run -q --resume ""
expect_status2 "--output: is empty" timeout 60 "$exe" run -q --no-analyze --packing "$packing" -o ""
expect_status2 "--packing: is empty" timeout 60 "$exe" run -q --packing ""
expect_status2 "--output: is empty" timeout 60 "$exe" prepare -q -o ""
expect_status2 "run_dir: is empty" timeout 60 "$exe" analyze ""
expect_status2 "campaign_dir: is empty" timeout 60 "$exe" report ""
expect_status2 "file: is empty" timeout 60 "$exe" scene "" -o empty_scene
test -e empty_scene && { echo "FAIL: an empty argument wrote a folder"; fails=$((fails + 1)); }
checks=$((checks + 1))
# An output folder that cannot be made names the true cause, not an "unexpected error".
echo "a file" > plain_file
expect_status2 "plain_file/sub: cannot create the output folder: Not a directory" \
  "$exe" run -q --no-analyze --packing "$packing" --set shear.duration=0.2 -o plain_file/sub
ln -s "$work/nowhere/folder" dangling
expect_status2 "dangling: is a symbolic link to $work/nowhere/folder, which does not exist" \
  "$exe" run -q --no-analyze --packing "$packing" --set shear.duration=0.2 -o dangling
# The time-step warning prints a tiny displacement bound as given, not as 0.000000.
"$exe" run -q --no-analyze --packing "$packing" --set measure.enabled=false \
  --set shear.duration=0.01 --set step.displacement_bound=1e-300 -o tiny_bound > out.txt 2>&1
checks=$((checks + 1))
grep -q "above step.displacement_bound = 1e-300;" out.txt ||
  { echo "FAIL: the tiny bound's warning: $(cat out.txt)"; fails=$((fails + 1)); }
grep -q "warning: packing" out.txt &&
  { echo "FAIL: a warning of the packing's own stress: $(cat out.txt)"; fails=$((fails + 1)); }
# A prepared packing too narrow for a shear cell is refused before it is cached, and leaves no
# packings/ folder behind.
mkdir -p narrow
expect_status2 "the prepared packing (L_x" \
  env -C narrow "$exe" run -q --set system.n=1 --set system.height=1.01 -o imp
checks=$((checks + 1))
[ -z "$(ls -A narrow)" ] || { echo "FAIL: a refused narrow cell left $(ls -A narrow)"; fails=$((fails + 1)); }
# So is one that `prepare` makes (a campaign's packings come from it): to the cache, to a new
# folder (removed) and to a folder of the user's (kept, empty).
expect_status2 "the prepared packing (L_x" \
  env -C narrow "$exe" prepare -q --set system.n=1 --set system.height=1.01
expect_status2 "not written to new/p.json" \
  env -C narrow "$exe" prepare -q --set system.n=1 --set system.height=1.01 -o new/p.json
mkdir -p narrow/mine
expect_status2 "makes no shear cell" \
  env -C narrow "$exe" prepare -q --set system.n=1 --set system.height=1.01 -o mine/p.json
checks=$((checks + 1))
[ "$(ls -A narrow)" = mine ] && [ -z "$(ls -A narrow/mine)" ] ||
  { echo "FAIL: prepare's refused narrow cell left $(ls -AR narrow)"; fails=$((fails + 1)); }
# A packing compressed under another piston stress than the case's preparation is named.
"$exe" run -q --no-analyze --packing "$packing" --set measure.enabled=false \
  --set shear.duration=0.01 --set preparation.piston_stress=0.3 -o other_stress > out.txt 2>&1
checks=$((checks + 2))
grep -q "was compressed under piston_stress 0.25, the case's preparation.piston_stress is 0.3" \
  out.txt || { echo "FAIL: no piston-stress warning: $(cat out.txt)"; fails=$((fails + 1)); }
# A blow-up that a resume goes past leaves no stale blowup_state.json behind; its message prints
# a tiny bound as given.
"$exe" run -q --no-analyze --packing "$packing" --set shear.duration=0.1 -o blown > /dev/null
rc=0; "$exe" run -q --no-analyze --resume blown --set shear.duration=0.2 \
  --set step.abort_overlap=1e-9 > blown.out 2>&1 || rc=$?
checks=$((checks + 1))
{ [ $rc -eq 3 ] && test -f blown/blowup_state.json && grep -q "exceeds abort_overlap 1e-09" blown.out; } ||
  { echo "FAIL: no blow-up (exit $rc) or no state, or the bound misprinted: $(cat blown.out)"; fails=$((fails + 1)); }
"$exe" run -q --no-analyze --resume blown --set shear.duration=0.2 --set step.abort_overlap=0.1 \
  > /dev/null 2>&1 || { echo "FAIL: the resume past the blow-up failed"; fails=$((fails + 1)); }
checks=$((checks + 1))
test ! -e blown/blowup_state.json || { echo "FAIL: a stale blowup_state.json"; fails=$((fails + 1)); }
# A fast start is no blow-up: at V = 30 the first collisions launch the walls, which fly apart
# past five times the nominal L_y of 20 within 6 t (the run's load brings them back hundreds of t
# later), and the run goes on to its end.
rc=0; "$exe" run -q --no-analyze --packing "$packing" -V 30 --set shear.duration=6 \
  --set measure.enabled=false --threads 1 -o dilated > dilated.out 2>&1 || rc=$?
checks=$((checks + 1))
height=$(/usr/bin/python3 -c 'import json, sys; w = json.load(open(sys.argv[1]))["walls"]
print(w[1]["point"][1] - w[0]["point"][1])' dilated/final_state.json 2> /dev/null || echo 0)
{ [ $rc -eq 0 ] && test ! -e dilated/blowup_state.json &&
  /usr/bin/python3 -c 'import sys; sys.exit(float(sys.argv[1]) <= 100)' "$height"; } ||
  { echo "FAIL: a fast start (exit $rc, L_y $height): $(cat dilated.out)"; fails=$((fails + 1)); }
# A --set key must be a case key: nothing in it can be read as part of its value.
expect_status2 "has an empty part" "$exe" run -q --set ".=1"
expect_status2 "is not a case key" "$exe" run -q --set "shear velocity=1"

# A path that cannot be followed is bad input, named, for every command that takes one.
ln -s loop_b loop_a; ln -s loop_a loop_b
expect_status2 "loop_a: Too many levels of symbolic links" "$exe" scene loop_a -o never
expect_status2 "loop_a: Too many levels of symbolic links" "$exe" run -q loop_a
expect_status2 "loop_a: Too many levels of symbolic links" "$exe" run -q --packing loop_a
expect_status2 "loop_a: Too many levels of symbolic links" "$exe" settings loop_a
expect_status2 "loop_a: Too many levels of symbolic links" "$exe" sweep loop_a

# Two run.h5 files behind a correct seal that the HDF5 library (Debian's 1.10.8) cannot read: one
# byte of a small synthetic run changed (tests/data/README.md). One crashes it (SIGSEGV), one
# makes it loop for ever; `analyze` names the folder and the cause, exit 2, in seconds.
mkdir -p crash hang
cp "$data/hdf5_crash_run.h5" crash/run.h5
cp "$data/hdf5_hang_run.h5" hang/run.h5
expect_status2 "crash: the analysis (\`analyze\`) died of signal 11" "$exe" analyze crash
expect_status2 "hang: the analysis (\`analyze\`) gave up reading run.h5 after its time limit" \
  env CDSHEAR_READ_TIME_LIMIT=3 "$exe" analyze hang

# A dotted key of thousands of parts is refused before the TOML library builds its tables by
# recursion (which overflowed the stack), by every reader of TOML files.
/usr/bin/python3 -c "print('a' + '.a' * 40000 + ' = 1')" > deep.toml
expect_status2 "deep.toml: line 1 holds a dotted key of more than 16 parts" "$exe" settings deep.toml
expect_status2 "deep.toml: line 1 holds a dotted key of more than 16 parts" "$exe" scene deep.toml -o never
expect_status2 "deep.toml: line 1 holds a dotted key of more than 16 parts" "$exe" sweep deep.toml --dry-run -o never
# Time steps too short for the solver's sums: given, or made by the auto rule.
expect_error "key 'step.dt': must be >= 1e-100, got 1e-170" \
  "$exe" run -q --packing "$packing" --set step.dt=1e-170 --set shear.duration=3e-170
expect_error "key 'step.dt': \"auto\" gives min(dt_max, displacement_per_step / V)" \
  "$exe" run -q --packing "$packing" --set step.displacement_per_step=1e-120 --set shear.duration=1e-115 \
  --set measure.enabled=false
expect_error "key 'step.dt': must be at least 1e-100, got 4.94066e-324" \
  "$exe" scene "$scene" --set step.dt=5e-324 --set run.duration=1e-323 -o never
# A scene whose series would hold no row.
expect_error "key 'run.sample_every': is 1000000000 steps, more than the run's" \
  "$exe" scene "$scene" --set run.sample_every=1000000000 -o never
# A packing disk far outside its period (its wrap would place it outside the cell).
/usr/bin/python3 -c "
import json, sys
d = json.load(open(sys.argv[1])); d['disks_xyr'][0][0] = 1e20
json.dump(d, open('far_packing.json', 'w'))" "$packing"
expect_error "key 'disks_xyr[0]': x = 1e+20 is more than a million periods" \
  "$exe" run -q --packing far_packing.json --set measure.enabled=false -o never
# A sweep's progress lines: below a second they would come at every poll of the runs.
expect_error "--progress-every: must be 0 (no progress lines) or at least 1 s, got 1e-300" \
  "$exe" sweep no_campaign.toml --progress-every 1e-300
# Snapshots: a typo's count of them.
expect_error "key 'output.snapshot_interval': 1e+299 snapshots over the duration 0.1" \
  "$exe" run -q --packing "$packing" --set shear.duration=0.1 --set output.snapshot_interval=1e-300 -o never
test ! -e never || { echo "FAIL: a refused run left never/"; fails=$((fails + 1)); }
# An interval longer than the run is a resume's to reach: this leg writes no snapshot, so it
# makes no snapshots/ and does not name one.
checks=$((checks + 1))
if ! "$exe" run --packing "$packing" --set shear.duration=0.02 --set output.snapshot_interval=1 \
     --set measure.enabled=false --no-analyze -o short_leg > out.txt 2> err.txt ||
   [ -e short_leg/snapshots ] || grep -q "snapshots" out.txt; then
  echo "FAIL: a leg shorter than the snapshot interval:"; cat out.txt err.txt; fails=$((fails + 1))
fi
# `prepare` writes to a case's preparation.packing, where `run` of that case looks for it: its
# destination is checked there before anything is prepared.
printf '[preparation]\npacking = "a_folder"\n' > own_packing.toml
expect_error "a_folder: exists and is not a regular file" "$exe" prepare -q own_packing.toml

# scripts/paired_check.sh: a run given twice (another path), and a side kept from another
# DURATION (checked before anything is resumed; 20.0 and 20 are one DURATION)
paired="$(cd "$(dirname "$0")/../scripts" && pwd)/paired_check.sh"
mkdir -p paired_run && touch paired_run/case.toml paired_run/checkpoint.cbor paired_run/run.h5
expect_status2 "./paired_run/: given twice (as paired_run): each run pairs once" \
  env CDSHEAR="$exe" SET_B="solver.relaxation=1.4" "$paired" paired_out 4 paired_run ./paired_run/
mkdir -p paired_out/1_paired_run/a
printf '%s \n' "$exe" > paired_out/1_paired_run/a/paired_check.side
echo 20 > paired_out/1_paired_run/a/paired_check.duration
touch paired_out/1_paired_run/a/paired_check.done
mkdir -p paired_out/1_paired_run/b && echo other > paired_out/1_paired_run/b/paired_check.side
touch paired_out/1_paired_run/b/paired_check.done
expect_status2 "paired_out/1_paired_run/a: made for DURATION 20, not 4: give a new OUT_DIR" \
  env CDSHEAR="$exe" SET_B="solver.relaxation=1.4" "$paired" paired_out 4 paired_run
expect_status2 "paired_out/1_paired_run/b: made by other, not" \
  env CDSHEAR="$exe" SET_B="solver.relaxation=1.4" "$paired" paired_out 20.0 paired_run

echo "cli_errors_test: $((checks - fails)) passed, $fails failed"
[ $fails -eq 0 ]
