// Every manifold of so3_manifold.h: Ceres' own invariant matchers (Plus/Minus round trips,
// PlusJacobian and MinusJacobian against numeric differentiation, MinusJacobian * PlusJacobian = I)
// at identity, near identity and at random points, plus the perturbation side and angle scale each
// one documents.
#include "ctcal/spline/so3_manifold.h"

#include <ceres/manifold_test_utils.h>
#include <gtest/gtest.h>

#include "ctcal/spline/se3.h"
#include "spline_test_utils.h"

namespace ctcal {
namespace {

Eigen::VectorXd RandomPoint(const ceres::Manifold& m, std::mt19937* rng, double angle) {
  Eigen::VectorXd x(m.AmbientSize());
  x.head<4>() = testing::RandomRotation(rng, angle).coeffs();
  if (m.AmbientSize() == 7)
    x.tail<3>() = testing::RandomVector(rng, 2.0);
  return x;
}

template <typename M>
void CheckInvariants(double angle, double tolerance) {
  // Ceres' invariant macro names its matchers unqualified.
  using namespace ceres;  // NOLINT(build/namespaces)
  const M manifold;
  std::mt19937 rng(17);
  for (int i = 0; i < 10; ++i) {
    const Eigen::VectorXd x = RandomPoint(manifold, &rng, angle);
    Eigen::VectorXd y = RandomPoint(manifold, &rng, angle);
    // q and -q are one rotation; Ceres compares Plus(x, Minus(y, x)) with y coefficient-wise, so
    // y takes the representative Plus produces (positive w of x^-1 y, Log's principal branch).
    const Eigen::Quaterniond qx(x.head<4>()), qy(y.head<4>());
    if ((qx.conjugate() * qy).w() < 0)
      y.head<4>() = -y.head<4>();
    // |delta| < pi: Minus(Plus(x, delta), x) = delta only holds inside Log's principal range.
    Eigen::VectorXd delta(manifold.TangentSize());
    for (int k = 0; k < delta.size(); k += 3) {
      delta.segment<3>(k) = LogSO3<double>(testing::RandomRotation(&rng, std::min(angle, 3.0)));
    }
    EXPECT_THAT_MANIFOLD_INVARIANTS_HOLD(manifold, x, delta, y, tolerance);
  }
}

// Near identity the Plus/Minus round trip of a 1e-7 step is relative to the step, while the
// rounding of t + R rho is relative to |t| ~ 1: 1e-16 / 1e-7 = 1e-9 is the floor.
constexpr double kTinyTolerance = 1e-7;

TEST(So3LeftManifoldTest, InvariantsHold) {
  CheckInvariants<So3LeftManifold>(3.6, 1e-9);
  CheckInvariants<So3LeftManifold>(1e-7, kTinyTolerance);
}
TEST(So3RightManifoldTest, InvariantsHold) {
  CheckInvariants<So3RightManifold>(3.6, 1e-9);
  CheckInvariants<So3RightManifold>(1e-7, kTinyTolerance);
}
TEST(Se3RightManifoldTest, InvariantsHold) {
  CheckInvariants<Se3RightManifold>(3.6, 1e-9);
  CheckInvariants<Se3RightManifold>(1e-7, kTinyTolerance);
}

TEST(ManifoldSideTest, LeftAndRightPerturbTheDocumentedSideWithTheFullAngle) {
  const Eigen::Quaterniond q = ExpSO3<double>(Eigen::Vector3d(0.3, -0.5, 1.0));
  const Eigen::Vector3d d(0.01, 0.02, -0.03);
  Eigen::Quaterniond left, right;
  So3LeftManifold().Plus(q.coeffs().data(), d.data(), left.coeffs().data());
  So3RightManifold().Plus(q.coeffs().data(), d.data(), right.coeffs().data());
  EXPECT_LT((left.toRotationMatrix() - ExpSO3Matrix<double>(d) * q.toRotationMatrix()).norm(),
            1e-14);
  EXPECT_LT((right.toRotationMatrix() - q.toRotationMatrix() * ExpSO3Matrix<double>(d)).norm(),
            1e-14);

  Eigen::Matrix<double, 7, 1> x, x_plus;
  x << q.coeffs(), 1.0, -2.0, 0.5;
  Vec6T<double> xi;
  xi << 0.1, 0.2, -0.3, d;
  Se3RightManifold().Plus(x.data(), xi.data(), x_plus.data());
  const PoseT<double> expected =
      PoseT<double>{q.toRotationMatrix(), x.tail<3>()} * ExpSE3<double>(xi);
  EXPECT_LT((Eigen::Quaterniond(x_plus.head<4>()).toRotationMatrix() - expected.R).norm(), 1e-14);
  EXPECT_LT((x_plus.tail<3>() - expected.t).norm(), 1e-14);
}

// A tangent Jacobian lifted to the ambient space maps back to itself through PlusJacobian.
TEST(ManifoldSideTest, LiftToAmbientRoundTripsThroughPlusJacobian) {
  std::mt19937 rng(3);
  const Se3RightManifold se3;
  const Eigen::VectorXd x = RandomPoint(se3, &rng, 2.0);
  const Eigen::MatrixXd J_tangent = Eigen::MatrixXd::Random(3, 6);
  Eigen::Matrix<double, 3, 7, Eigen::RowMajor> J_ambient;
  LiftToAmbient(&se3, x.data(), J_tangent, J_ambient.data());
  Eigen::Matrix<double, 7, 6, Eigen::RowMajor> P;
  se3.PlusJacobian(x.data(), P.data());
  EXPECT_LT((J_ambient * P - J_tangent).norm(), 1e-12);
}

}  // namespace
}  // namespace ctcal
