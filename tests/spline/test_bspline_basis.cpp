// The cumulative basis (bspline_basis.h) and the time -> segment mapping.
#include "ctcal/spline/bspline_basis.h"

#include <gtest/gtest.h>

namespace ctcal {
namespace {

template <typename C>
class BasisTest : public ::testing::Test {};
template <int kN>
struct Order {
  static constexpr int N = kN;
};
using Orders = ::testing::Types<Order<2>, Order<3>, Order<4>, Order<5>, Order<6>>;
TYPED_TEST_SUITE(BasisTest, Orders);

template <int N>
std::array<std::array<double, N>, kMaxDerivative + 1> Lambda(double u, double inv_dt = 1.0) {
  std::array<std::array<double, N>, kMaxDerivative + 1> l;
  CumulativeBasis<N>::Evaluate(u, inv_dt, kMaxDerivative, &l);
  return l;
}

TEST(BasisTest, CubicBlendingMatrixIsTheTextbookOne) {
  // Qin (2000), cubic: 1/6 [1 4 1 0; -3 0 3 0; 3 -6 3 0; -1 3 -3 1] (row = power of u).
  const double expected[4][4] = {{1, 4, 1, 0}, {-3, 0, 3, 0}, {3, -6, 3, 0}, {-1, 3, -3, 1}};
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) {
      EXPECT_NEAR(CumulativeBasis<4>::kBlending[i][j], expected[i][j] / 6.0, 1e-15) << i << j;
    }
  }
}

// lambda_0 = 1 (partition of unity), lambda_j in [0, 1], non-increasing in j.
TYPED_TEST(BasisTest, CumulativeBasisIsAPartitionOfUnity) {
  constexpr int N = TypeParam::N;
  for (double u = 0.0; u <= 1.0; u += 0.125) {
    const auto l = Lambda<N>(u);
    EXPECT_NEAR(l[0][0], 1.0, 1e-14);
    for (int k = 1; k <= kMaxDerivative; ++k)
      EXPECT_NEAR(l[k][0], 0.0, 1e-12);
    for (int j = 1; j < N; ++j) {
      EXPECT_GE(l[0][j], -1e-15);
      EXPECT_LE(l[0][j], l[0][j - 1] + 1e-15);
    }
  }
}

// Segment i at u = 1 equals segment i+1 at u = 0 with the knots shifted by one: for the cumulative
// basis, lambda_j(1) = lambda_{j+1}(0) + 1 ... i.e. b_j(1) = b_{j+1}(0) in every derivative up to
// N-2 (C^(N-2) continuity of the spline).
TYPED_TEST(BasisTest, SegmentsJoinWithNMinus2ContinuousDerivatives) {
  constexpr int N = TypeParam::N;
  const auto end = Lambda<N>(1.0);
  const auto start = Lambda<N>(0.0);
  const auto b = [](const std::array<double, N>& l, int j) {
    return j + 1 < N ? l[j] - l[j + 1] : l[j];
  };
  for (int k = 0; k <= std::min(N - 2, kMaxDerivative); ++k) {
    for (int j = 0; j + 1 < N; ++j) {
      EXPECT_NEAR(b(end[k], j + 1), b(start[k], j), 1e-12) << "derivative " << k << " j " << j;
    }
    EXPECT_NEAR(b(end[k], 0), 0.0, 1e-12);
    EXPECT_NEAR(b(start[k], N - 1), 0.0, 1e-12);
  }
}

TYPED_TEST(BasisTest, TimeDerivativesMatchFiniteDifferences) {
  constexpr int N = TypeParam::N;
  const double inv_dt = 4.0;  // dt = 0.25 s
  const double h = 1e-6;
  for (double u : {0.1, 0.5, 0.83}) {
    const auto l = Lambda<N>(u, inv_dt);
    const auto lp = Lambda<N>(u + h * inv_dt, inv_dt);
    const auto lm = Lambda<N>(u - h * inv_dt, inv_dt);
    for (int k = 0; k < kMaxDerivative; ++k) {
      for (int j = 0; j < N; ++j) {
        EXPECT_NEAR(l[k + 1][j], (lp[k][j] - lm[k][j]) / (2 * h),
                    1e-6 * std::max(1.0, std::abs(l[k + 1][j])));
      }
    }
  }
}

TEST(KnotTimingTest, LocateSplitsIntegerAndOffsetTimeExactly) {
  const KnotTiming timing{1'000'000'000'000'000'000, 50'000'000};  // t0 ~ 31 years in ns
  SegmentLocation<double> loc;
  ASSERT_TRUE(timing.Locate(timing.t0_ns + 3 * 50'000'000 + 10'000'000, 0.0, 10, &loc));
  EXPECT_EQ(loc.first_index, 3);
  EXPECT_NEAR(loc.u, 0.2, 1e-15);
  EXPECT_DOUBLE_EQ(loc.inv_dt, 20.0);
  // An offset crossing into the previous segment.
  ASSERT_TRUE(timing.Locate(timing.t0_ns + 3 * 50'000'000 + 10'000'000, -0.02, 10, &loc));
  EXPECT_EQ(loc.first_index, 2);
  EXPECT_NEAR(loc.u, 0.8, 1e-12);
  // The end point belongs to the last segment; beyond and before are out of range.
  ASSERT_TRUE(timing.Locate(timing.t0_ns + 10 * 50'000'000, 0.0, 10, &loc));
  EXPECT_EQ(loc.first_index, 9);
  EXPECT_DOUBLE_EQ(loc.u, 1.0);
  EXPECT_FALSE(timing.Locate(timing.t0_ns + 10 * 50'000'000 + 1, 0.0, 10, &loc));
  EXPECT_FALSE(timing.Locate(timing.t0_ns - 1, 0.0, 10, &loc));
  EXPECT_FALSE(timing.Locate(timing.t0_ns, -1e-9, 10, &loc));
  EXPECT_TRUE(timing.Locate(timing.t0_ns - 1, 2e-9, 10, &loc));
  EXPECT_EQ(loc.first_index, 0);
}

TEST(KnotTimingTest, JetOffsetCarriesDuDtAndKeepsTheSegment) {
  using Jet = ceres::Jet<double, 1>;
  const KnotTiming timing{0, 100'000'000};
  SegmentLocation<Jet> loc;
  ASSERT_TRUE(timing.Locate(250'000'000, Jet(0.01, 0), 10, &loc));
  EXPECT_EQ(loc.first_index, 2);
  EXPECT_NEAR(loc.u.a, 0.6, 1e-12);
  EXPECT_NEAR(loc.u.v[0], 10.0, 1e-12);  // du/d(offset) = 1/dt
}

}  // namespace
}  // namespace ctcal
