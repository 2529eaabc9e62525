#!/usr/bin/env bash
# Fuzzes the readers with libFuzzer (tests/fuzz, docs/development/reliability.md): the .npz
# reader (npz), the
# snapshot rawlog reader (rawlog), the text pose-graph reader of dba-posegraph (graph) and the
# ground-truth readers of dba-evaluate (ground_truth); and the DROID hook's tensor reader (hook:
# share/droid/tests/fuzz_hook.py, a Python mutational fuzzer, needs python3-torch).
# Usage: scripts/fuzz.sh [SECONDS] [TARGET...]
#   SECONDS  the fuzzing wall time in all (default 60; CI runs 60; a longer run: scripts/fuzz.sh
#            3600). The targets run in parallel, one per core, in waves: each target gets
#            SECONDS / waves, so 4 targets on 2 cores run in two waves of 30 s each, on 4 cores in
#            one wave of 60 s (at least 1 s each). hook runs in the last wave, beside its
#            libFuzzer targets, and adds no wave.
#   TARGET   npz, rawlog, graph, ground_truth, python_snapshot, hook (default all)
# Builds the fuzzers in $DBACOV_FUZZ_BUILD_DIR (default build-fuzz/; scripts/test.sh passes its
# sanitizer tree build-asan/), configured by scripts/sanitizer_tree.sh (clang, AddressSanitizer +
# UndefinedBehaviorSanitizer, -fsanitize=fuzzer), writes the seed corpus into DIR/corpus/<target>/
# (kept between runs, so longer runs build on earlier ones) and prints what each target did. A
# crash, leak, sanitizer report, timeout or out-of-memory stops the target; its input is in
# DIR/artifacts/. Fix the cause, then add the input to tests/fuzz/regressions/<target>/: ctest
# replays it in every build from then on.
# Exit status 0 when every target ran clean, 1 otherwise. Needs clang and libclang-rt-14-dev
# (scripts/setup.sh installs them).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
[ $# -gt 0 ] && shift
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(npz rawlog graph ground_truth python_snapshot hook)
hook=0  # the Python fuzzer: no build, run beside the last wave
libfuzzer=()
for t in "${targets[@]}"; do
  if [ "$t" = hook ]; then hook=1; else libfuzzer+=("$t"); fi
done
targets=("${libfuzzer[@]}")
cores=$(nproc)
waves=$(( (${#targets[@]} + cores - 1) / cores ))
[ "$waves" -ge 1 ] || waves=1
per_target=$(( seconds / waves ))
[ "$per_target" -ge 1 ] || per_target=1

dir=${DBACOV_FUZZ_BUILD_DIR:-build-fuzz}
if [ ${#targets[@]} -gt 0 ]; then
  tests=OFF  # a tree that builds the suites too (scripts/test.sh's) keeps them
  grep -qs '^DBACOV_BUILD_TESTS:BOOL=ON' "$dir/CMakeCache.txt" && tests=ON
  scripts/sanitizer_tree.sh "$dir" "$tests"
  cmake --build "$dir" -j"$(nproc)" --target fuzz_seeds "${targets[@]/#/fuzz_}"
  "$dir"/bin/fuzz_seeds "$dir"/corpus
fi
mkdir -p "$dir"/artifacts "$dir"/logs

# The hook's fuzzer (share/droid/tests/fuzz_hook.py) for SECONDS / waves less torch's start-up,
# in the background; a finding prints its seed and case, which replay it exactly.
hook_pid=
hook_log="$dir"/logs/hook.log
hook_seconds=$(( per_target > 4 ? per_target - 2 : per_target ))
start_hook() {
  if ! /usr/bin/python3 -c 'import numpy, torch' 2>/dev/null; then
    echo "fuzz: hook: skipped (/usr/bin/python3 has no numpy or torch: apt-get install" \
         "python3-torch)"
    hook=0
    return
  fi
  /usr/bin/python3 -B share/droid/tests/fuzz_hook.py --seconds "$hook_seconds" \
    --seed $(( $(date +%s) % 100000 )) > "$hook_log" 2>&1 &
  hook_pid=$!
}
finish_hook() {
  [ -n "$hook_pid" ] || return 0
  status=0
  wait "$hook_pid" || status=$?
  hook_pid=
  summary=$(sed -n 's/^fuzz_hook: seed \([0-9]*\): \([0-9]*\) cases.*(\([0-9]*\)\/s), \([0-9]*\) valid, \([0-9]*\) refused.*/seed \1, \2 cases (\3\/s), \4 valid, \5 refused/p' "$hook_log")
  if [ "$status" -eq 0 ]; then
    echo "fuzz: hook: ${summary:-?} in ${hook_seconds} s, no finding"
  else
    failed=1
    echo "fuzz: hook: FAILED (status $status): ${summary:-?}; log: $hook_log" >&2
    grep -a -A8 'FINDING' "$hook_log" | head -20 >&2 || true
    echo "fuzz: fix the cause, then add the case as a regression test to" \
         "share/droid/tests/test_fuzz_hook.py" >&2
  fi
}

declare -A pid
failed=0
[ ${#targets[@]} -gt 0 ] || { [ "$hook" -eq 0 ] || start_hook; finish_hook; }
for ((first = 0; first < ${#targets[@]}; first += cores)); do
  wave=("${targets[@]:first:cores}")
  [ "$hook" -eq 0 ] || (( first + cores < ${#targets[@]} )) || start_hook
  for t in "${wave[@]}"; do
    # -rss_limit_mb: libFuzzer's default (2 GiB), which also limits any single allocation.
    "$dir"/bin/fuzz_"$t" "$dir"/corpus/"$t" -max_total_time="$per_target" -timeout=10 \
      -rss_limit_mb=2048 -dict=tests/fuzz/"$t".dict -artifact_prefix="$dir"/artifacts/"$t"- \
      -print_final_stats=1 > "$dir"/logs/"$t".log 2>&1 &
    pid[$t]=$!
  done
  for t in "${wave[@]}"; do
    status=0
    wait "${pid[$t]}" || status=$?
    log="$dir"/logs/"$t".log
    runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")
    cov=$({ grep -aE '^#[0-9]+.*(DONE|cov:)' "$log" || true; } | tail -1 |
      sed -n 's/.*cov: \([0-9]*\) ft: \([0-9]*\) corp: \([^ ]*\).*/cov \1, features \2, corpus \3/p')
    if [ "$status" -eq 0 ]; then
      echo "fuzz: $t: ${runs:-?} inputs in ${per_target} s, ${cov:-?}, no crash"
    else
      failed=1
      echo "fuzz: $t: FAILED (status $status) after ${runs:-?} inputs; log: $log" >&2
      grep -aE 'ERROR|SUMMARY|runtime error|artifact' "$log" | head -20 >&2 || true
      echo "fuzz: reproduce with $dir/bin/fuzz_$t $dir/artifacts/$t-*; once fixed, copy" \
           "the input into tests/fuzz/regressions/$t/" >&2
    fi
  done
  finish_hook
done
exit "$failed"
