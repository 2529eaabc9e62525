#!/usr/bin/env bash
# Fuzzes the .npz reader and the snapshot rawlog reader with libFuzzer (tests/fuzz, README
# "Reliability"). Usage: scripts/fuzz.sh [SECONDS] [TARGET...]
#   SECONDS  how long each target runs (default 60; CI runs 60, a longer run: scripts/fuzz.sh 3600)
#   TARGET   npz, rawlog (default both); the targets run in parallel, one per core
# Builds build-fuzz/ (clang, AddressSanitizer + UndefinedBehaviorSanitizer, -fsanitize=fuzzer),
# writes the seed corpus into build-fuzz/corpus/<target>/ (kept between runs, so longer runs build
# on earlier ones) and prints what each target did. A crash, leak, sanitizer report, timeout or
# out-of-memory stops the target; its input is in build-fuzz/artifacts/. Fix the cause, then add
# the input to tests/fuzz/regressions/<target>/: ctest replays it in every build from then on.
# Exit status 0 when every target ran clean, 1 otherwise. Needs clang and libclang-rt-14-dev
# (scripts/setup.sh installs them).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
[ $# -gt 0 ] && shift
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(npz rawlog)

san="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined"
CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g" \
  -DDBACOV_BUILD_TESTS=OFF -DDBACOV_BUILD_BENCHMARKS=OFF -DDBACOV_BUILD_FUZZERS=ON \
  -DCMAKE_CXX_FLAGS="$san -Wno-pass-failed" -DCMAKE_EXE_LINKER_FLAGS="$san" \
  -DCMAKE_SHARED_LINKER_FLAGS="$san" > /dev/null
cmake --build build-fuzz -j"$(nproc)" --target fuzz_seeds "${targets[@]/#/fuzz_}"
build-fuzz/bin/fuzz_seeds build-fuzz/corpus
mkdir -p build-fuzz/artifacts build-fuzz/logs

declare -A pid
for t in "${targets[@]}"; do
  # -rss_limit_mb: libFuzzer's default (2 GiB), which also limits any single allocation.
  build-fuzz/bin/fuzz_"$t" build-fuzz/corpus/"$t" -max_total_time="$seconds" -timeout=10 \
    -rss_limit_mb=2048 -dict=tests/fuzz/"$t".dict -artifact_prefix=build-fuzz/artifacts/"$t"- \
    -print_final_stats=1 > build-fuzz/logs/"$t".log 2>&1 &
  pid[$t]=$!
done
failed=0
for t in "${targets[@]}"; do
  status=0
  wait "${pid[$t]}" || status=$?
  log=build-fuzz/logs/"$t".log
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")
  cov=$(grep -E '^#[0-9]+.*(DONE|cov:)' "$log" | tail -1 | sed -n 's/.*cov: \([0-9]*\) ft: \([0-9]*\) corp: \([^ ]*\).*/cov \1, features \2, corpus \3/p')
  if [ "$status" -eq 0 ]; then
    echo "fuzz: $t: ${runs:-?} inputs in ${seconds} s, ${cov:-?}, no crash"
  else
    failed=1
    echo "fuzz: $t: FAILED (status $status) after ${runs:-?} inputs; log: $log" >&2
    grep -E 'ERROR|SUMMARY|runtime error|artifact' "$log" | head -20 >&2 || true
    echo "fuzz: reproduce with build-fuzz/bin/fuzz_$t build-fuzz/artifacts/$t-*; once fixed, copy" \
         "the input into tests/fuzz/regressions/$t/" >&2
  fi
done
exit "$failed"
