#include "allocator_reuse.h"

#include <cstdint>
#include <cstdlib>
#include <mutex>

#if defined(__GLIBC__)
#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>
#endif

namespace dbacov::app {

void keepFreedMemoryForReuse() {
#if defined(__GLIBC__)
  static std::once_flag once;
  std::call_once(once, [] {
    mallopt(M_MMAP_THRESHOLD, 256 << 20);  // blocks up to 256 MiB from the heap
    mallopt(M_TRIM_THRESHOLD, 512 << 20);  // give back only beyond 512 MiB of free top
    // Grow the heap now by at least kPad (a block of kPad, plus kPad of top padding), and advise
    // the grown part for transparent huge pages: what glibc.malloc.hugetlb=1 would do, without an
    // environment variable. A part of the heap grown later by brk is not covered (the kernel
    // gives it a mapping of its own); 64 MiB is more than one snapshot's buffers, with or without
    // self-calibration (an advice only: nothing changes where THP is off or always on).
    constexpr std::size_t kPad = std::size_t{64} << 20;
    mallopt(M_TOP_PAD, static_cast<int>(kPad));
    void* block = std::malloc(kPad);
    const auto end = reinterpret_cast<std::uintptr_t>(sbrk(0));
    constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
    const auto lo = (reinterpret_cast<std::uintptr_t>(block) + kHuge - 1) & ~(kHuge - 1);
    const auto hi = end & ~(kHuge - 1);
    // Only when the block really came from the brk heap (not from mmap, or another allocator).
    if (block && hi > lo && hi - lo <= 4 * kPad)
      static_cast<void>(madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_HUGEPAGE));
    std::free(block);
  });
#endif
}

}  // namespace dbacov::app
