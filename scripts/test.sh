#!/usr/bin/env bash
# Installs the dependencies, builds, and runs the whole test suite (what CI runs).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
# setup.sh installed the headless browser: the report's browser test must run, not skip.
export CDSHEAR_REQUIRE_BROWSER=1
ctest --test-dir build --output-on-failure -j "$(nproc)"
# A one-minute fuzzing run over every reader (clang, ASan, UBSan; docs/reliability.md).
scripts/fuzz.sh 60
