#!/usr/bin/env bash
# Sets everything up (packages + Release build) and runs the whole test suite (ctest over
# GoogleTest). Extra arguments go to ctest (e.g. -R Covariance).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
ctest --test-dir build --output-on-failure -j"$(nproc)" "$@"
