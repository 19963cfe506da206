// So3Spline: the O(N) recursions against finite differences of the orientation, knot Jacobians of
// orientation / angular velocity / acceleration against central differences on So3RightManifold,
// and the Jet path, for orders 4, 5, 6.
#include "ctcal/spline/so3_spline.h"

#include <gtest/gtest.h>

#include "ctcal/spline/so3_manifold.h"
#include "spline_test_utils.h"

namespace ctcal {
namespace {

using testing::CentralDifference;
using testing::RelativeError;

template <int kN>
struct Order {
  static constexpr int N = kN;
};
template <typename C>
class So3SplineTest : public ::testing::Test {
 protected:
  static constexpr int N = C::N;
  So3Spline<N> RandomSpline(unsigned seed, double step, int num_knots) const {
    So3Spline<N> s(KnotTiming{0, 50'000'000}, num_knots);
    std::mt19937 rng(seed);
    Eigen::Quaterniond q = testing::RandomRotation(&rng, 3.0);
    for (int k = 0; k < num_knots; ++k) {
      q = testing::RandomRotation(&rng, step, q);
      s.Knot(k) = q;
    }
    return s;
  }
};
using Orders = ::testing::Types<Order<4>, Order<5>, Order<6>>;
TYPED_TEST_SUITE(So3SplineTest, Orders);

TYPED_TEST(So3SplineTest, RecursionsMatchFiniteDifferencesOfTheOrientation) {
  const auto s = this->RandomSpline(1, 1.0, TypeParam::N + 4);
  const double h = 1e-5;
  for (std::int64_t t = s.MinTimeNs() + 3'000'000; t < s.MaxTimeNs(); t += 37'000'000) {
    typename So3Spline<TypeParam::N>::template Output<double> o, op, om;
    s.Evaluate(t, 0.0, 3, &o);
    s.Evaluate(t, h, 3, &op);
    s.Evaluate(t, -h, 3, &om);
    const Eigen::Vector3d w_fd =
        LogSO3<double>(Eigen::Quaterniond(om.value.transpose() * op.value)) / (2 * h);
    EXPECT_LT(RelativeError(o.velocity, w_fd), 1e-6);
    EXPECT_LT(RelativeError(o.acceleration, (op.velocity - om.velocity) / (2 * h)), 1e-6);
    EXPECT_LT(RelativeError(o.jerk, (op.acceleration - om.acceleration) / (2 * h)), 1e-5);
    // The class convenience accessors are the same evaluation.
    EXPECT_LT((s.AngularVelocity(t) - o.velocity).norm(), 1e-12);
    EXPECT_LT((s.AngularAcceleration(t) - o.acceleration).norm(), 1e-12);
    EXPECT_LT(s.Orientation(t).angularDistance(Eigen::Quaterniond(o.value)), 1e-12);
  }
}

TYPED_TEST(So3SplineTest, KnotJacobiansMatchCentralDifferences) {
  constexpr int N = TypeParam::N;
  using S = So3Spline<N>;
  for (double step : {1.2, 1e-6}) {
    const S s = this->RandomSpline(2, step, N);
    typename S::template Output<double> o;
    std::array<Mat3T<double>, N> J_R, J_w, J_a;
    typename S::template Jacobians<double> J{&J_R, &J_w, &J_a};
    const std::int64_t t = s.MinTimeNs() + 21'000'000;
    s.Evaluate(t, 0.0, 2, &o, &J);
    const So3RightManifold manifold;
    for (int i = 0; i < N; ++i) {
      const auto perturbed = [&](const Eigen::VectorXd& d) {
        S p = s;
        manifold.Plus(s.Knot(i).coeffs().data(), d.data(), p.KnotData(i));
        typename S::template Output<double> out;
        p.Evaluate(t, 0.0, 2, &out);
        return out;
      };
      const auto num_R = CentralDifference(
          [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
            return LogSO3<double>(Eigen::Quaterniond(o.value.transpose() * perturbed(d).value));
          },
          3);
      const auto num_w = CentralDifference(
          [&](const Eigen::VectorXd& d) -> Eigen::VectorXd { return perturbed(d).velocity; }, 3);
      const auto num_a = CentralDifference(
          [&](const Eigen::VectorXd& d) -> Eigen::VectorXd { return perturbed(d).acceleration; },
          3);
      EXPECT_LT(RelativeError(J_R[i], num_R), 1e-7) << "knot " << i << " step " << step;
      EXPECT_LT(RelativeError(J_w[i], num_w), 1e-7) << "knot " << i << " step " << step;
      EXPECT_LT(RelativeError(J_a[i], num_a), 1e-7) << "knot " << i << " step " << step;
    }
  }
}

TYPED_TEST(So3SplineTest, JetEvaluationEqualsDoubleEvaluation) {
  constexpr int N = TypeParam::N;
  using Jet = ceres::Jet<double, 4>;
  const auto s = this->RandomSpline(3, 0.8, N);
  std::array<QuatT<Jet>, N> knots;
  std::array<const Jet*, N> ptrs;
  for (int i = 0; i < N; ++i) {
    knots[i] = s.Knot(i).template cast<Jet>();
    ptrs[i] = knots[i].coeffs().data();
  }
  // Derivative with respect to the w coefficient of knot 1 (not on the manifold, but a valid
  // directional derivative of the identical expression) against central differences.
  knots[1].w().v[0] = 1.0;
  typename So3Spline<N>::template Output<Jet> oj;
  So3Spline<N>::EvaluateSegment(ptrs.data(), Jet(0.3), Jet(20.0), 2, true, &oj);
  typename So3Spline<N>::template Output<double> o, op, om;
  const std::int64_t t = s.MinTimeNs() + 15'000'000;
  s.Evaluate(t, 0.0, 2, &o);
  auto sp = s, sm = s;
  const double h = 1e-7;
  sp.Knot(1).w() += h;
  sm.Knot(1).w() -= h;
  sp.Evaluate(t, 0.0, 2, &op);
  sm.Evaluate(t, 0.0, 2, &om);
  for (int r = 0; r < 3; ++r) {
    EXPECT_NEAR(oj.velocity[r].a, o.velocity[r], 1e-12);
    EXPECT_NEAR(oj.acceleration[r].a, o.acceleration[r], 1e-10);
    EXPECT_NEAR(oj.velocity[r].v[0], (op.velocity[r] - om.velocity[r]) / (2 * h), 1e-5);
  }
}

}  // namespace
}  // namespace ctcal
