// ReleaseFreedMemory's rule (memory_usage.h): the heap's free pages go back to the system once it
// holds kTrimAboveBytes free, and are kept, for the next stage to reuse, below that.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <vector>

#include "ctcal/calibrator/memory_usage.h"

namespace ctcal {
namespace {

constexpr std::size_t kChunk = std::size_t{64} << 10;  // below glibc's mmap threshold: heap
constexpr double kMiB = 1024.0 * 1024.0;

// `bytes` of touched heap chunks, then freed but the last: it keeps the heap's top in use, so that
// free() cannot return the others itself (only a trim can). Returns the last.
void* HoldThenFree(std::size_t bytes) {
  std::vector<void*> chunks;
  for (std::size_t n = 0; n <= bytes; n += kChunk) {
    void* p = std::malloc(kChunk);
    std::memset(p, 1, kChunk);
    chunks.push_back(p);
  }
  for (std::size_t i = 0; i + 1 < chunks.size(); ++i)
    std::free(chunks[i]);
  return chunks.back();
}

TEST(ReleaseFreedMemory, ReturnsTheFreePagesOnlyAboveItsThreshold) {
  if (FreeHeapBytes() < 0)
    GTEST_SKIP() << "the heap's free bytes are not known here (glibc >= 2.33 reports them)";
  ReleaseFreedMemory();  // what the test process held before
  const double small_mb = 16.0;
  ASSERT_LT(small_mb * kMiB + static_cast<double>(FreeHeapBytes()),
            static_cast<double>(kTrimAboveBytes));
  void* top1 = HoldThenFree(static_cast<std::size_t>(small_mb * kMiB));
  EXPECT_GE(static_cast<double>(FreeHeapBytes()), small_mb * kMiB);
  const double rss_small = CurrentMemoryUsage().rss_mb;
  EXPECT_FALSE(ReleaseFreedMemory());
  // Kept: still resident (the test touches nothing else meanwhile).
  EXPECT_GT(CurrentMemoryUsage().rss_mb, rss_small - 0.25 * small_mb);

  const double large_mb = 2.0 * static_cast<double>(kTrimAboveBytes) / kMiB;
  void* top2 = HoldThenFree(static_cast<std::size_t>(large_mb * kMiB));
  ASSERT_GE(FreeHeapBytes(), kTrimAboveBytes);
  const double rss_large = CurrentMemoryUsage().rss_mb;
  EXPECT_TRUE(ReleaseFreedMemory());
  // Returned: the freed chunks' pages, the small ones' with them.
  EXPECT_LT(CurrentMemoryUsage().rss_mb, rss_large - 0.75 * large_mb);
  std::free(top1);
  std::free(top2);
}

}  // namespace
}  // namespace ctcal
