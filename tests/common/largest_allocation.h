// The largest single allocation made while a function runs, for tests that check that declared
// sizes are refused before anything of that size is allocated. largest_allocation.cpp replaces the
// global operator new of the test executable to record it: add that file to the executable's
// SOURCES (once per executable).
#pragma once

#include <cstddef>
#include <functional>

namespace dbacov::testing {

/// Runs `f` and returns the size of the largest `operator new` request made meanwhile (by any
/// thread). Not reentrant.
std::size_t largestAllocationDuring(const std::function<void()>& f);

}  // namespace dbacov::testing
