#!/usr/bin/env bash
# `mpirun -n 3 cdshear sweep` end to end (rank 0 hands out, ranks 1 and 2 run): a tiny campaign
# of system 1 (the fixture's packing, no measurement) finishes every run; a second mpirun redoes
# nothing; a plain `cdshear sweep` on the same folder still works (MPI is only initialized under
# a launcher); bad input exits 2; an mpirun whose ranks get SIGTERM exits 130 with checkpoints,
# and the same command again resumes the interrupted runs and finishes all; a SIGTERM to one
# worker rank stops the whole sweep.
# Usage: sweep_mpi_test.sh MPIEXEC CDSHEAR PACKING WORKDIR
set -euo pipefail
mpiexec=$1; exe=$2; packing=$3; work=$4
rm -rf "$work"; mkdir -p "$work"; cd "$work"
fail() { echo "FAIL: $*"; exit 1; }
mpi() { "$mpiexec" --oversubscribe --allow-run-as-root -n 3 "$@"; }

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

# 1. Three runs on two worker ranks; then the same command again redoes nothing.
campaign three "[0.25, 0.5, 1.0]" 4
mpi "$exe" sweep three.toml -o three > three.out 2>&1 || fail "mpirun exited $?: $(cat three.out)"
for v in 0.25 0.5 1; do
  test -f "three/runs/s1_seed1_V$v/final_state.json" || fail "run V$v did not finish"
  grep -q '"outcome": "finished"' "three/runs/s1_seed1_V$v/run_info.json" || fail "V$v outcome"
  test -s "three/logs/s1_seed1_V$v.log" || fail "no log for V$v"
done
grep -q "3/3 runs finished" three.out || fail "no final summary: $(cat three.out)"
grep -q "up to 2 at once (MPI" three.out || fail "not run on 2 worker ranks: $(cat three.out)"
[ "$(grep -c "3/3 runs finished" three.out)" -eq 1 ] || fail "more than one rank printed a summary"
sums=$(md5sum three/runs/*/run_info.json)
mpi "$exe" sweep three.toml -o three > again.out 2>&1 || fail "second mpirun exited $?"
grep -q "3 finished earlier" again.out || fail "second mpirun: $(cat again.out)"
[ "$sums" = "$(md5sum three/runs/*/run_info.json)" ] || fail "a finished run was redone"
"$exe" sweep three.toml -o three > plain.out 2>&1 || fail "plain sweep exited $?"
grep -q "3 finished earlier" plain.out || fail "plain sweep: $(cat plain.out)"

# 2. Bad input: the exit code of rank 0 (2), every rank ends.
campaign three "[0.25, 0.5, 2.0]" 4
rc=0; mpi "$exe" sweep three.toml -o three > changed.out 2>&1 || rc=$?
[ $rc -eq 2 ] || fail "a changed campaign under mpirun exited $rc, not 2: $(cat changed.out)"

# 3. SIGTERM to the ranks once both workers' runs have a checkpoint: exit 130, then resume.
campaign long "[0.5, 1.0]" 40
"$mpiexec" --oversubscribe --allow-run-as-root -n 3 "$exe" sweep long.toml -o long > stopped.out 2>&1 & pid=$!
for _ in $(seq 1 1200); do
  test -f long/runs/s1_seed1_V0.5/checkpoint.cbor && test -f long/runs/s1_seed1_V1/checkpoint.cbor &&
    break
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
for v in 0.5 1; do
  test ! -f "long/runs/s1_seed1_V$v/final_state.json" || fail "V$v finished before the SIGTERM"
  test -f "long/runs/s1_seed1_V$v/checkpoint.cbor" || fail "V$v left no checkpoint"
done
mpi "$exe" sweep long.toml -o long > resumed.out 2>&1 || fail "the resumed mpirun exited $?: $(cat resumed.out)"
grep -q "2 to resume" resumed.out || fail "nothing resumed: $(cat resumed.out)"
for v in 0.5 1; do
  test -f "long/runs/s1_seed1_V$v/final_state.json" || fail "V$v did not finish on resume"
  ls long/runs/s1_seed1_V$v/run_info_resume_*.json > /dev/null 2>&1 || fail "V$v not resumed"
done
grep -q "2/2 runs finished" resumed.out || fail "resumed summary: $(cat resumed.out)"
# 4. SIGTERM to one worker rank only (a node going down): the whole sweep stops, 130.
campaign one "[0.5, 1.0]" 40
"$mpiexec" --oversubscribe --allow-run-as-root -n 3 "$exe" sweep one.toml -o one > one.out 2>&1 &
pid=$!
for _ in $(seq 1 1200); do
  test -f one/runs/s1_seed1_V0.5/checkpoint.cbor && test -f one/runs/s1_seed1_V1/checkpoint.cbor &&
    break
  sleep 0.05
done
worker=""
for r in $(pgrep -P $pid || true); do
  grep -qz '^OMPI_COMM_WORLD_RANK=2$' /proc/$r/environ 2>/dev/null && worker=$r
done
[ -n "$worker" ] || fail "no rank 2 under mpirun"
kill -TERM "$worker"
rc=0; wait $pid || rc=$?
[ $rc -eq 130 ] || fail "a SIGTERM to rank 2 only: mpirun exited $rc, not 130: $(cat one.out)"
grep -q "0 failed, 2 interrupted" one.out || fail "rank 2's SIGTERM did not stop all: $(cat one.out)"
for v in 0.5 1; do
  test -f "one/runs/s1_seed1_V$v/interrupted_state.json" || fail "V$v was not stopped cleanly"
done
echo "sweep_mpi_test: runs on worker ranks, nothing redone, exit codes, SIGTERM + resume"
