#!/usr/bin/env bash
# `mpirun -n 3 cdshear sweep` end to end (rank 0 hands out and runs one run itself, ranks 1 and 2
# run one each): a tiny campaign of system 1 (the fixture's packing, no measurement) finishes every
# run, each rank running one (the rank written in each log's first line); a second mpirun redoes
# nothing; a plain `cdshear sweep` on the same folder still works, and `mpirun -n 1` runs a campaign
# as a plain sweep (MPI is only initialized under a launcher with more than one rank); bad input
# exits 2; an mpirun whose ranks get SIGTERM exits 130 with checkpoints (rank 0's own run stopped
# cleanly too), and the same command again resumes the interrupted runs and finishes all (rank 0's
# periodic progress line with an estimate comes before the SIGTERM); under
# `mpirun -n 2`, a SIGTERM to the one worker rank stops the whole sweep, rank 0's run included;
# a job that rank 0 cannot start (its log cannot be opened) fails that job only, as on a worker.
# Usage: sweep_mpi_test.sh MPIEXEC CDSHEAR PACKING WORKDIR
set -euo pipefail
mpiexec=$1; exe=$2; packing=$3; work=$4
rm -rf "$work"; mkdir -p "$work"; cd "$work"
fail() { echo "FAIL: $*"; exit 1; }
mpi() { "$mpiexec" --oversubscribe --allow-run-as-root -n 3 "$@"; }
runs_of_rank() {  # runs_of_rank DIR RANK: how many logs say that rank RANK ran their job
  { grep -l "^==== cdshear sweep starts (MPI rank $2 on " "$1"/logs/*.log || true; } | wc -l
}

campaign() {  # campaign NAME VELOCITIES DURATION
  cat > "$1.toml" <<TOML
[campaign]
name = "$1"
systems = [1]
velocities = $2
duration = $3
analyze = false
packing = { 1 = "$packing" }
[set]
measure.enabled = false
output.checkpoint_interval = 1
TOML
}

# 1. Three runs on three ranks, one each, rank 0's included (each log's first line names its
# rank); then the same command again redoes nothing.
campaign three "[0.25, 0.5, 1.0]" 4
mpi "$exe" sweep three.toml -o three > three.out 2>&1 || fail "mpirun exited $?: $(cat three.out)"
for v in 0.25 0.5 1; do
  test -f "three/runs/s1_seed1_V$v/final_state.json" || fail "run V$v did not finish"
  grep -q '"outcome": "finished"' "three/runs/s1_seed1_V$v/run_info.json" || fail "V$v outcome"
  test -s "three/logs/s1_seed1_V$v.log" || fail "no log for V$v"
done
grep -q "3/3 runs finished" three.out || fail "no final summary: $(cat three.out)"
grep -q "up to 3 at once (MPI: one per rank)" three.out || fail "not on 3 ranks: $(cat three.out)"
for r in 0 1 2; do
  [ "$(runs_of_rank three $r)" -eq 1 ] ||
    fail "rank $r ran $(runs_of_rank three $r) runs, not 1: $(head -qn 1 three/logs/*.log)"
done
[ "$(grep -c "3/3 runs finished" three.out)" -eq 1 ] || fail "more than one rank printed a summary"
sums=$(md5sum three/runs/*/run_info.json)
mpi "$exe" sweep three.toml -o three > again.out 2>&1 || fail "second mpirun exited $?"
grep -q "3 finished earlier" again.out || fail "second mpirun: $(cat again.out)"
[ "$sums" = "$(md5sum three/runs/*/run_info.json)" ] || fail "a finished run was redone"
"$exe" sweep three.toml -o three > plain.out 2>&1 || fail "plain sweep exited $?"
grep -q "3 finished earlier" plain.out || fail "plain sweep: $(cat plain.out)"
# `mpirun -n 1`: a plain sweep, its one rank running every run itself (--jobs honoured).
campaign solo "[0.5, 1.0]" 2
"$mpiexec" --allow-run-as-root -n 1 "$exe" sweep solo.toml -o solo --jobs 2 > solo.out 2>&1 ||
  fail "mpirun -n 1 exited $?: $(cat solo.out)"
grep -q "2 to start; up to 2 at once, " solo.out || fail "mpirun -n 1, not plain: $(cat solo.out)"
grep -q "2/2 runs finished" solo.out || fail "mpirun -n 1: $(cat solo.out)"
[ "$(grep -l "^==== cdshear sweep starts: " solo/logs/*.log | wc -l)" -eq 2 ] ||
  fail "mpirun -n 1: $(head -qn 1 solo/logs/*.log)"

# 2. Bad input: the exit code of rank 0 (2), every rank ends.
campaign three "[0.25, 0.5, 2.0]" 4
rc=0; mpi "$exe" sweep three.toml -o three > changed.out 2>&1 || rc=$?
[ $rc -eq 2 ] || fail "a changed campaign under mpirun exited $rc, not 2: $(cat changed.out)"

# 3. SIGTERM to the ranks once both runs (on ranks 0 and 1) have a checkpoint and rank 0's loop
# has printed a periodic progress line with an estimate: exit 130, both runs stopped cleanly
# (rank 0 forwards the SIGTERM to its own run), no run finished before that line, then resume.
# The runs are long enough (200 t, about 19 s each beside the other rank) for the estimate (from a
# progress.json, written every 2 s, and a tick every 1 s) to come well before they end on a
# machine several times faster; the stop does not wait for more.
campaign long "[0.5, 1.0]" 200
"$mpiexec" --oversubscribe --allow-run-as-root -n 3 "$exe" sweep long.toml -o long \
  --progress-every 1 > stopped.out 2>&1 & pid=$!
estimate='^sweep: after .*: runs done 0/2, running 2, left 0; about .* left$'
for _ in $(seq 1 1200); do
  test -f long/runs/s1_seed1_V0.5/checkpoint.cbor && test -f long/runs/s1_seed1_V1/checkpoint.cbor &&
    grep -q "$estimate" stopped.out && break
  kill -0 $pid 2>/dev/null || break
  sleep 0.05
done
# SIGTERM to every rank, as SLURM's scancel or time limit gives it (Open MPI 4's mpirun itself,
# on SIGTERM, signals the ranks only after odls_base_sigkill_timeout and then exits 1).
ranks=$(pgrep -P $pid || true)
[ -n "$ranks" ] || fail "no rank processes under mpirun"
kill -TERM $ranks 2>/dev/null || true
rc=0; wait $pid || rc=$?
[ $rc -eq 130 ] || fail "the stopped mpirun exited $rc, not 130: $(cat stopped.out)"
grep -q "interrupted: run the same command again" stopped.out || fail "no stop summary: $(cat stopped.out)"
grep -q "$estimate" stopped.out ||
  fail "no periodic progress line with an estimate from rank 0: $(cat stopped.out)"
for v in 0.5 1; do
  test ! -f "long/runs/s1_seed1_V$v/final_state.json" || fail "V$v finished before the SIGTERM"
  test -f "long/runs/s1_seed1_V$v/checkpoint.cbor" || fail "V$v left no checkpoint"
  test -f "long/runs/s1_seed1_V$v/interrupted_state.json" || fail "V$v was not stopped cleanly"
done
[ "$(runs_of_rank long 0)" -eq 1 ] || fail "rank 0 ran no run: $(head -qn 1 long/logs/*.log)"
mpi "$exe" sweep long.toml -o long > resumed.out 2>&1 ||
  fail "the resumed mpirun exited $?: $(cat resumed.out)"
grep -q "2 to resume" resumed.out || fail "nothing resumed: $(cat resumed.out)"
for v in 0.5 1; do
  test -f "long/runs/s1_seed1_V$v/final_state.json" || fail "V$v did not finish on resume"
  ls long/runs/s1_seed1_V$v/run_info_resume_*.json > /dev/null 2>&1 || fail "V$v not resumed"
done
grep -q "2/2 runs finished" resumed.out || fail "resumed summary: $(cat resumed.out)"
# 4. `mpirun -n 2`: rank 0 and the one worker run a run each; a SIGTERM to the worker only (a node
# going down) stops the whole sweep, 130, rank 0's own run with its checkpoint too.
campaign one "[0.5, 1.0]" 40
"$mpiexec" --oversubscribe --allow-run-as-root -n 2 "$exe" sweep one.toml -o one > one.out 2>&1 &
pid=$!
for _ in $(seq 1 1200); do
  test -f one/runs/s1_seed1_V0.5/checkpoint.cbor && test -f one/runs/s1_seed1_V1/checkpoint.cbor &&
    break
  sleep 0.05
done
worker=""
for r in $(pgrep -P $pid || true); do
  grep -qz '^OMPI_COMM_WORLD_RANK=1$' /proc/$r/environ 2>/dev/null && worker=$r
done
[ -n "$worker" ] || fail "no rank 1 under mpirun"
kill -TERM "$worker"
rc=0; wait $pid || rc=$?
[ $rc -eq 130 ] || fail "a SIGTERM to rank 1 only: mpirun exited $rc, not 130: $(cat one.out)"
grep -q "0 failed, 2 interrupted" one.out || fail "rank 1's SIGTERM did not stop all: $(cat one.out)"
for v in 0.5 1; do
  test -f "one/runs/s1_seed1_V$v/interrupted_state.json" || fail "V$v was not stopped cleanly"
done
for r in 0 1; do
  [ "$(runs_of_rank one $r)" -eq 1 ] ||
    fail "mpirun -n 2: rank $r ran $(runs_of_rank one $r) runs, not 1: $(head -qn 1 one/logs/*.log)"
done
# 5. A job that rank 0 cannot start fails that job only, as on a worker: the costliest run (the
# fastest V, dt = 0.002 / V; rank 0 takes the first job) has a symbolic link to itself where its
# log should be (which the sweep's checks before it starts cannot look at, unlike a folder there);
# the other run finishes, the sweep exits 1 with that one failure.
campaign badlog "[0.25, 0.5]" 2
mkdir -p badlog/logs && ln -s s1_seed1_V0.5.log badlog/logs/s1_seed1_V0.5.log  # open fails, root or not
rc=0
"$mpiexec" --oversubscribe --allow-run-as-root -n 2 "$exe" sweep badlog.toml -o badlog \
  > badlog.out 2>&1 || rc=$?
[ $rc -eq 1 ] || fail "a log that cannot be opened: mpirun exited $rc, not 1: $(cat badlog.out)"
grep -q "MPI rank 0: s1_seed1_V0.5: .*s1_seed1_V0.5.log: Too many levels of symbolic links" \
  badlog.out ||
  fail "rank 0 did not report the job it could not start: $(cat badlog.out)"
grep -q "1/2 runs finished (0 earlier), 1 failed, 0 interrupted, 0 not started" badlog.out ||
  fail "rank 0's failed start stopped the sweep: $(cat badlog.out)"
grep -q "failed: s1_seed1_V0.5: exit 1, nothing to resume from" badlog.out ||
  fail "no failure: $(cat badlog.out)"
test -f badlog/runs/s1_seed1_V0.25/final_state.json ||
  fail "V0.25 did not finish: $(cat badlog.out)"
echo "sweep_mpi_test: runs on every rank (rank 0 too), nothing redone, exit codes," \
  "SIGTERM + resume, a job rank 0 cannot start fails alone"
