#!/usr/bin/env bash
# Soft-contact DEM (LAMMPS, bench/peers/lammps/in.shear) beside a cdshear campaign: each run of
# the campaign is run again by LAMMPS from the same packing, at the same wall speed and for the
# same time, then `python3 -m cdshear_analysis lammps-compare` pairs every LAMMPS run with its
# namesake and prints the differences in mu_eff (walls), bulk solid fraction and L_y, run by run
# and paired over the seeds of each system and speed (docs/benchmarks.md, "Regime C beside
# LAMMPS").
#
#   bench/peers/lammps_campaign.sh CAMPAIGN_DIR -o DIR [--kappa K] [--jobs N] [--runs "NAME ..."]
#
# CAMPAIGN_DIR: a campaign folder of `cdshear sweep` (its runs' case.toml name the packing, the
# speed and the duration); DIR: one folder per run (packing.data(.vars), lammps/ with series.txt,
# dump.txt and log.lammps, run.json written when LAMMPS has finished); --kappa: LAMMPS' stiffness
# level k_n / sigma_yy (default 2e4, as in "Side by side with LAMMPS"); --jobs: LAMMPS runs at
# once, one core each (default 1); --runs: only these runs. A run with its run.json is not run
# again (one made with another kappa is an error), so the script resumes a stopped series run by
# run (an interrupted LAMMPS run starts over). in.shear holds the physics of docs/model.md: a run
# whose case.toml sets another normal stress, friction, wall mass or initial velocity is refused.
# Environment: LMP (default lmp; Debian's lammps package).
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
die() { echo "lammps_campaign.sh: error: $*" >&2; exit 2; }

[[ $# -ge 1 && "$1" != -h && "$1" != --help ]] ||
  { sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 2; }
campaign="$1"; shift
out="" kappa=2e4 jobs=1 only=""
while [ $# -gt 0 ]; do
  case "$1" in
    -o|--output) [ $# -ge 2 ] || die "$1 needs a value"; out="$2"; shift 2 ;;
    --kappa) [ $# -ge 2 ] || die "$1 needs a value"; kappa="$2"; shift 2 ;;
    --jobs) [ $# -ge 2 ] || die "$1 needs a value"; jobs="$2"; shift 2 ;;
    --runs) [ $# -ge 2 ] || die "$1 needs a value"; only="$2"; shift 2 ;;
    *) die "unknown argument '$1' (see --help)" ;;
  esac
done
[ -d "$campaign/runs" ] || die "'$campaign' is not a campaign folder (no runs/ in it)"
[ -n "$out" ] || die "-o DIR is required"
[[ "$jobs" =~ ^[1-9][0-9]*$ ]] || die "--jobs must be a positive whole number, got '$jobs'"
[[ "$kappa" =~ ^[0-9]+([.][0-9]+)?([eE][-+]?[0-9]+)?$ ]] && awk -v k="$kappa" 'BEGIN{exit !(k >= 100)}' \
  || die "--kappa must be a number of at least 100, got '$kappa'"
lmp="${LMP:-lmp}"
command -v "$lmp" >/dev/null || die "'$lmp' not found (apt-get install lammps)"
python=/usr/bin/python3
mkdir -p "$out"
out="$(cd "$out" && pwd)"
campaign="$(cd "$campaign" && pwd)"

# the value of KEY in case.toml (read as TOML: the first KEY of any table, in file order; a
# number in its shortest form, a string without its quotes); empty where it has none
case_value() {
  "$python" -c 'import sys, tomllib
def find(table):
    for k, v in table.items():
        if isinstance(v, dict):
            found = find(v)
            if found is not None: return found
        elif k == sys.argv[2]: return v
value = find(tomllib.load(open(sys.argv[1], "rb")))
print("" if value is None else value)' "$1" "$2" 2>/dev/null
}
# whether two numbers are equal (awk reads 0.050000000000000003 as 0.05)
same_number() { awk -v a="$1" -v b="$2" 'BEGIN{exit !(a + 0 == b + 0 && a != "")}'; }

one_run() {
  local name="$1" case_file="$campaign/runs/$1/case.toml" dir="$out/$1"
  if [ -f "$dir/run.json" ]; then
    local made
    made="$(sed -n 's/.*"kappa": \([^,]*\),.*/\1/p' "$dir/run.json")"
    same_number "$made" "$kappa" \
      || { echo "$name: $dir/run.json was made with kappa $made, not $kappa" >&2; return 1; }
    echo "$name: done before"; return 0
  fi
  local packing velocity duration key want got
  packing="$(case_value "$case_file" packing)"
  velocity="$(case_value "$case_file" velocity)"
  duration="$(case_value "$case_file" duration)"
  for key in velocity duration; do
    [[ "${!key}" =~ ^[0-9.eE+-]+$ ]] \
      || { echo "$name: $case_file: no number for shear.$key" >&2; return 1; }
  done
  for want in normal_stress=0.25 friction_grain=0.5 friction_wall=0.5 wall_mass=50; do
    key="${want%=*}"; got="$(case_value "$case_file" "$key")"
    [ -z "$got" ] || same_number "$got" "${want#*=}" \
      || { echo "$name: $case_file: $key = $got; in.shear runs ${want#*=} only" >&2; return 1; }
  done
  got="$(case_value "$case_file" initial_velocity)"
  [ -z "$got" ] || [ "$got" = linear ] \
    || { echo "$name: $case_file: initial_velocity = '$got'; in.shear starts linear only" >&2; return 1; }
  # a campaign moved since its runs were made: its own packings/ folder
  [ -f "$packing" ] || packing="$campaign/packings/$(basename "$packing")"
  [ -f "$packing" ] || { echo "$name: packing '$packing' not found" >&2; return 1; }
  rm -rf "$dir"; mkdir -p "$dir/lammps"
  PYTHONPATH="$root/python" "$python" -m cdshear_analysis lammps-data "$packing" \
    -o "$dir/packing.data" >"$dir/convert.log" 2>&1 || { cat "$dir/convert.log" >&2; return 1; }
  local t0 t1
  t0=$(date +%s.%N)
  "$lmp" -in "$root/bench/peers/lammps/in.shear" -screen none -log none \
    -var data "$dir/packing.data" -var vars "$dir/packing.data.vars" -var V "$velocity" \
    -var T "$duration" -var kappa "$kappa" -var out "$dir/lammps" \
    || { echo "$name: LAMMPS failed, see $dir/lammps/log.lammps" >&2; return 1; }
  t1=$(date +%s.%N)
  printf '{"run": "%s", "velocity": %s, "duration": %s, "kappa": %s, "packing": "%s", "lammps_seconds": %s}\n' \
    "$name" "$velocity" "$duration" "$kappa" "$packing" \
    "$(awk -v a="$t0" -v b="$t1" 'BEGIN{printf "%.3f", b - a}')" >"$dir/run.json"
  echo "$name: LAMMPS done ($(awk -v a="$t0" -v b="$t1" 'BEGIN{printf "%.0f", b - a}') s)"
}
export -f one_run case_value same_number
export campaign out kappa lmp python root

names=()
for d in "$campaign"/runs/*/; do
  name="$(basename "$d")"
  [ -f "$d/case.toml" ] || continue
  if [ -n "$only" ] && [[ " $only " != *" $name "* ]]; then continue; fi
  names+=("$name")
done
[ ${#names[@]} -gt 0 ] || die "no run with a case.toml in $campaign/runs"
failed=0 compared=0
printf '%s\0' "${names[@]}" | xargs -0 -n 1 -P "$jobs" bash -c 'one_run "$1"' _ || failed=1
PYTHONPATH="$root/python" "$python" -m cdshear_analysis lammps-compare "$campaign" "$out" \
  || compared=1
[ "$failed" = 0 ] || die "some LAMMPS runs failed (above); the table holds the others"
[ "$compared" = 0 ] || die "lammps-compare failed (above)"
