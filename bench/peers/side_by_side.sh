#!/usr/bin/env bash
# Side by side with soft-contact DEM: the same sheared packing with cdshear (Contact
# Dynamics, rigid disks) and with LAMMPS (gran/hooke/history, bench/peers/lammps/in.shear),
# one after the other on the same cores, then one table: wall seconds per simulated time unit of
# each and their ratio, mu_eff (ratio of the time-averaged tangential and normal wall forces)
# and solid fraction over the second half of the run with block-averaging errors (the same
# estimator for both, python/cdshear_analysis/peers.py), LAMMPS' largest overlap in d.
#
#   bench/peers/side_by_side.sh [-T DURATION] [-V VELOCITY] [--kappa K] [--packing FILE] [-o DIR]
#                               [--system N] [--threads N] [--cdshear-set KEY=VALUE]...
#
# -T: simulated time of each run (default 400; about 3 minutes on one core in all);
# --cdshear-set: a case setting of the cdshear run (repeatable), e.g. the coarser time step
# `step.displacement_per_step=0.005` (docs/accuracy.md);
# -V: wall speed (default 0.5); --kappa: LAMMPS' stiffness level k_n / sigma_yy (default 1e4;
# dt = t_c / 50 follows it, so the cost grows as sqrt(kappa));
# --system: the system (docs/model.md section 6) whose shear cell both run (default 1, n = 511; 7
# is n = 5119);
# --threads: cores given to each code (default 1): cdshear's --threads, and LAMMPS as that many
# MPI processes (`mpirun -np N lmp`, domain decomposition; Debian's lammps is built with
# Open MPI);
# --packing: a packing of `cdshear prepare` for that system (default: the one `cdshear run
# --system N` caches in packings/, prepared first if absent: 1.5-2 min for system 1, about
# 10 min on two threads for system 7);
# -o: output folder (default runs/peers/V<V>_T<T>[_s<system>][_j<threads>], refused if it
# exists and is not empty).
# Environment: CDSHEAR (the executable, default build/cdshear, built by scripts/setup.sh if
# absent), LMP (default lmp; Debian's lammps package is installed if missing).
# Outputs in DIR: cdshear/ (a cdshear run folder), lammps/ (series.txt, dump.txt, log.lammps),
# packing.data(.vars), table.txt, table.json, command.txt.
# Wall times are whole processes (start-up, measurement and output included), from `date`.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
cd "$root"

die() { echo "side_by_side.sh: error: $*" >&2; exit 2; }

T=400
V=0.5
kappa=1e4
system=1
threads=1
packing=""
out=""
cd_sets=()
while [ $# -gt 0 ]; do
  case "$1" in
    -T|--duration) [ $# -ge 2 ] || die "$1 needs a value"; T="$2"; shift 2 ;;
    -V|--velocity) [ $# -ge 2 ] || die "$1 needs a value"; V="$2"; shift 2 ;;
    --kappa) [ $# -ge 2 ] || die "$1 needs a value"; kappa="$2"; shift 2 ;;
    --system) [ $# -ge 2 ] || die "$1 needs a value"; system="$2"; shift 2 ;;
    --threads) [ $# -ge 2 ] || die "$1 needs a value"; threads="$2"; shift 2 ;;
    --packing) [ $# -ge 2 ] || die "$1 needs a value"; packing="$2"; shift 2 ;;
    -o|--output) [ $# -ge 2 ] || die "$1 needs a value"; out="$2"; shift 2 ;;
    --cdshear-set) [ $# -ge 2 ] || die "$1 needs KEY=VALUE"; cd_sets+=(--set "$2"); shift 2 ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) die "unknown argument '$1' (see --help)" ;;
  esac
done
positive='^[0-9]+([.][0-9]+)?([eE][-+]?[0-9]+)?$'
[[ "$T" =~ $positive ]] && awk -v t="$T" 'BEGIN{exit !(t >= 20)}' \
  || die "-T must be a number of at least 20 (time units), got '$T'"
[[ "$V" =~ $positive ]] && awk -v v="$V" 'BEGIN{exit !(v > 0)}' \
  || die "-V must be a positive number, got '$V'"
[[ "$kappa" =~ $positive ]] && awk -v k="$kappa" 'BEGIN{exit !(k >= 100)}' \
  || die "--kappa must be a number of at least 100, got '$kappa'"
[[ "$system" =~ ^[1-9][0-9]*$ ]] ||
  die "--system must be a system number of docs/model.md section 6, got '$system'"
[[ "$threads" =~ ^[1-9][0-9]*$ ]] || die "--threads must be a positive whole number, got '$threads'"
[ -z "$packing" ] || [ -f "$packing" ] || die "packing file '$packing' not found"
suffix=""; [ "$system" = 1 ] || suffix="_s$system"; [ "$threads" = 1 ] || suffix="${suffix}_j$threads"
out="${out:-runs/peers/V${V}_T${T}${suffix}}"
if [ -d "$out" ] && [ -n "$(ls -A "$out")" ]; then
  die "output folder '$out' is not empty; give another -o"
fi
mkdir -p "$out/lammps"
out="$(cd "$out" && pwd)"

python=/usr/bin/python3          # Debian's python with numpy and h5py (docs/analysis.md)
[ -x "$python" ] || die "$python not found (run scripts/setup.sh)"
cdshear="${CDSHEAR:-build/cdshear}"
if [ ! -x "$cdshear" ]; then
  [ -z "${CDSHEAR:-}" ] || die "CDSHEAR=$cdshear is not an executable"
  echo "side_by_side.sh: build/cdshear missing, running scripts/setup.sh" >&2
  scripts/setup.sh
fi
lmp="${LMP:-lmp}"
if ! command -v "$lmp" >/dev/null; then
  [ -z "${LMP:-}" ] || die "LMP=$lmp not found"
  echo "side_by_side.sh: LAMMPS missing, installing Debian's lammps package" >&2
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq || die "apt-get update failed"
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq lammps \
    || die "could not install lammps with apt-get"
  command -v "$lmp" >/dev/null || die "lammps installed but '$lmp' not on PATH"
fi

# The packing: the one cdshear caches for the system (a 1-time-unit probe run prepares it if
# needed and names it in its case.toml), unless given.
if [ -z "$packing" ]; then
  echo "side_by_side.sh: finding (or preparing) the system-$system packing" >&2
  "$cdshear" run --system "$system" -V "$V" --set shear.duration=1 --no-analyze -q \
    --threads "$threads" \
    -o "$out/probe" >/dev/null || die "cdshear probe run failed"
  packing="$("$python" -c 'import sys, tomllib
print(tomllib.load(open(sys.argv[1], "rb"))["preparation"]["packing"])' "$out/probe/case.toml")"
  [ -f "$packing" ] || die "cannot find the packing named in $out/probe/case.toml"
  rm -rf "$out/probe"
fi
packing="$(cd "$(dirname "$packing")" && pwd)/$(basename "$packing")"

PYTHONPATH="$root/python" "$python" -m cdshear_analysis lammps-data "$packing" \
  -o "$out/packing.data" >&2 || die "converting $packing to a LAMMPS data file failed"

now() { date +%s.%N; }
cd_cmd=("$cdshear" run --system "$system" -V "$V" --packing "$packing" --set "shear.duration=$T"
        --threads "$threads" -q --no-analyze -o "$out/cdshear" "${cd_sets[@]}")
# LAMMPS on several cores: MPI processes (its OpenMP styles do not cover fix rigid).
mpi=()
if [ "$threads" -gt 1 ]; then
  command -v mpirun >/dev/null || die "--threads $threads needs mpirun (Debian's openmpi-bin)"
  mpi=(mpirun -np "$threads" --bind-to none)
  [ "$(id -u)" -ne 0 ] || mpi+=(--allow-run-as-root)
fi
lmp_cmd=("${mpi[@]}" "$lmp" -in "$root/bench/peers/lammps/in.shear" -screen none -log none
         -var data "$out/packing.data" -var vars "$out/packing.data.vars"
         -var V "$V" -var T "$T" -var kappa "$kappa" -var out "$out/lammps")
printf '%q ' "${cd_cmd[@]}" >"$out/command.txt"; echo >>"$out/command.txt"
printf '%q ' "${lmp_cmd[@]}" >>"$out/command.txt"; echo >>"$out/command.txt"

echo "side_by_side.sh: cdshear, system $system, T = $T, V = $V, $threads thread(s)" >&2
t0=$(now)
"${cd_cmd[@]}" || die "cdshear run failed (see above)"
t1=$(now)
echo "side_by_side.sh: LAMMPS, system $system, T = $T, V = $V, kappa = $kappa, $threads process(es)" >&2
"${lmp_cmd[@]}" || die "LAMMPS failed: see $out/lammps/log.lammps"
t2=$(now)
cd_s=$(awk -v a="$t0" -v b="$t1" 'BEGIN{printf "%.3f", b - a}')
lmp_s=$(awk -v a="$t1" -v b="$t2" 'BEGIN{printf "%.3f", b - a}')
echo "side_by_side.sh: wall seconds: cdshear $cd_s, LAMMPS $lmp_s" >&2

PYTHONPATH="$root/python" "$python" -m cdshear_analysis side-by-side \
  --cdshear-run "$out/cdshear" --lammps-dir "$out/lammps" --duration "$T" \
  --cdshear-seconds "$cd_s" --lammps-seconds "$lmp_s" --json "$out/table.json" \
  | tee "$out/table.txt"
grep -A12 '^Loop time' "$out/lammps/log.lammps" >"$out/lammps/timing.txt" || true
echo "(in $out; LAMMPS' own timing breakdown: $out/lammps/timing.txt)"
