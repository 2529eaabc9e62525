#include "allocator_reuse.h"

#include <mutex>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace dbacov::app {

void keepFreedMemoryForReuse() {
#if defined(__GLIBC__)
  static std::once_flag once;
  std::call_once(once, [] {
    mallopt(M_MMAP_THRESHOLD, 256 << 20);  // blocks up to 256 MiB from the heap
    mallopt(M_TRIM_THRESHOLD, 512 << 20);  // give back only beyond 512 MiB of free top
  });
#endif
}

}  // namespace dbacov::app
