#!/usr/bin/env bash
# Mutation probes: applies each one-line mutation of mutations.txt to a copy of the committed
# tree, rebuilds, runs the test programs, and reports whether the suite caught it (a test
# failed). Not part of CI (about 2 minutes per mutation on 2 cores); run it after changing the
# engine or the tests, and report the score. Usage: tests/mutation/run_mutations.sh [WORKDIR]
set -uo pipefail
repo="$(cd "$(dirname "$0")/../.." && pwd)"
work="${1:-/tmp/cdshear_mutations}"
rm -rf "$work"; mkdir -p "$work/src"
git -C "$repo" archive HEAD | tar -x -C "$work/src"
cmake -S "$work/src" -B "$work/build" -G Ninja -DCMAKE_BUILD_TYPE=Release > /dev/null
cmake --build "$work/build" -j "$(nproc)" > /dev/null || { echo "baseline build failed"; exit 2; }
packing="$work/build/fixtures/system1_packing.json"
mkdir -p "$(dirname "$packing")"
# Prepared by the build under test (about 1.5 minutes): a packing cached in packings/ may come from
# a build that numbered its disks otherwise, and the tests check the current preparation's.
"$work/build/cdshear" prepare -q --system 1 -o "$packing" > /dev/null
run_tests() {
  "$work/build/tests/cdshear_tests" > "$work/log.txt" 2>&1 &&
  "$work/build/tests/cdshear_shear_tests" >> "$work/log.txt" 2>&1
}
run_tests || { echo "the unmutated suite fails: fix that first"; exit 2; }
caught=0; total=0
while IFS= read -r line; do
  [[ -z "$line" || "$line" == \#* ]] && continue
  file=${line%% @@ *}; rest=${line#* @@ }
  from=${rest%% @@ *}; rest=${rest#* @@ }
  to=${rest%% @@ *}; what=${rest#* @@ }
  total=$((total + 1))
  target="$work/src/$file"
  cp "$target" "$target.orig"
  FROM="$from" TO="$to" /usr/bin/python3 - "$target" <<'PY'
import os, sys
p = sys.argv[1]; s = open(p).read(); a, b = os.environ["FROM"], os.environ["TO"]
if s.count(a) != 1: sys.exit(f"mutation text found {s.count(a)} times in {p}")
open(p, "w").write(s.replace(a, b))
PY
  if [ $? -ne 0 ]; then echo "SKIP  $what (text not found)"; mv "$target.orig" "$target"; continue; fi
  if ! cmake --build "$work/build" -j "$(nproc)" > /dev/null 2>&1; then
    echo "BUILD $what (does not compile: counts as caught)"; caught=$((caught + 1))
  elif run_tests; then
    echo "MISSED $what"
  else
    failed=$(grep -c '^\[  FAILED  \] [A-Za-z]' "$work/log.txt")
    echo "CAUGHT $what ($failed failing tests)"; caught=$((caught + 1))
  fi
  mv "$target.orig" "$target"
done < "$repo/tests/mutation/mutations.txt"
cmake --build "$work/build" -j "$(nproc)" > /dev/null 2>&1
echo "mutation score: $caught of $total caught"
