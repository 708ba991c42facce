#include "vilma/core/heap.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace vilma {

HeapUsage ReadHeapUsage() {
  HeapUsage h;
#if defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 33))
  const struct mallinfo2 m = mallinfo2();
  constexpr double kMiB = 1024.0 * 1024.0;
  h.in_use_mb = static_cast<double>(m.uordblks + m.hblkhd) / kMiB;
  h.free_mb = static_cast<double>(m.fordblks) / kMiB;
  h.mmapped_mb = static_cast<double>(m.hblkhd) / kMiB;
#endif
  return h;
}

bool FixMallocMmapThreshold(std::size_t threshold_bytes) {
#if defined(__GLIBC__)
  return mallopt(M_MMAP_THRESHOLD, static_cast<int>(threshold_bytes)) == 1;
#else
  (void)threshold_bytes;
  return true;
#endif
}

void ReleaseFreeHeap() {
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

}  // namespace vilma
