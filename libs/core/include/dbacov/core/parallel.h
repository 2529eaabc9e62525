// Parallel loops of the engine (oneTBB underneath; TBB stays out of public headers).
//
// Work is spread over TBB's shared pool with work stealing, so nested use (snapshots in parallel,
// each linearizing its source keyframes in parallel) neither oversubscribes nor deadlocks. The
// number of threads is the process-wide limit set with ThreadLimit (the apps' --threads).
#pragma once

#include <cstddef>
#include <functional>
#include <memory>

namespace dbacov {

/// Calls fn(i) for every i in [0, n), in parallel, one index per task. Exceptions propagate.
void parallelFor(std::size_t n, const std::function<void(std::size_t)>& fn);

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

}  // namespace dbacov
