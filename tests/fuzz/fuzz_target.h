// Shared by the fuzz targets: what a target may throw, and the engine run on what it reads.
//
// Each target is one function of the libFuzzer interface. Built with -fsanitize=fuzzer it is
// LLVMFuzzerTestOneInput; the replay test (test_fuzz_replay.cpp, a normal ctest test) compiles
// the same file with DBACOV_FUZZ_ENTRY set to another name and feeds it the seed corpus and every
// file of tests/fuzz/regressions/<target>/.
//
// Contract checked on every input: reading a damaged or hostile file throws dbacov::InputError
// (and nothing else), a snapshot that reads and validates gives covariances or a
// dbacov::NumericalError, and nothing crashes, leaks or trips a sanitizer.
#pragma once

#include <cstddef>
#include <cstdint>

#include "dbacov/core/covariance.h"
#include "dbacov/core/errors.h"
#include "dbacov/core/snapshot.h"
#include "dbacov/core/threads.h"

namespace dbacov::fuzz {

/// Runs the engine on a valid snapshot small enough to be fast (a fuzzer runs thousands of inputs
/// per second); every covariance it returns must be finite.
inline void computeCovariances(const Snapshot& s) {
  if (s.numKeyframes() > 32 || s.numEdges() > 64 || s.pixelsPerFrame() > 400) return;
  const ThreadLimit one_thread(1);
  try {
    DbaOptions o = DbaOptions::droid();
    o.weight_scale = 4;
    const DbaCovariance cov(s, o);
    for (int k : cov.keyframes())
      if (!cov.marginal(k).allFinite()) __builtin_trap();
  } catch (const NumericalError&) {
    // A valid snapshot without covariances (no gauge reaches a part, indefinite system).
  }
}

}  // namespace dbacov::fuzz

#ifndef DBACOV_FUZZ_ENTRY
#define DBACOV_FUZZ_ENTRY LLVMFuzzerTestOneInput
#endif
