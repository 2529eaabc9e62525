// Parallel loops of the engine (internal; oneTBB underneath, TBB stays out of every header).
//
// Work is spread over TBB's shared pool with work stealing, so nested use (snapshots in parallel,
// each linearizing its source keyframes in parallel) neither oversubscribes nor deadlocks. The
// number of threads is the process-wide limit set with ThreadLimit (threads.h).
#pragma once

#include <cstddef>
#include <functional>
#include <memory>

#include "dbacov/core/threads.h"

namespace dbacov {

/// Calls fn(i) for every i in [0, n), in parallel, one index per task. Exceptions propagate.
void parallelFor(std::size_t n, const std::function<void(std::size_t)>& fn);

}  // namespace dbacov
