#!/usr/bin/env bash
# Sets everything up (packages + Release build) and runs the whole test suite (ctest over
# GoogleTest) after the source checks (scripts/check_source.sh: clang-format, MRPT only in
# libs/mrpt, no citations) and the documentation build (scripts/docs.sh: mkdocs --strict and
# Doxygen, no warning), then the reliability passes (docs/development/reliability.md):
#   1. the suite in build/ (Release);
#   2. the suite again under AddressSanitizer (everywhere) + UndefinedBehaviorSanitizer (libs/ and
#      apps/) in build-asan/ (clang, -O1, assertions on, benchmarks off; scripts/sanitizer_tree.sh;
#      any sanitizer report fails its test), without the Monte Carlo tests (see below);
#   3. a bounded fuzz run of the .npz, rawlog, text pose-graph and ground-truth readers
#      (scripts/fuzz.sh, built in build-asan/, 60 s of wall time in all: one target per core, in
#      waves).
# --quick (the inner loop): the Release build and its suite without the statistical Monte Carlo
# tests (below); no documentation, sanitizer or fuzz pass. CI runs everything.
# Extra arguments go to both ctest runs (e.g. -R Covariance). DBACOV_TEST_PASSES selects passes
# (default "release asan fuzz"); DBACOV_FUZZ_SECONDS sets the fuzz time (default 60);
# DBACOV_BUILD_DIR the Release build directory (default build).
set -euo pipefail
cd "$(dirname "$0")/.."
passes=${DBACOV_TEST_PASSES:-release asan fuzz}
quick=0
if [ "${1:-}" = "--quick" ]; then
  quick=1
  passes=release
  shift
fi
clock() { date +%s; }
# The Monte Carlo tests repeat, 20 to 100 times, solves whose every code path a single-run test
# also takes (SimulApp, DroidModes, SelfCalibration, ImageFlow.OpenCvFlow...,
# SequenceInformation.Export..., CalibratedSolve.Grossly...); they prove statistics, which the
# Release pass checks. Under the sanitizers they would be half of the suite's time and find
# nothing the single runs do not; --quick leaves them out too.
statistical='^(MonteCarlo|SelfCalibrationMonteCarlo)\.|^ImageFlow\.RealFlowIsOverConfidentUntilSelfCalibrated$'
statistical+='|^SequenceInformation\.PerSnapshotMarginalGraphIsOverConfidentSequenceGraphIsNot$'
statistical+='|^SequenceInformation\.SharedFlowsChainedGaugeSequenceGraphConsistentAndNoLessAccurate$'
statistical+='|^CalibratedSolve\.OverWeighted'  # its single runs: CalibratedSolve's other tests
report() { echo "test.sh: $1 took $(($(clock) - $2)) s" >&2; }

t0=$(clock)
scripts/setup.sh
# Formatting and layout rules first: a violation fails the run before any test (check_source.sh).
scripts/check_source.sh
# The documentation: the site and the C++ reference build without a warning (scripts/docs.sh).
if ((!quick)); then scripts/docs.sh; fi
report "setup + Release build + docs" "$t0"
if [[ " $passes " == *" release "* ]]; then
  t=$(clock)
  exclude=()
  if ((quick)); then exclude=(-E "$statistical"); fi
  ctest --test-dir "${DBACOV_BUILD_DIR:-build}" --output-on-failure -j"$(nproc)" "${exclude[@]}" "$@"
  report "Release tests" "$t"
fi

if [[ " $passes " == *" asan "* ]]; then
  t=$(clock)
  scripts/sanitizer_tree.sh build-asan
  cmake --build build-asan -j"$(nproc)"
  report "sanitizer build" "$t"
  t=$(clock)
  # No runtime suppressions are needed (docs/development/reliability.md); the one compile-time
  # exemption, UBSan's alignment check on MRPT's OpenGL objects, is documented in CMakeLists.txt.
  export ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
  log=build-asan/ctest.log
  status=0
  ctest --test-dir build-asan --output-on-failure -j"$(nproc)" -E "$statistical" "$@" 2>&1 |
    tee "$log" || status=$?
  # LeakSanitizer's own stop-the-world tracer sometimes crashes at a process's exit while other
  # threads are exiting ("Tracer caught signal 11 ... LeakSanitizer has encountered a fatal
  # error": google/sanitizers#1353), which is no finding about our code. Only then, the failed
  # tests run once more and must pass; a leak report or any other failure is never retried.
  if [ "$status" -ne 0 ] && grep -q "LeakSanitizer has encountered a fatal error" "$log" &&
    ! grep -qE "ERROR: (LeakSanitizer: detected|AddressSanitizer)|runtime error:" "$log"; then
    echo "test.sh: LeakSanitizer's tracer crashed (not a leak report); re-running the failed tests" >&2
    status=0
    ctest --test-dir build-asan --output-on-failure --rerun-failed -E "$statistical" "$@" ||
      status=$?
  fi
  [ "$status" -eq 0 ] || exit "$status"
  report "sanitizer tests" "$t"
fi

if [[ " $passes " == *" fuzz "* ]]; then
  t=$(clock)
  # The fuzzers are built in the sanitizer tree (scripts/sanitizer_tree.sh): no second build of
  # the libraries.
  DBACOV_FUZZ_BUILD_DIR=build-asan scripts/fuzz.sh "${DBACOV_FUZZ_SECONDS:-60}"
  report "fuzz build + run" "$t"
fi
report "everything" "$t0"
