#!/usr/bin/env bash
# Builds the libFuzzer target over every reader (clang, AddressSanitizer, UBSan) in
# ./build-fuzz and runs it for SECONDS (default 60) on a copy of fuzz/corpus. Exits non-zero
# when the fuzzer finds a crash, a sanitizer report, an exception other than ConfigError, or a
# hang (an input taking more than 10 s). The long run: scripts/fuzz.sh 3600 (docs/reliability.md).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
CC=clang CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCDSHEAR_FUZZ=ON > /dev/null
cmake --build build-fuzz -j "$(nproc)" --target cdshear_fuzz
mkdir -p build-fuzz/corpus build-fuzz/findings
cp -n fuzz/corpus/* build-fuzz/corpus/ 2>/dev/null || true
# HDF5's own diagnostics are silenced by the reader; its memory is kept until exit (not leaks).
ASAN_OPTIONS=detect_leaks=0 ./build-fuzz/cdshear_fuzz build-fuzz/corpus \
  -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=65536 \
  -artifact_prefix=build-fuzz/findings/ -print_final_stats=1 2>&1 | tail -20
