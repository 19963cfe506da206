// The simulator's random source: reproducible, independent streams, and the right moments.
#include <gtest/gtest.h>

#include <cmath>

#include "ctcal/sim/random.h"

namespace ctcal::sim {
namespace {

TEST(Random, SameSeedSameNumbersDifferentSeedDifferent) {
  Random a(42), b(42), c(43);
  bool any_different = false;
  for (int i = 0; i < 1000; ++i) {
    const double x = a.Gaussian();
    EXPECT_EQ(x, b.Gaussian());
    any_different |= (x != c.Gaussian());
  }
  EXPECT_TRUE(any_different);
}

TEST(Random, KnownFirstValuesPinThePortableDistributions) {
  // std::mt19937_64 is specified by the standard (its 10000th output for the default seed is
  // 9981545732273789042); the distributions on top are ours, so these values may only change
  // when the algorithm changes on purpose.
  std::mt19937_64 engine;
  engine.discard(9999);
  EXPECT_EQ(engine(), 9981545732273789042ULL);
  Random r(5489);  // the default seed
  std::mt19937_64 ref(5489);
  EXPECT_EQ(r.Uniform(), static_cast<double>(ref() >> 11) * 0x1.0p-53);
}

TEST(Random, ForkedStreamsDoNotDependOnPriorDraws) {
  Random a(7);
  const Random fresh(7);
  for (int i = 0; i < 17; ++i)
    a.Gaussian();
  Random s1 = a.Fork(3), s2 = fresh.Fork(3), s3 = fresh.Fork(4);
  const double x = s1.Uniform();
  EXPECT_EQ(x, s2.Uniform());
  EXPECT_NE(x, s3.Uniform());
}

TEST(Random, GaussianAndUniformMoments) {
  Random r(1);
  const int n = 200000;
  double s = 0, s2 = 0, s4 = 0, u = 0, u2 = 0;
  for (int i = 0; i < n; ++i) {
    const double g = r.Gaussian();
    s += g;
    s2 += g * g;
    s4 += g * g * g * g;
    const double x = r.Uniform();
    ASSERT_GE(x, 0.0);
    ASSERT_LT(x, 1.0);
    u += x;
    u2 += x * x;
  }
  // Bounds of about 5 standard errors of each estimate.
  EXPECT_NEAR(s / n, 0.0, 5.0 / std::sqrt(n));
  EXPECT_NEAR(s2 / n, 1.0, 5.0 * std::sqrt(2.0 / n));
  EXPECT_NEAR(s4 / n, 3.0, 5.0 * std::sqrt(96.0 / n));
  EXPECT_NEAR(u / n, 0.5, 5.0 * std::sqrt(1.0 / 12 / n));
  EXPECT_NEAR(u2 / n - (u / n) * (u / n), 1.0 / 12, 5.0 * std::sqrt(1.0 / 180 / n));
}

}  // namespace
}  // namespace ctcal::sim
