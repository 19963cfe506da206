// RdSpline: linear precision, weights = Jacobians, derivatives against finite differences, Jet.
#include "ctcal/spline/rd_spline.h"

#include <gtest/gtest.h>

#include <random>

namespace ctcal {
namespace {

template <int kN>
struct Order {
  static constexpr int N = kN;
};
template <typename C>
class RdSplineTest : public ::testing::Test {};
using Orders = ::testing::Types<Order<4>, Order<5>, Order<6>>;
TYPED_TEST_SUITE(RdSplineTest, Orders);

// Knots on a line at the centres of their supports reproduce the line exactly (linear precision
// of uniform B-splines), with its constant velocity and zero acceleration.
TYPED_TEST(RdSplineTest, ReproducesALineExactly) {
  constexpr int N = TypeParam::N;
  const KnotTiming timing{2'000'000'000, 40'000'000};
  RdSpline<3, N> s(timing, 12);
  const Eigen::Vector3d p0(1.0, -2.0, 0.5), v(0.3, 0.1, -0.7);
  for (int k = 0; k < s.NumKnots(); ++k) {
    s.Knot(k) = p0 + v * 1e-9 * static_cast<double>(s.KnotCentreTimeNs(k));
  }
  for (std::int64_t t = s.MinTimeNs(); t <= s.MaxTimeNs(); t += 7'000'001) {
    const double ts = 1e-9 * static_cast<double>(t);
    EXPECT_LT((s.Evaluate(t) - (p0 + v * ts)).norm(), 1e-9);
    EXPECT_LT((s.Evaluate(t, 1) - v).norm(), 1e-9);
    EXPECT_LT(s.Evaluate(t, 2).norm(), 1e-7);
  }
}

TYPED_TEST(RdSplineTest, WeightsAreTheKnotJacobiansAndDerivativesMatchFiniteDifferences) {
  constexpr int N = TypeParam::N;
  RdSpline<2, N> s(KnotTiming{0, 100'000'000}, N + 2);
  std::mt19937 rng(2);
  std::normal_distribution<double> gauss;
  for (int k = 0; k < s.NumKnots(); ++k)
    s.Knot(k) = Eigen::Vector2d(gauss(rng), gauss(rng));
  const std::int64_t t = 123'456'789;
  for (int d = 0; d <= 2; ++d) {
    int first = -1;
    std::array<double, N> w;
    const Eigen::Vector2d value = s.Evaluate(t, d, 0.0, &first, &w);
    EXPECT_EQ(first, 1);
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    for (int i = 0; i < N; ++i)
      sum += w[i] * s.Knot(first + i);
    EXPECT_LT((sum - value).norm(), 1e-10);
    // Moving knot i by e changes the value by w_i e.
    RdSpline<2, N> moved = s;
    moved.Knot(first + 2) += Eigen::Vector2d(1e-3, 0.0);
    EXPECT_NEAR((moved.Evaluate(t, d) - value).x(), w[2] * 1e-3,
                1e-9 * std::max(1.0, std::abs(w[2])));
    // d/dt of derivative d is derivative d+1.
    const double h = 1e-6;
    const Eigen::Vector2d fd = (s.Evaluate(t, d, h) - s.Evaluate(t, d, -h)) / (2 * h);
    EXPECT_LT((fd - s.Evaluate(t, d + 1)).norm(), 1e-6 * std::max(1.0, fd.norm()));
  }
}

TYPED_TEST(RdSplineTest, JetTimeOffsetDerivativeIsTheVelocity) {
  constexpr int N = TypeParam::N;
  using Jet = ceres::Jet<double, 1>;
  RdSpline<3, N> s(KnotTiming{0, 100'000'000}, N + 1);
  for (int k = 0; k < s.NumKnots(); ++k)
    s.Knot(k) = Eigen::Vector3d(k * k, -k, std::sin(k));
  SegmentLocation<Jet> loc;
  ASSERT_TRUE(s.ComputeIndex(150'000'000, Jet(0.0, 0), &loc));
  std::vector<Eigen::Matrix<Jet, 3, 1>> knots;
  for (int i = 0; i < N; ++i)
    knots.push_back(s.Knot(loc.first_index + i).template cast<Jet>());
  std::array<const Jet*, N> ptrs;
  for (int i = 0; i < N; ++i)
    ptrs[i] = knots[i].data();
  const auto p = RdSpline<3, N>::EvaluateSegment(ptrs.data(), loc.u, loc.inv_dt, 0);
  const Eigen::Vector3d v = s.Evaluate(150'000'000, 1);
  for (int r = 0; r < 3; ++r)
    EXPECT_NEAR(p[r].v[0], v[r], 1e-10 * std::max(1.0, std::abs(v[r])));
}

TEST(RdSplineErrors, BadConstructionAndOutOfRangeTimesThrowWithAReason) {
  EXPECT_THROW((RdSpline<3, 4>(KnotTiming{0, 0}, 10)), std::invalid_argument);
  EXPECT_THROW((RdSpline<3, 4>(KnotTiming{0, 10}, 3)), std::invalid_argument);
  const RdSpline<3, 4> s(KnotTiming{0, 10}, 5);
  try {
    s.Evaluate(21);
    FAIL() << "no exception";
  } catch (const std::out_of_range& e) {
    EXPECT_NE(std::string(e.what()).find("outside its time range [0, 20]"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace ctcal
