#!/usr/bin/env bash
# Configures the sanitizer build tree that scripts/test.sh and scripts/fuzz.sh share
# (docs/development/reliability.md): clang, -O1, AddressSanitizer everywhere and UBSan on the project's libraries and
# programs (DBACOV_SANITIZE, top-level CMakeLists.txt), the libFuzzer targets with coverage feedback
# from the libraries (DBACOV_BUILD_FUZZERS), unity builds, no benchmarks.
# Usage: scripts/sanitizer_tree.sh DIR [ON|OFF]   (the second argument: build the test suites too;
# default ON). A DIR configured otherwise (another compiler, no sanitizers) is configured anew.
set -euo pipefail
cd "$(dirname "$0")/.."
dir=$1
tests=${2:-ON}
cache=$dir/CMakeCache.txt
if [ -f "$cache" ] && ! { grep -q '^DBACOV_SANITIZE:BOOL=ON' "$cache" &&
  grep -q '^CMAKE_CXX_COMPILER:[A-Z]*=.*clang++' "$cache" &&
  grep -q "^DBACOV_BUILD_TESTS:BOOL=$tests" "$cache"; }; then
  rm -rf "$dir"
fi
source scripts/ccache_env.sh
# -Wno-pass-failed: clang at -O1 declines the pixel kernel's vectorization hints (Release obeys them).
CXX=clang++ cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" \
  -DCMAKE_CXX_FLAGS="-Wno-pass-failed" -DDBACOV_SANITIZE=ON -DDBACOV_BUILD_FUZZERS=ON \
  -DDBACOV_BUILD_TESTS="$tests" -DDBACOV_BUILD_BENCHMARKS=OFF -DDBACOV_UNITY_BUILD=ON \
  -DCMAKE_CXX_COMPILER_LAUNCHER=ccache > /dev/null
