// How many threads the engine's parallel loops use (oneTBB underneath, private to dbacov_core).
// The number is a process-wide limit that a ThreadLimit sets while it lives (the apps' --threads).
// Also the check of the engine's other process-wide setting, DBACOV_KERNEL_ISA.
#pragma once

#include <chrono>
#include <cstddef>
#include <functional>
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

/// A host's way to stop a long computation (the Python module: Ctrl-C). While it lives, every
/// parallel loop of the engine that this thread starts calls `check` on this thread — when the
/// loop starts and between its items — at most once per `period`; an exception thrown by `check`
/// stops the loop and leaves the computation (the engine's state is RAII-owned, nothing leaks).
/// Loops run by other threads are not checked. Scopes nest; the innermost is used.
class ScopedInterruptCheck {
 public:
  explicit ScopedInterruptCheck(std::function<void()> check,
                                std::chrono::milliseconds period = std::chrono::milliseconds(20));
  ~ScopedInterruptCheck();
  ScopedInterruptCheck(const ScopedInterruptCheck&) = delete;
  ScopedInterruptCheck& operator=(const ScopedInterruptCheck&) = delete;

  /// Calls this thread's innermost check when its period has passed (or `now` is set); does
  /// nothing on a thread without one.
  static void poll(bool now = false);

 private:
  std::function<void()> check_;
  std::chrono::steady_clock::duration period_;
  std::chrono::steady_clock::time_point last_;
  ScopedInterruptCheck* outer_;
};

/// Threads the parallel regions may use now.
std::size_t currentThreadLimit();

/// Throws std::invalid_argument, naming the variable, when DBACOV_KERNEL_ISA names no variant of
/// the pixel kernel that this CPU runs (docs/development/performance.md). Every linearization would
/// throw the same; the apps call this with their other usage checks, before reading anything.
void checkEngineEnvironment();

}  // namespace dbacov
