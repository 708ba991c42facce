// vilma/core/heap.h: the mmap threshold stays fixed (large blocks keep going back to the
// kernel after the first one is freed), and mallinfo2's figures move with an allocation.
#include <catch2/catch.hpp>

#include <cstring>
#include <memory>

#include "vilma/core/heap.h"

namespace {

constexpr std::size_t kBlockBytes = 4 * 1024 * 1024;
constexpr double kBlockMb = 4.0;

}  // namespace

#if defined(__GLIBC__)
TEST_CASE("FixMallocMmapThreshold: every large block is mmapped and returned, not only the first",
          "[core][heap]") {
  REQUIRE(vilma::FixMallocMmapThreshold());
  // With glibc's dynamic threshold the first free of a 4 MiB mmapped block raises the
  // threshold to 4 MiB, and the second block would come from the heap and stay there after free.
  for (int round = 0; round < 3; ++round) {
    INFO("round " << round);
    const vilma::HeapUsage before = vilma::ReadHeapUsage();
    {
      std::unique_ptr<char[]> block(new char[kBlockBytes]);
      std::memset(block.get(), round + 1, kBlockBytes);  // resident
      const vilma::HeapUsage during = vilma::ReadHeapUsage();
      CHECK(during.mmapped_mb - before.mmapped_mb >= kBlockMb - 0.01);
      CHECK(during.in_use_mb - before.in_use_mb >= kBlockMb - 0.01);
    }
    const vilma::HeapUsage after = vilma::ReadHeapUsage();
    CHECK(after.mmapped_mb == Approx(before.mmapped_mb).margin(0.01));
    // Not kept as free heap either.
    CHECK(after.free_mb < before.free_mb + 0.5);
  }
}
#endif

TEST_CASE("ReadHeapUsage: non-negative figures, in use >= mmapped", "[core][heap]") {
  const vilma::HeapUsage h = vilma::ReadHeapUsage();
  CHECK(h.in_use_mb >= 0.0);
  CHECK(h.free_mb >= 0.0);
  CHECK(h.mmapped_mb >= 0.0);
  CHECK(h.in_use_mb >= h.mmapped_mb);
  vilma::ReleaseFreeHeap();  // must not disturb the heap's figures' consistency
  const vilma::HeapUsage t = vilma::ReadHeapUsage();
  CHECK(t.in_use_mb >= t.mmapped_mb);
}
