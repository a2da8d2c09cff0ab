#!/usr/bin/env bash
# `cdshear sweep` end to end on a tiny campaign of system 1 (the fixture's packing, no
# measurement, a few time units per run): every run finishes from one packing; a second sweep
# redoes nothing (and refuses a final state or a run folder copied from another run, and takes
# a run killed between its final state and its interrupted state's removal as finished), nor
# does one in a folder kept as git keeps it (summaries, no final states), nor one whose
# progress.json was last written before its end; a sweep stopped by
# SIGTERM exits 130, and
# the next one keeps the finished runs untouched (run_info.json unchanged), resumes the
# interrupted one from its checkpoint and finishes all; a run killed between its last step and
# its analysis is analysed, not run again; a changed campaign for the same folder (or the
# folder's campaign.toml edited by hand) is refused; a longer duration extends finished runs,
# resumes an extension killed before its new final state and reports one that failed before it
# started; `--progress-every` prints a progress line with an
# estimate before any run has finished; a folder that is not a campaign's, or with something
# else where its runs/ folder or a log goes, or runs and no campaign.toml, is refused untouched; a
# run whose log cannot be opened, or whose folder links to files elsewhere, fails alone, and so
# does one whose preparation failed, with its log's error; so do a finished run with neither
# run.h5 nor a summary of its own, and an extension stopped short without its checkpoint; a
# campaign that names the folder's own packing copy keeps it.
# Usage: sweep_test.sh CDSHEAR PACKING WORKDIR
set -euo pipefail
exe=$1; packing=$2; work=$3
rm -rf "$work"; mkdir -p "$work"; cd "$work"
fail() { echo "FAIL: $*"; exit 1; }

campaign() {  # campaign NAME VELOCITIES [DURATION, 4 t unless given]
  cat > "$1.toml" <<TOML
[campaign]
name = "$1"
systems = [1]
velocities = $2
duration = ${3:-4}
analyze = false
packing = { 1 = "$packing" }
[set]
measure.enabled = false
output.checkpoint_interval = 1
TOML
}

# 1. Two runs, two at once, in the default folder campaigns/<name>.
campaign two "[0.25, 1.0]"
"$exe" sweep two.toml --jobs 2 > two.out || fail "sweep two exited $? ($(cat two.out))"
dir=campaigns/two
for v in 0.25 1; do
  test -f "$dir/runs/s1_seed1_V$v/final_state.json" || fail "run V$v did not finish"
  grep -q '"outcome": "finished"' "$dir/runs/s1_seed1_V$v/run_info.json" || fail "V$v outcome"
  test -s "$dir/logs/s1_seed1_V$v.log" || fail "no log for V$v"
done
[ "$(ls "$dir"/packings/*.json | wc -l)" -eq 1 ] || fail "expected one packing, got: $(ls "$dir/packings")"
grep -q "fingerprint" "$dir/campaign.toml" || fail "campaign.toml holds no fingerprint"
grep -q "2/2 runs finished" two.out || fail "no final summary: $(cat two.out)"
sums=$(md5sum "$dir"/runs/*/run_info.json)
"$exe" sweep two.toml > again.out || fail "second sweep exited $?"
grep -q "2 finished earlier" again.out || fail "second sweep: $(cat again.out)"
[ "$sums" = "$(md5sum "$dir"/runs/*/run_info.json)" ] || fail "a finished run was redone"
grep -q '"velocity": 0.25' "$dir/runs/s1_seed1_V0.25/final_state.json" ||
  fail "the final state carries no case identity"
# A final state copied from another run does not pass for this run's end.
cp -r "$dir" swapped
cp swapped/runs/s1_seed1_V1/final_state.json swapped/runs/s1_seed1_V0.25/final_state.json
"$exe" sweep two.toml -o swapped > swapped.out 2>&1 && fail "a swapped final state was accepted"
grep -q "s1_seed1_V0.25: .*final_state.json is of another run (velocity = 1.0, its case.toml says 0.25)" \
  swapped.out || fail "swapped final state: $(cat swapped.out)"
# A finished run's case.toml emptied (or only comments) is named, not read as the defaults.
cp -r "$dir" emptied
printf '# c\n' > emptied/runs/s1_seed1_V1/case.toml
"$exe" sweep two.toml -o emptied > emptied.out 2>&1 && fail "an emptied case.toml was accepted"
grep -q "s1_seed1_V1: .*case.toml: is empty: a run's case.toml holds its whole case" emptied.out ||
  fail "an emptied case.toml: $(cat emptied.out)"
# A whole run folder copied into another run's place is neither skipped nor resumed as that run.
cp -r "$dir" moved
rm -r moved/runs/s1_seed1_V0.25
cp -r moved/runs/s1_seed1_V1 moved/runs/s1_seed1_V0.25
"$exe" sweep two.toml -o moved > moved.out 2>&1 && fail "another run's folder was accepted"
grep -q "s1_seed1_V0.25: .*case.toml is of another run (velocity = 1.0 where the campaign's run has 0.25)" \
  moved.out || fail "another run's folder: $(cat moved.out)"
# A run killed between writing its final state and removing its interrupted_state.json (of the
# same step) is finished, not resumed past its end by every later sweep.
cp -r "$dir" stale
test -f stale/runs/s1_seed1_V1/checkpoint.cbor || fail "the finished run kept no checkpoint"
cp stale/runs/s1_seed1_V1/final_state.json stale/runs/s1_seed1_V1/interrupted_state.json
"$exe" sweep two.toml -o stale > stale.out 2>&1 || fail "a stale interrupted state: $(cat stale.out)"
grep -q "2 finished earlier" stale.out || fail "a stale interrupted state: $(cat stale.out)"
# A run whose last progress.json write failed (it only warns) keeps an earlier "running" line:
# its final state of the file's own end step makes it finished, not resumed past its end.
cp -r "$dir" unwritten
sed -i 's/"state": "finished"/"state": "running"/; s/"step": \([0-9]*\)/"step": 1/' \
  unwritten/runs/s1_seed1_V1/progress.json
grep -q '"step": 1,' unwritten/runs/s1_seed1_V1/progress.json || fail "progress.json not edited"
"$exe" sweep two.toml -o unwritten > unwritten.out 2>&1 ||
  fail "a stale progress file: $(cat unwritten.out)"
grep -q "2 finished earlier" unwritten.out || fail "a stale progress file: $(cat unwritten.out)"

# A run folder that is a symbolic link to a folder elsewhere holding files and no run to resume
# is listed as failed, its files untouched (a new start would replace cdshear's files there); a
# link to a finished run of the campaign's is skipped as finished.
cp -r "$dir" linked
mkdir elsewhere
cp "$dir/runs/s1_seed1_V1/case.toml" "$dir/runs/s1_seed1_V1/progress.json" elsewhere/
echo "my notes" > elsewhere/notes.txt
rm -r linked/runs/s1_seed1_V1 && ln -s "$PWD/elsewhere" linked/runs/s1_seed1_V1
rc=0; "$exe" sweep two.toml -o linked > linked.out 2>&1 || rc=$?
[ $rc -eq 1 ] && grep -q "s1_seed1_V1: .* is a symbolic link to $PWD/elsewhere, which holds files" \
  linked.out || fail "a linked run folder (exit $rc): $(cat linked.out)"
[ "$(ls elsewhere | tr '\n' ' ')" = "case.toml notes.txt progress.json " ] ||
  fail "files at a link's target were touched: $(ls elsewhere)"
rm -r linked/runs/s1_seed1_V1 && mv moved/runs/s1_seed1_V1 moved_V1 &&
  ln -s "$PWD/moved_V1" linked/runs/s1_seed1_V1
"$exe" sweep two.toml -o linked > linked.out 2>&1 || fail "a linked finished run: $(cat linked.out)"
grep -q "2 finished earlier" linked.out || fail "a linked finished run: $(cat linked.out)"
# A folder whose runs/ holds runs and no campaign.toml (deleted) cannot be compared with the
# campaign: refused untouched; --force takes its runs as the campaign's.
cp -r "$dir" unnamed && rm unnamed/campaign.toml
rc=0; "$exe" sweep two.toml -o unnamed > unnamed.out 2>&1 || rc=$?
[ $rc -eq 2 ] && grep -q "unnamed/runs holds 2 run folders and the folder no campaign.toml" \
  unnamed.out && [ ! -e unnamed/campaign.toml ] ||
  fail "runs without a campaign.toml (exit $rc): $(cat unnamed.out)"
"$exe" sweep two.toml -o unnamed --force > unnamed.out 2>&1 ||
  fail "runs without a campaign.toml, --force: $(cat unnamed.out)"
grep -q "warning: --force: .*taken as this campaign's" unnamed.out &&
  grep -q "2 finished earlier" unnamed.out || fail "--force: $(cat unnamed.out)"

# A packing put by hand in a folder's packings/ under another seed's name is refused before any
# run or preparation starts (it would make two seeds one packing).
mkdir -p by_hand/packings && cp "$packing" by_hand/packings/s1_seed2.json
cat > by_hand.toml <<TOML
[campaign]
name = "by_hand"
systems = [1]
seeds = [2]
velocities = [1.0]
duration = 4
analyze = false
TOML
rc=0; "$exe" sweep by_hand.toml -o by_hand > by_hand.out 2>&1 || rc=$?
[ $rc -eq 2 ] && grep -q "s1_seed2.json: it was placed with seed 1, the campaign's run has seed 2" \
  by_hand.out || fail "a packing of another seed (exit $rc): $(cat by_hand.out)"
[ ! -d by_hand/runs ] || [ -z "$(ls by_hand/runs)" ] || fail "a run started on another seed's packing"
# A preparation that fails is reported with its log's error line, and its runs with it.
sed 's/name = "by_hand"/name = "unplaced"/; s/^seeds.*//' by_hand.toml > unplaced.toml
printf '[set]\npreparation.initial_solid_fraction = 0.549\n' >> unplaced.toml
rc=0; "$exe" sweep unplaced.toml > unplaced.out 2>&1 || rc=$?
[ $rc -eq 1 ] &&
  grep -q "s1_seed1_V1: its packing was not prepared, log .*: error: .*could place only" unplaced.out || fail "a failed preparation (exit $rc): $(cat unplaced.out)"

# 1b. A run killed after its last step, before its run_info.json and its analysis were written,
# is not run again (every step is done); a missing summary.json is
# made by `cdshear analyze`.
cat > measured.toml <<TOML
[campaign]
name = "measured"
systems = [1]
velocities = [1.0]
duration = 4
packing = { 1 = "$packing" }
[set]
output.checkpoint_interval = 1
measure.window = 1
TOML
"$exe" sweep measured.toml -o measured > measured.out 2>&1 || fail "measured: $(cat measured.out)"
ended=measured/runs/s1_seed1_V1
test -f $ended/summary.json || fail "the measured run was not analysed"
rm -r $ended/run_info.json $ended/summary.json $ended/figures
state=$(md5sum $ended/final_state.json)
"$exe" sweep measured.toml -o measured > ended.out 2>&1 || fail "ended: $(cat ended.out)"
grep -q "1 finished earlier (1 to analyse)" ended.out || fail "ended run: $(cat ended.out)"
[ "$state" = "$(md5sum $ended/final_state.json)" ] || fail "the ended run was run again"
test -f $ended/summary.json || fail "the ended run was not analysed"
ls $ended/figures/*.png > /dev/null 2>&1 || fail "the ended run's figures were not made"
ls $ended/run_info_resume_*.json > /dev/null 2>&1 && fail "the ended run was resumed"
# Killed during its analysis or its figures: a summary.json cut short, a figure missing.
for damage in "truncate -s 100 $ended/summary.json" \
              "rm $ended/figures/height_solid_fraction.png"; do
  $damage
  "$exe" sweep measured.toml -o measured > damaged.out 2>&1 || fail "damaged: $(cat damaged.out)"
  grep -q "1 finished earlier (1 to analyse)" damaged.out ||
    fail "after '$damage': $(cat damaged.out)"
  /usr/bin/python3 -c "import json, sys; json.load(open(sys.argv[1]))" $ended/summary.json ||
    fail "after '$damage': summary.json not made again"
  test -f $ended/figures/height_solid_fraction.png || fail "after '$damage': figure not made again"
done
# An extension stopped in its analysis keeps the summary of the run's earlier end, or in its
# figures those of the earlier analysis: both are made again.
/usr/bin/python3 -c "import json, sys
summary = json.load(open(sys.argv[1])); summary['case']['duration'] = 2.0
json.dump(summary, open(sys.argv[1], 'w'))" $ended/summary.json
touch -d '2000-01-01' $ended/figures/com_velocity.png
"$exe" sweep measured.toml -o measured > earlier_end.out 2>&1 ||
  fail "earlier end: $(cat earlier_end.out)"
grep -q "1 finished earlier (1 to analyse)" earlier_end.out ||
  fail "a summary of an earlier end: $(cat earlier_end.out)"
grep -q '"duration": 4' $ended/summary.json || fail "the summary of an earlier end was kept"
[ "$(date -r $ended/figures/com_velocity.png +%Y)" != 2000 ] || fail "an old figure was kept"
touch -d '2000-01-01' $ended/figures/snapshot.png
"$exe" sweep measured.toml -o measured > old_figure.out 2>&1 || fail "old: $(cat old_figure.out)"
grep -q "1 finished earlier (1 to analyse)" old_figure.out ||
  fail "a figure older than the summary: $(cat old_figure.out)"
"$exe" sweep measured.toml -o measured > analysed.out 2>&1 || fail "analysed: $(cat analysed.out)"
grep -q "1 finished earlier, 0 to resume" analysed.out ||
  fail "an analysed run analysed again: $(cat analysed.out)"
# A finished run kept as its run.h5 (checkpoint, final state and summary deleted to save space)
# is finished and analysed again, its data untouched; one whose run.h5 is of another run, or
# unfinished with nothing to resume it from, is listed as failed and left as it is.
cp -r measured data_only
rm data_only/runs/s1_seed1_V1/{checkpoint.cbor,final_state.json,summary.json}
data=$(md5sum data_only/runs/s1_seed1_V1/run.h5)
[ -n "$data" ] || fail "the measured run wrote no run.h5"
"$exe" sweep measured.toml -o data_only > data_only.out 2>&1 ||
  fail "run.h5 alone: $(cat data_only.out)"
grep -q "1 finished earlier (1 to analyse)" data_only.out ||
  fail "run.h5 alone: $(cat data_only.out)"
[ "$data" = "$(md5sum data_only/runs/s1_seed1_V1/run.h5)" ] || fail "the run.h5 kept was replaced"
test -f data_only/runs/s1_seed1_V1/summary.json || fail "the run.h5 kept was not analysed"
"$exe" run --packing "$packing" -V 0.5 --set shear.duration=1 --set measure.window=1 -q \
  --no-analyze -o other_run > other_run.out 2>&1 || fail "other run: $(cat other_run.out)"
cp -r data_only swapped_data
rm swapped_data/runs/s1_seed1_V1/summary.json
cp other_run/run.h5 swapped_data/runs/s1_seed1_V1/run.h5
rc=0; "$exe" sweep measured.toml -o swapped_data > swapped_data.out 2>&1 || rc=$?
[ $rc -eq 1 ] &&
  grep -q "s1_seed1_V1: .*run.h5 is of another run (velocity = 0.5, its case.toml says 1" \
  swapped_data.out || fail "another run's run.h5 (exit $rc): $(cat swapped_data.out)"
cp -r data_only unfinished
rm unfinished/runs/s1_seed1_V1/summary.json
printf 'not hdf5' > unfinished/runs/s1_seed1_V1/run.h5
rc=0; "$exe" sweep measured.toml -o unfinished > unfinished.out 2>&1 || rc=$?
[ $rc -eq 1 ] && grep -q "s1_seed1_V1: holds a run's data (run.h5) unfinished or unreadable" \
  unfinished.out || fail "an unreadable run.h5 (exit $rc): $(cat unfinished.out)"
[ "$(cat unfinished/runs/s1_seed1_V1/run.h5)" = "not hdf5" ] ||
  fail "the unreadable run.h5 was replaced"
# Finished, its run.h5 gone, and its summary.json missing or another run's: nothing to analyse
# it again from, so listed as failed (not counted finished) and left as it is.
cp -r measured no_data
rm no_data/runs/s1_seed1_V1/{run.h5,summary.json}
rc=0; "$exe" sweep measured.toml -o no_data > no_data.out 2>&1 || rc=$?
[ $rc -eq 1 ] && grep -q "s1_seed1_V1: finished, but .*summary.json is missing or unreadable, and its run.h5" \
  no_data.out || fail "no summary and no run.h5 (exit $rc): $(cat no_data.out)"
cp -r measured foreign_summary
rm foreign_summary/runs/s1_seed1_V1/run.h5
sed -i 's/"velocity": 1.0/"velocity": 0.5/' foreign_summary/runs/s1_seed1_V1/summary.json
rc=0; "$exe" sweep measured.toml -o foreign_summary > foreign_summary.out 2>&1 || rc=$?
[ $rc -eq 1 ] && grep -q "s1_seed1_V1: finished, but .*summary.json is of another run (velocity = 0.5, its case.toml says 1.0), and its run.h5" \
  foreign_summary.out || fail "another run's summary, no run.h5 (exit $rc): $(cat foreign_summary.out)"
# An analysis that fails: the run is listed as failed and the sweep exits 1; a later sweep whose
# analysis succeeds exits 0.
rm $ended/summary.json
printf '#!/bin/sh\nexit 1\n' > failing_python.sh && chmod +x failing_python.sh
if CDSHEAR_PYTHON="$PWD/failing_python.sh" "$exe" sweep measured.toml -o measured \
     > failed_analysis.out 2>&1; then
  fail "a sweep whose run's analysis failed exited 0: $(cat failed_analysis.out)"
fi
grep -q "s1_seed1_V1: finished, but its analysis failed" failed_analysis.out ||
  fail "the failed analysis not listed: $(cat failed_analysis.out)"
"$exe" sweep measured.toml -o measured > reanalysed.out 2>&1 ||
  fail "the analysis made again: $(cat reanalysed.out)"
# A run that fails: the sweep's account of it gives the run's own error line.
cp -r measured broken
rm broken/runs/s1_seed1_V1/final_state.json
echo "not a checkpoint" > broken/runs/s1_seed1_V1/checkpoint.cbor
"$exe" sweep measured.toml -o broken > broken.out 2>&1 &&
  fail "a run with a damaged checkpoint passed"
grep -q "s1_seed1_V1: exit 2, its checkpoint kept, log .*: error: .*checkpoint.cbor" broken.out ||
  fail "the failed run's error is not in the sweep's account: $(cat broken.out)"

# 1c. A campaign folder as git keeps it (each run's case.toml, run_info*.json and summary.json;
# no final state, run.h5 or checkpoint) counts its runs finished and leaves them untouched; a
# summary of another case does not pass for this run's end.
cp -r measured kept
find kept/runs -type f ! -name case.toml ! -name 'run_info*.json' ! -name summary.json -delete
rm -r kept/runs/*/figures
kept_sums=$(md5sum kept/runs/*/*)
"$exe" sweep measured.toml -o kept > kept.out 2>&1 || fail "kept: $(cat kept.out)"
grep -q "1 finished earlier" kept.out || fail "kept runs: $(cat kept.out)"
[ "$kept_sums" = "$(md5sum kept/runs/*/*)" ] || fail "a run kept as its summary was redone"
sed -i 's/"velocity": 1.0/"velocity": 0.5/' kept/runs/s1_seed1_V1/summary.json
"$exe" sweep measured.toml -o kept > kept2.out 2>&1 && fail "another run's summary was accepted"
grep -q "summary.json is of another run (velocity = 0.5, its case.toml says 1.0)" kept2.out ||
  fail "another run's summary: $(cat kept2.out)"
# The same case, another seed's folder: refused by the folder the summary names.
sed -i 's/"velocity": 0.5/"velocity": 1.0/; s|"run_dir": "\(.*\)/s1_seed1_V1"|"run_dir": "\1/s1_seed2_V1"|' \
  kept/runs/s1_seed1_V1/summary.json
grep -q '"run_dir": ".*/s1_seed2_V1"' kept/runs/s1_seed1_V1/summary.json || fail "run_dir not edited"
"$exe" sweep measured.toml -o kept > kept3.out 2>&1 && fail "another seed's summary was accepted"
grep -q "summary.json is of another run (run_dir .*s1_seed2_V1\")" kept3.out ||
  fail "another seed's summary: $(cat kept3.out)"
# A summary analysed from inside its folder by an older analysis names "." or "..": a name that
# says nothing, so the run is judged by its case alone and kept.
for said in . ..; do
  sed -i "s|\"run_dir\": \"[^\"]*\"|\"run_dir\": \"$said\"|" kept/runs/s1_seed1_V1/summary.json
  grep -q "\"run_dir\": \"$said\"" kept/runs/s1_seed1_V1/summary.json || fail "run_dir not $said"
  "$exe" sweep measured.toml -o kept > kept4.out 2>&1 || fail "run_dir $said: $(cat kept4.out)"
  grep -q "1 finished earlier" kept4.out ||
    fail "a summary naming $said was not kept: $(cat kept4.out)"
done

# A run's log starts with its command line as a shell reads it back: a folder with a space and a
# quote in its name is one word.
campaign quoted "[1.0]" 0.1
"$exe" sweep quoted.toml -o "it's quoted" > quoted.out || fail "sweep quoted exited $?"
line=$(head -n 1 "it's quoted/logs/s1_seed1_V1.log")
eval "set -- ${line#==== cdshear sweep starts: }"
while [ $# -gt 1 ] && [ "$1" != "-o" ]; do shift; done
[ "${2:-}" = "$PWD/it's quoted/runs/s1_seed1_V1" ] || fail "log's command line not quoted: $line"

# A given packing changed in place since the sweep copied it, or a copy recorded as made
# otherwise, is refused naming the copy; --force makes it anew, and the copy is then the file's.
cp "$packing" mine.json
sed "s|$packing|$PWD/mine.json|" quoted.toml > mine.toml
"$exe" sweep mine.toml -o mine > mine.out || fail "sweep mine exited $? ($(cat mine.out))"
grep -q "^copied from $PWD/mine.json$" mine/packings/s1_seed1.source ||
  fail "no record of the copy: $(cat mine/packings/s1_seed1.source)"
sed 's/"seed": 1,/"seed": 1 ,/' "$packing" > mine.json
"$exe" sweep mine.toml -o mine > mine.out 2>&1 && fail "an edited given packing was not noticed"
grep -q "mine/packings/s1_seed1.json: it differs from $PWD/mine.json" mine.out ||
  fail "edited packing: $(cat mine.out)"
"$exe" sweep mine.toml -o mine --force > mine.out 2>&1 || fail "--force: $(cat mine.out)"
grep -q "made anew" mine.out || fail "--force did not say it made the packing anew: $(cat mine.out)"
cmp -s mine.json mine/packings/s1_seed1.json || fail "--force left the old copy"
echo "prepared as n511_other.json" > mine/packings/s1_seed1.source
"$exe" sweep mine.toml -o mine > mine.out 2>&1 && fail "a packing made otherwise was not noticed"
grep -q "it was prepared as n511_other.json, the campaign's run is copied from" mine.out ||
  fail "packing made otherwise: $(cat mine.out)"
# The campaign pointed at the folder's own copy (its original moved away): --force keeps that
# copy, only its record changes; it is never removed.
sed "s|$PWD/mine.json|$PWD/mine/packings/s1_seed1.json|" mine.toml > own.toml
copy_sum=$(md5sum < mine/packings/s1_seed1.json)
"$exe" sweep own.toml -o mine --force > own.out 2>&1 || fail "its own copy: $(cat own.out)"
grep -q "kept, as the campaign's packing" own.out || fail "its own copy: $(cat own.out)"
[ "$copy_sum" = "$(md5sum < mine/packings/s1_seed1.json)" ] || fail "the only copy was lost"
grep -q "^copied from $PWD/mine/packings/s1_seed1.json$" mine/packings/s1_seed1.source ||
  fail "the copy's record: $(cat mine/packings/s1_seed1.source)"

# 2. Three runs one at a time (longest first: V 1, 0.5, 0.25); SIGTERM once the first finished.
# 20 t each (about 1.5 s): the stop must land before the second run ends.
campaign three "[0.25, 0.5, 1.0]" 20
"$exe" sweep three.toml --jobs 1 -o stopped > stopped.out 2>&1 & pid=$!
# The stop lands once the second run (V 0.5) has written its first checkpoint (t = 1 of 20).
for _ in $(seq 1 1200); do
  test -f stopped/runs/s1_seed1_V0.5/checkpoint.cbor && break
  kill -0 $pid 2>/dev/null || break
  sleep 0.05
done
kill -TERM $pid 2>/dev/null || true
rc=0; wait $pid || rc=$?
[ $rc -eq 130 ] || fail "the stopped sweep exited $rc, not 130: $(cat stopped.out)"
done_runs=$(ls stopped/runs/*/final_state.json 2>/dev/null | wc -l)
[ "$done_runs" -ge 1 ] || fail "no run finished before the SIGTERM"
[ "$done_runs" -lt 3 ] || fail "the SIGTERM did not interrupt the sweep (every run had finished)"
test -f stopped/runs/s1_seed1_V1/final_state.json || fail "the longest run (V 1) was not first"
test -f stopped/runs/s1_seed1_V0.5/checkpoint.cbor || fail "the interrupted run left no checkpoint"
finished_sums=$(md5sum stopped/runs/*/final_state.json | sed 's/final_state/run_info/' |
                awk '{print $2}' | xargs md5sum)
"$exe" sweep three.toml --jobs 1 -o stopped > resumed.out 2>&1 ||
  fail "the resumed sweep exited $?: $(cat resumed.out)"
for v in 0.25 0.5 1; do
  test -f "stopped/runs/s1_seed1_V$v/final_state.json" || fail "V$v did not finish on resume"
done
[ "$finished_sums" = "$(echo "$finished_sums" | awk '{print $2}' | xargs md5sum)" ] ||
  fail "a run finished before the SIGTERM was redone"
ls stopped/runs/s1_seed1_V0.5/run_info_resume_*.json > /dev/null 2>&1 ||
  fail "the interrupted run was not resumed from its checkpoint"
grep -q "3/3 runs finished" resumed.out || fail "resumed summary: $(cat resumed.out)"

# 3. A changed campaign for an existing folder is refused, naming what changed.
campaign three "[0.25, 0.5, 2.0]" 20
rc=0; "$exe" sweep three.toml -o stopped > changed.out 2>&1 || rc=$?
[ $rc -eq 2 ] || fail "a changed campaign exited $rc, not 2"
grep -q "campaign.velocities" changed.out || fail "the refusal does not say what changed"
# --dry-run prints the campaign and refuses the folder the same way; with --force it passes.
rc=0; "$exe" sweep three.toml -o stopped --dry-run > dry.out 2> dry.err || rc=$?
[ $rc -eq 2 ] && grep -q "s1_seed1_V2" dry.out && grep -q "campaign.velocities" dry.err ||
  fail "--dry-run on a changed campaign's folder (exit $rc): $(cat dry.out dry.err)"
"$exe" sweep three.toml -o stopped --dry-run --force > dry.out 2>&1 ||
  fail "--dry-run --force: $(cat dry.out)"
# The folder's own campaign.toml edited by hand and swept: its header's fingerprint names the
# change; unedited, it sweeps as before (nothing to do).
cp -r stopped edited
"$exe" sweep edited/campaign.toml -o edited > unedited.out 2>&1 ||
  fail "the folder's own campaign.toml: $(cat unedited.out)"
grep -q "3 finished earlier" unedited.out || fail "unedited record: $(cat unedited.out)"
sed -i 's/\(velocities = \[ *0.25, 0.5, \)1.0/\12.0/' edited/campaign.toml
grep -q "0.5, 2.0" edited/campaign.toml || fail "the test's edit missed: $(cat edited/campaign.toml)"
rc=0; "$exe" sweep edited/campaign.toml -o edited > edited.out 2>&1 || rc=$?
[ $rc -eq 2 ] || fail "a hand-edited campaign.toml exited $rc, not 2: $(cat edited.out)"
grep -q "changed after the sweep wrote it: fingerprint" edited.out ||
  fail "the refusal does not name the edit: $(cat edited.out)"

# 3b. A longer duration (--force) extends the finished runs from their last checkpoint, to the
# state a run asked for the longer duration from the start reaches; an extension stopped before
# its new end is resumed, not taken as finished; a finished run without its checkpoint is
# reported, not started again.
campaign grow "[1.0]"
"$exe" sweep grow.toml -o grown > grow.out 2>&1 || fail "grow: $(cat grow.out)"
sed -i 's/^duration = 4/duration = 6/' grow.toml
"$exe" sweep grow.toml -o grown --force > grown.out 2>&1 || fail "grown: $(cat grown.out)"
grep -q "0 finished earlier, 0 to resume, 1 to extend, 0 to start" grown.out ||
  fail "the longer campaign did not extend the run: $(cat grown.out)"
ls grown/runs/s1_seed1_V1/run_info_resume_*.json > /dev/null 2>&1 || fail "not extended by a resume"
campaign whole "[1.0]" 6
"$exe" sweep whole.toml -o whole > whole.out 2>&1 || fail "whole: $(cat whole.out)"
cmp -s grown/runs/s1_seed1_V1/final_state.json whole/runs/s1_seed1_V1/final_state.json ||
  fail "the extended run differs from the run asked for 6 t from the start"
"$exe" run --resume grown/runs/s1_seed1_V1 --set shear.duration=8 --stop-at 7 -q > stop.out 2>&1 ||
  fail "the stopped extension exited $?: $(cat stop.out)"
# Its interrupted_state.json says it stopped short, even where progress.json is lost.
rm grown/runs/s1_seed1_V1/progress.json
sed -i 's/^duration = 6/duration = 8/' grow.toml
# Without its checkpoint it has nothing to go on from: reported, not taken as finished.
cp -r grown stopped_lost
rm stopped_lost/runs/s1_seed1_V1/checkpoint.cbor
rc=0; "$exe" sweep grow.toml -o stopped_lost --force > stopped_lost.out 2>&1 || rc=$?
[ $rc -eq 1 ] && grep -q "s1_seed1_V1: stopped short of the duration its case.toml asks for" \
  stopped_lost.out || fail "a stopped extension without its checkpoint (exit $rc): $(cat stopped_lost.out)"
"$exe" sweep grow.toml -o grown --force > regrown.out 2>&1 || fail "regrown: $(cat regrown.out)"
grep -q "0 finished earlier, 1 to resume, 0 to start" regrown.out ||
  fail "a stopped extension was not resumed: $(cat regrown.out)"
grep -q '"state": "finished"' grown/runs/s1_seed1_V1/progress.json &&
  grep -q '"duration": 8.0' grown/runs/s1_seed1_V1/progress.json ||
  fail "the extension did not reach 8 t: $(cat grown/runs/s1_seed1_V1/progress.json)"
# An extension killed after it wrote the longer duration into case.toml but before its new final
# state (its progress.json still of the earlier end) is resumed to the state of the longer run.
cp -r grown killed_extension
sed -i 's/^duration = 8.0$/duration = 9.0/' killed_extension/runs/s1_seed1_V1/case.toml
sed 's/^duration = 8/duration = 9/' grow.toml > grow9.toml
"$exe" sweep grow9.toml -o killed_extension --force > killed_extension.out 2>&1 ||
  fail "killed extension: $(cat killed_extension.out)"
grep -q "0 finished earlier, 1 to resume, 0 to start" killed_extension.out ||
  fail "a killed extension was not resumed: $(cat killed_extension.out)"
campaign whole9 "[1.0]" 9
"$exe" sweep whole9.toml -o whole9 > whole9.out 2>&1 || fail "whole9: $(cat whole9.out)"
cmp -s killed_extension/runs/s1_seed1_V1/final_state.json whole9/runs/s1_seed1_V1/final_state.json ||
  fail "the resumed extension differs from the run asked for 9 t from the start"
# An extension that fails before it starts (a damaged checkpoint) is reported as not extended.
cp -r grown damaged_extension
head -c 1000 grown/runs/s1_seed1_V1/checkpoint.cbor > damaged_extension/runs/s1_seed1_V1/checkpoint.cbor
rc=0; "$exe" sweep grow9.toml -o damaged_extension --force > damaged_extension.out 2>&1 || rc=$?
[ $rc -eq 1 ] && grep -q "s1_seed1_V1: not extended: still finished at 8 t where the campaign asks for 9 t" \
  damaged_extension.out || fail "a failed extension (exit $rc): $(cat damaged_extension.out)"
rm grown/runs/s1_seed1_V1/checkpoint.cbor
sed -i 's/^duration = 8/duration = 10/' grow.toml
rc=0; "$exe" sweep grow.toml -o grown --force > lost.out 2>&1 || rc=$?
[ $rc -eq 1 ] || fail "a run that cannot be extended exited $rc, not 1: $(cat lost.out)"
grep -q "s1_seed1_V1: finished at 8 t where the campaign asks for 10 t; extending it needs its checkpoint.cbor" \
  lost.out || fail "the run without its checkpoint: $(cat lost.out)"
test -f grown/runs/s1_seed1_V1/final_state.json || fail "the run without its checkpoint was touched"
# An extension that blew up is reported as blown up, not started again by every sweep.
campaign burst "[1.0]"
"$exe" sweep burst.toml -o burst > burst.out 2>&1 || fail "burst: $(cat burst.out)"
rc=0; "$exe" run --resume burst/runs/s1_seed1_V1 --set shear.duration=6 \
  --set step.abort_overlap=1e-9 -q --no-analyze > blew.out 2>&1 || rc=$?
[ $rc -eq 3 ] && test -f burst/runs/s1_seed1_V1/blowup_state.json ||
  fail "the extension did not blow up (exit $rc): $(cat blew.out)"
sed -i 's/^duration = 4/duration = 6/' burst.toml
sittings=$(ls burst/runs/s1_seed1_V1 | grep -c '^run_info')
rc=0; "$exe" sweep burst.toml -o burst --force > reburst.out 2>&1 || rc=$?
[ $rc -eq 1 ] && grep -q "s1_seed1_V1: blew up in an earlier sweep" reburst.out &&
  [ "$(ls burst/runs/s1_seed1_V1 | grep -c '^run_info')" -eq "$sittings" ] ||
  fail "a blown-up extension (exit $rc): $(cat reburst.out)"

# 4. One sweep per folder: a second one started while the first works there is refused.
campaign long "[0.5]" 400
"$exe" sweep long.toml -o busy > busy.out 2>&1 & pid=$!
for _ in $(seq 1 600); do test -f busy/runs/s1_seed1_V0.5/checkpoint.cbor && break; sleep 0.05; done
rc=0; "$exe" sweep long.toml -o busy > second.out 2>&1 || rc=$?
kill -TERM $pid 2>/dev/null || true
wait $pid || true
[ $rc -eq 2 ] || fail "a second sweep in a busy folder exited $rc, not 2: $(cat second.out)"
grep -q "another sweep" second.out || fail "the refusal does not say why: $(cat second.out)"

# 5. A run longer than the step limit of `cdshear run` is refused before anything starts.
cat > huge.toml <<TOML
[campaign]
name = "huge"
systems = [1]
velocities = [1e-6]
strain = 1e5
packing = { 1 = "$packing" }
TOML
rc=0; "$exe" sweep huge.toml -o huge > huge.out 2>&1 || rc=$?
[ $rc -eq 2 ] || fail "a run beyond the step limit exited $rc, not 2: $(cat huge.out)"
grep -q "campaign.strain" huge.out || fail "the refusal does not name the key: $(cat huge.out)"
test ! -e huge || fail "a refused campaign wrote its folder"
# A wall speed that would not move the walls by a grain in any allowed run is blamed on the
# campaign's velocities, not on [set].
sed -i 's/^velocities = .*/velocities = [1e-9]/; s/^strain = .*/duration = 10/' huge.toml
rc=0; "$exe" sweep huge.toml -o huge > huge.out 2>&1 || rc=$?
[ $rc -eq 2 ] || fail "V = 1e-9 exited $rc, not 2: $(cat huge.out)"
grep -q "key 'campaign.velocities'" huge.out || fail "the refusal does not name the key: $(cat huge.out)"

# A FIFO in a run's log's place is refused naming it (exit 2), not waited on; without it the
# same campaign runs.
campaign fifo "[0.5]"
mkdir -p fifo/logs && mkfifo fifo/logs/s1_seed1_V0.5.log
rc=0; timeout 60 "$exe" sweep fifo.toml -o fifo > fifo.out 2>&1 || rc=$?
[ $rc -eq 2 ] || fail "a FIFO log exited $rc, not 2: $(cat fifo.out)"
grep -q "fifo/logs/s1_seed1_V0.5.log: is not a regular file" fifo.out ||
  fail "the refusal does not name the FIFO: $(cat fifo.out)"
rm fifo/logs/s1_seed1_V0.5.log
# A folder there is refused the same way.
mkdir fifo/logs/s1_seed1_V0.5.log
rc=0; timeout 60 "$exe" sweep fifo.toml -o fifo > fifo.out 2>&1 || rc=$?
[ $rc -eq 2 ] || fail "a folder as a log exited $rc, not 2: $(cat fifo.out)"
grep -q "fifo/logs/s1_seed1_V0.5.log: is a folder in a run's log's place" fifo.out ||
  fail "the refusal does not name the folder: $(cat fifo.out)"
rmdir fifo/logs/s1_seed1_V0.5.log
"$exe" sweep fifo.toml -o fifo > fifo.out 2>&1 || fail "the campaign without the FIFO exited $?"

# A run whose log cannot be opened (a symbolic link to itself, which the checks before the sweep
# starts cannot look at) fails alone: the run started before it goes on to its end, the sweep
# exits 1 with that one failure. V 0.5 is the costlier (more steps), so it starts first.
campaign badlog "[0.25, 0.5]"
mkdir -p badlog/logs && ln -s s1_seed1_V0.25.log badlog/logs/s1_seed1_V0.25.log
rc=0; timeout 120 "$exe" sweep badlog.toml -o badlog --jobs 2 > badlog.out 2>&1 || rc=$?
[ $rc -eq 1 ] || fail "a log that cannot be opened: exited $rc, not 1: $(cat badlog.out)"
grep -q "s1_seed1_V0.25: .*s1_seed1_V0.25.log: Too many levels of symbolic links" badlog.out ||
  fail "the run that could not start is not named with its cause: $(cat badlog.out)"
grep -q "1/2 runs finished (0 earlier), 1 failed, 0 interrupted, 0 not started" badlog.out ||
  fail "the failed start stopped the sweep: $(cat badlog.out)"
grep -q "s1_seed1_V0.25: exit 1, nothing to resume from" badlog.out || fail "no failure: $(cat badlog.out)"
test -f badlog/runs/s1_seed1_V0.5/final_state.json ||
  fail "V0.5 did not finish: $(cat badlog.out)"

# A folder in the lock's place is named as the cause (not "another sweep is working").
campaign locked "[0.5]"
mkdir -p locked/.sweep.lock
rc=0; "$exe" sweep locked.toml -o locked > locked.out 2>&1 || rc=$?
[ $rc -eq 2 ] || fail "a folder as the lock exited $rc, not 2: $(cat locked.out)"
grep -q "locked/.sweep.lock: is a folder in the sweep's lock's place" locked.out ||
  fail "the refusal does not name the lock: $(cat locked.out)"

# A folder that is not a campaign's is refused before anything is written in it: one holding
# the user's own campaign file (`-o .`, with or without --force, would write over it), and one
# holding other files.
mkdir -p own && campaign own "[0.5]" && cp own.toml own/campaign.toml
for force in "" --force; do
  rc=0; (cd own && "$exe" sweep campaign.toml -o . $force) > own.out 2>&1 || rc=$?
  [ $rc -eq 2 ] || fail "-o . onto the campaign file ($force) exited $rc, not 2: $(cat own.out)"
  grep -q "own/campaign.toml: this campaign.toml was not written by a sweep" own.out ||
    fail "the refusal does not name the file: $(cat own.out)"
  cmp -s own.toml own/campaign.toml || fail "the user's campaign file was changed ($force)"
done
[ "$(ls own)" = campaign.toml ] || fail "a refused sweep wrote into the folder: $(ls own)"
mkdir -p foreign && echo keep > foreign/notes.txt
rc=0; "$exe" sweep own.toml -o foreign > foreign.out 2>&1 || rc=$?
[ $rc -eq 2 ] || fail "a foreign folder exited $rc, not 2: $(cat foreign.out)"
grep -q "foreign: the folder holds 'notes.txt' and no campaign.toml of a sweep" foreign.out ||
  fail "the refusal does not name the folder and its file: $(cat foreign.out)"
[ "$(ls foreign)" = notes.txt ] || fail "a refused sweep wrote into a foreign folder"
mkdir -p fifo_campaign && mkfifo fifo_campaign/campaign.toml
rc=0; timeout 60 "$exe" sweep own.toml -o fifo_campaign > fifo_campaign.out 2>&1 || rc=$?
[ $rc -eq 2 ] || fail "a FIFO as campaign.toml exited $rc, not 2: $(cat fifo_campaign.out)"
grep -q "fifo_campaign/campaign.toml: is not a regular file" fifo_campaign.out ||
  fail "the refusal does not name the FIFO: $(cat fifo_campaign.out)"
# A file where the campaign's runs/ folder goes, or a folder where a run's log goes: refused before
# any folder is made or any job starts.
mkdir -p runs_file && touch runs_file/runs
rc=0; "$exe" sweep own.toml -o runs_file > runs_file.out 2>&1 || rc=$?
[ $rc -eq 2 ] || fail "a file named runs exited $rc, not 2: $(cat runs_file.out)"
grep -q "runs_file/runs: the campaign's folder runs/ goes here" runs_file.out ||
  fail "the refusal does not name runs: $(cat runs_file.out)"
[ "$(ls runs_file)" = runs ] || fail "a refused sweep made folders: $(ls runs_file)"
mkdir -p log_folder/logs/s1_seed1_V0.5.log
rc=0; "$exe" sweep own.toml -o log_folder > log_folder.out 2>&1 || rc=$?
[ $rc -eq 2 ] || fail "a folder as a log exited $rc, not 2: $(cat log_folder.out)"
grep -q "log_folder/logs/s1_seed1_V0.5.log: is a folder in a run's log's place" log_folder.out ||
  fail "the refusal does not name the log: $(cat log_folder.out)"
[ ! -e log_folder/packings/s1_seed1.json ] || fail "a refused sweep copied its packing"

# 6. --progress-every: a progress line with runs done / running / left and an estimate of the
# time left from the running runs' logs, before any run has finished; a bad period is refused.
# The runs are long (400 t) and the sweep is stopped once the line is printed, so the check does
# not depend on the machine's speed (the estimate needs a progress.json, written every 2 s).
campaign ticks "[0.5, 1.0]" 400
"$exe" sweep ticks.toml --jobs 2 -o ticks --progress-every 1 > ticks.out 2>&1 & pid=$!
estimate='^sweep: after .*: runs done 0/2, running 2, left 0; about .* left$'
for _ in $(seq 1 1200); do
  grep -q "$estimate" ticks.out && break
  kill -0 $pid 2>/dev/null || break
  sleep 0.05
done
kill -TERM $pid 2>/dev/null || true
rc=0; wait $pid || rc=$?
grep -q "$estimate" ticks.out || fail "no periodic progress line with an estimate: $(cat ticks.out)"
[ $rc -eq 130 ] || fail "ticks: the sweep exited $rc, not 130: $(cat ticks.out)"
! grep -q '^sweep: s1_seed1_V.* finished (' ticks.out ||
  fail "a 400 t run finished before the first estimate: $(cat ticks.out)"
rc=0; "$exe" sweep ticks.toml -o ticks --progress-every -1 > bad_every.out 2>&1 || rc=$?
[ $rc -eq 2 ] || fail "--progress-every -1 exited $rc, not 2: $(cat bad_every.out)"

echo "sweep_test: campaigns run, skip finished runs (analysing one killed before its analysis),"\
  "resume interrupted ones, extend finished ones, refuse changes, a busy folder, a folder that is not"\
  "a campaign's and runs beyond the limits;"\
  "periodic progress lines with an estimate before any run has finished"
