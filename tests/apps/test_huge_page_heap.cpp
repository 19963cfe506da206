// The calibration's heap re-execution (apps/huge_page_heap.h): the GLIBC_TUNABLES value it sets,
// and when it leaves the process alone (the tunable set already, by the user or by the
// re-execution itself, which must not loop; huge pages never given, or given to all already).
#include "huge_page_heap.h"

#include <gtest/gtest.h>

namespace ctcal::app {
namespace {

constexpr const char* kMadvise = "always [madvise] never";

TEST(HugePageHeap, TurnsTheTunableOnBesideTheUsersOwn) {
  EXPECT_EQ(HugePageTunables(nullptr, kMadvise), "glibc.malloc.hugetlb=1");
  EXPECT_EQ(HugePageTunables("", kMadvise), "glibc.malloc.hugetlb=1");
  EXPECT_EQ(HugePageTunables("glibc.malloc.arena_max=2", kMadvise),
            "glibc.malloc.arena_max=2:glibc.malloc.hugetlb=1");
}

TEST(HugePageHeap, LeavesTheProcessAloneWhenThereIsNothingToDo) {
  // Set already: by the re-execution (no second one) or by the user (theirs stands, also 0).
  EXPECT_EQ(HugePageTunables("glibc.malloc.hugetlb=1", kMadvise), std::nullopt);
  EXPECT_EQ(HugePageTunables("glibc.malloc.arena_max=2:glibc.malloc.hugetlb=0", kMadvise),
            std::nullopt);
  // The kernel's mode: never, always (every anonymous page already), unreadable.
  EXPECT_EQ(HugePageTunables(nullptr, "always madvise [never]"), std::nullopt);
  EXPECT_EQ(HugePageTunables(nullptr, "[always] madvise never"), std::nullopt);
  EXPECT_EQ(HugePageTunables(nullptr, ""), std::nullopt);
}

}  // namespace
}  // namespace ctcal::app
