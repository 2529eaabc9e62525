// How much memory a reader may commit to one input before it allocates: a deflated archive of a
// few megabytes can declare gigabytes of arrays, and a reader that trusts it is stopped by the
// kernel or by std::bad_alloc long after the damage is done. Readers compare the sizes an input
// declares with this budget first and refuse it with a message that says how much and where.
#pragma once

#include <cstdint>
#include <string>

namespace dbacov::io {

/// The bytes of arrays one input (a snapshot) may declare, and where that number comes from.
struct MemoryBudget {
  std::uint64_t bytes = 0;
  /// For messages: "set by DBACOV_MEMORY_BUDGET", "a third of this process's memory; ..." or
  /// "the default cap of 4 GiB; ...".
  std::string source;
};

/// DBACOV_MEMORY_BUDGET when it is set (bytes, or a number with a K, M, G or T suffix, powers of
/// 1024); otherwise a third of what this process may use (physical memory, the address-space
/// limit, the cgroup's memory limit: the smallest), and at most kDefaultMemoryBudget. Throws
/// InputError when DBACOV_MEMORY_BUDGET is not a positive size.
MemoryBudget memoryBudget();

/// The cap of the default budget: 4 GiB of arrays, a global bundle adjustment of ~80 000 edges at
/// DROID's 48×64 grid; local windows are a few tens of megabytes.
inline constexpr std::uint64_t kDefaultMemoryBudget = std::uint64_t{4} << 30;

/// "4.9 GiB" / "775 MiB" / "4.0 KiB" / "17 bytes": a size for a message (powers of 1024, as
/// DBACOV_MEMORY_BUDGET's suffixes).
std::string sizeText(std::uint64_t bytes);

}  // namespace dbacov::io
