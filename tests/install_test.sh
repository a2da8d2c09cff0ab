#!/usr/bin/env bash
# `cmake --install` into a temporary prefix and `pip install` into a temporary venv, checked the
# way a user would use them (docs/install.md):
#   1. the prefix holds the executable, the analysis package, examples, campaigns and docs, and
#      nothing is written outside it (install_manifest.txt);
#   2. the installed cdshear names its installed package, runs a short shear run that ends with
#      `analyze` and `plot`, reports a campaign and runs a one-run sweep, all with the installed
#      package;
#   3. the example notebook's code cells run on synthetic runs with the installed package;
#   4. pip installs the package into a venv made with --system-site-packages (Debian's numpy,
#      scipy, matplotlib, h5py), offline, and the venv's Python imports it from there.
# Usage: install_test.sh BUILD_DIR SOURCE_DIR PACKING WORK_DIR
set -euo pipefail
build=$1 src=$2 packing=$3 work=$4
rm -rf "$work"
mkdir -p "$work"
prefix=$work/prefix
fail() { echo "FAIL: $*" >&2; exit 1; }

# 1. The install and what it wrote.
cmake --install "$build" --prefix "$prefix" > "$work/install.log"
manifest=$build/install_manifest.txt
[ -s "$manifest" ] || fail "no $manifest"
while read -r f; do
  case "$f" in "$prefix"/*) ;; *) fail "installed outside the prefix: $f" ;; esac
done < "$manifest"
prefix=$(realpath "$prefix")  # as the installed program sees its own path
pydir=$(ls -d "$prefix"/lib/python3*/dist-packages)
for f in bin/cdshear share/cdshear/examples/shear_system1.toml share/cdshear/examples/analysis.ipynb \
         share/cdshear/campaigns/validation.toml share/cdshear/scenes/box_settle.toml \
         share/doc/cdshear/README.md share/doc/cdshear/model.md; do
  [ -e "$prefix/$f" ] || fail "not installed: $f"
done
[ -f "$pydir/cdshear_analysis/__main__.py" ] || fail "no analysis package in $pydir"
if ls -d "$pydir"/cdshear_analysis/__pycache__ 2> /dev/null; then fail "__pycache__ installed"; fi

# 2. The installed executable uses the installed package.
exe=$prefix/bin/cdshear
unset CDSHEAR_ANALYSIS_DIR PYTHONPATH || true
"$exe" --version > "$work/version.txt"
grep -q "^analysis package: $pydir (install)$" "$work/version.txt" ||
  fail "the installed cdshear does not name its installed package: $(cat "$work/version.txt")"
cd "$work"
"$exe" run -q --threads 1 --system 1 -V 1 --packing "$packing" --set shear.duration=30 \
  --set measure.window=10 -o "$work/campaign/runs/s1_seed1_V1" > "$work/run.log" 2>&1 ||
  fail "installed run (and its analysis) failed: $(tail -5 "$work/run.log")"
[ -s "$work/campaign/runs/s1_seed1_V1/summary.json" ] || fail "no summary.json"
ls "$work"/campaign/runs/s1_seed1_V1/figures/*.png > /dev/null || fail "no figures"
"$exe" report "$work/campaign" > "$work/report.log" 2>&1 || fail "report: $(tail -3 "$work/report.log")"
[ -s "$work/campaign/report/runs.csv" ] || fail "no runs.csv"
cat > "$work/tiny.toml" <<TOML
[campaign]
name = "tiny"
systems = [1]
velocities = [1.0]
duration = 20
packing = { 1 = "$packing" }
[set]
measure.window = 10
TOML
"$exe" sweep "$work/tiny.toml" -o "$work/tiny" --jobs 1 -q > "$work/sweep.log" 2>&1 ||
  fail "installed sweep: $(tail -3 "$work/sweep.log")"
[ -s "$work/tiny/runs/s1_seed1_V1/summary.json" ] || fail "the sweep's run has no summary.json"

# 3. The example notebook, on synthetic runs, with the installed package.
PYTHONPATH=$pydir /usr/bin/python3 - "$work" <<'PY'
import os, sys
from cdshear_analysis.synthetic import write_synthetic_run
from cdshear_analysis.summary import analyze, write_summary
from cdshear_analysis import load_run
work = sys.argv[1]
for V in (0.5, 1.0, 2.0):
    d = os.path.join(work, "nb_campaign", "runs", f"s2_seed1_V{V:g}")
    write_synthetic_run(d, kind="A", duration=800.0, velocity=V)
    write_summary(analyze(load_run(d)), d)
PY
CDSHEAR_EXAMPLE_RUN=$work/nb_campaign/runs/s2_seed1_V1 CDSHEAR_EXAMPLE_CAMPAIGN=$work/nb_campaign \
  PYTHONPATH=$pydir /usr/bin/python3 "$src/tests/run_notebook.py" \
  "$prefix/share/cdshear/examples/analysis.ipynb" > "$work/notebook.log" 2>&1 ||
  fail "the example notebook: $(tail -5 "$work/notebook.log")"

# 4. pip into a venv over Debian's packages, offline, from a copy of the package's source (pip
#    builds in the folder it is given). --no-deps: Debian's h5py carries the distribution name
#    h5py._debian_h5py_serial, so pip would look for "h5py" on an index; the venv then imports
#    Debian's (checked below).
/usr/bin/python3 -m venv --system-site-packages "$work/venv"
cp -r "$src/python" "$work/pysrc"
rm -rf "$work/pysrc/tests"
"$work/venv/bin/pip" install -q --no-build-isolation --no-index --no-deps "$work/pysrc" > "$work/pip.log" 2>&1 ||
  fail "pip install: $(tail -5 "$work/pip.log")"
where=$(cd / && "$work/venv/bin/python" -c "import h5py, scipy, matplotlib, cdshear_analysis
print(cdshear_analysis.__file__)")
case "$where" in "$work/venv/"*) ;; *) fail "the venv imports cdshear_analysis from $where" ;; esac
"$work/venv/bin/cdshear-analysis" analyze "$work/nb_campaign/runs/s2_seed1_V2" --quiet ||
  fail "the venv's cdshear-analysis script"
echo "install test OK: $(du -sh "$prefix" | cut -f1) installed"
