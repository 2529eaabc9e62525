// How many threads the engine's parallel loops use (oneTBB underneath, private to dbacov_core).
// The number is a process-wide limit that a ThreadLimit sets while it lives (the apps' --threads).
// Also the check of the engine's other process-wide setting, DBACOV_KERNEL_ISA.
#pragma once

#include <cstddef>
#include <memory>

namespace dbacov {

/// Limits the threads of every parallel region while it lives (0 = the machine's default).
class ThreadLimit {
 public:
  explicit ThreadLimit(std::size_t threads);
  ~ThreadLimit();
  ThreadLimit(const ThreadLimit&) = delete;
  ThreadLimit& operator=(const ThreadLimit&) = delete;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Threads the parallel regions may use now.
std::size_t currentThreadLimit();

/// Throws std::invalid_argument, naming the variable, when DBACOV_KERNEL_ISA names no variant of
/// the pixel kernel that this CPU runs (docs/development/performance.md). Every linearization would
/// throw the same; the apps call this with their other usage checks, before reading anything.
void checkEngineEnvironment();

}  // namespace dbacov
