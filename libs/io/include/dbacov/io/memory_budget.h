// How much memory a reader may commit to one input before it allocates: a deflated archive of a
// few megabytes can declare gigabytes of arrays, and a reader that trusts it is stopped by the
// kernel or by std::bad_alloc long after the damage is done. Readers compare the sizes an input
// declares with this budget first and refuse it with a message that says how much and where.
#pragma once

#include <cstdint>
#include <string>

namespace dbacov::io {

/// Bytes of arrays one input (a snapshot) may declare. DBACOV_MEMORY_BUDGET when it is set (bytes,
/// or a number with a K, M, G or T suffix, powers of 1024); otherwise a third of what this process
/// may use (physical memory, the address-space limit, the cgroup's memory limit: the smallest),
/// and at most kDefaultMemoryBudget. Throws InputError when DBACOV_MEMORY_BUDGET is not a
/// positive size.
std::uint64_t memoryBudgetBytes();

/// The cap of the default budget: 4 GiB of arrays, a global bundle adjustment of ~80 000 edges at
/// DROID's 48×64 grid; local windows are a few tens of megabytes.
inline constexpr std::uint64_t kDefaultMemoryBudget = std::uint64_t{4} << 30;

/// "5.3 GB" / "812 MB" / "4.0 kB" / "17 bytes": a size for a message (powers of 1000).
std::string sizeText(std::uint64_t bytes);

}  // namespace dbacov::io
