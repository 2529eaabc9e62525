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
    // Blocks up to 256 MiB from the heap; an older glibc that refuses so high a threshold keeps
    // its own (and its dynamic adjustment), and nothing else is changed then.
    if (mallopt(M_MMAP_THRESHOLD, 256 << 20) != 1) return;
    mallopt(M_TRIM_THRESHOLD, 512 << 20);  // give back only beyond 512 MiB of free top
    // Grow the main heap now, in one step, by ≈ 2 × kPad (a block of kPad plus kPad of top
    // padding), and advise the grown part for transparent huge pages. The padding is set back
    // to glibc's default at once: it also sizes every thread arena and every later growth.
    // Only this region of the main arena is advised (glibc.malloc.hugetlb=1 would advise every
    // growth and arena); memory of worker threads' arenas and later growths is not.
    constexpr std::size_t kPad = std::size_t{64} << 20;
    const auto before = reinterpret_cast<std::uintptr_t>(sbrk(0));
    mallopt(M_TOP_PAD, static_cast<int>(kPad));
    void* block = std::malloc(kPad);
    mallopt(M_TOP_PAD, 128 * 1024);
    const auto end = reinterpret_cast<std::uintptr_t>(sbrk(0));
    const auto first = reinterpret_cast<std::uintptr_t>(block);
    constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
    const std::uintptr_t lo = (first + kHuge - 1) & ~(kHuge - 1), hi = end & ~(kHuge - 1);
    // Only when the break really grew by the block's size and the block lies at the heap's end
    // (not mmapped, not another allocator's); it may start in the top chunk's old free part.
    if (block && end >= before + kPad && first + kPad <= end && end - first <= 4 * kPad && hi > lo)
      static_cast<void>(madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_HUGEPAGE));
    std::free(block);
  });
#endif
}

}  // namespace dbacov::app
