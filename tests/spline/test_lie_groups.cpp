// so3.h and se3.h: Exp/Log round trips (near 0, generic, near pi), Jacobians against central
// differences, inverses, adjoint identities, on double and on ceres::Jet.
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <random>

#include "ctcal/spline/se3.h"
#include "spline_test_utils.h"

namespace ctcal {
namespace {

using testing::CentralDifference;
using testing::RelativeError;

std::vector<Eigen::Vector3d> TestRotationVectors() {
  std::mt19937 rng(1);
  std::vector<Eigen::Vector3d> out = {Eigen::Vector3d::Zero(), Eigen::Vector3d(1e-9, -2e-9, 5e-10),
                                      Eigen::Vector3d(1e-5, 2e-6, -3e-6),
                                      Eigen::Vector3d(0.05, -0.02, 0.07)};
  for (int i = 0; i < 5; ++i)
    out.push_back(testing::RandomVector(&rng, 1.5));
  out.push_back(Eigen::Vector3d(0.0, 0.0, M_PI - 1e-6));
  out.push_back(Eigen::Vector3d(1.0, -1.0, 0.5).normalized() * (M_PI - 1e-3));
  return out;
}

TEST(So3Test, ExpLogRoundTrip) {
  for (const Eigen::Vector3d& phi : TestRotationVectors()) {
    const Eigen::Vector3d back = LogSO3<double>(ExpSO3<double>(phi));
    EXPECT_LT((back - phi).norm(), 1e-9 * std::max(1.0, 1.0 / (M_PI - phi.norm())))
        << phi.transpose();
    EXPECT_LT((ExpSO3Matrix<double>(phi) - ExpSO3<double>(phi).toRotationMatrix()).norm(), 1e-14);
  }
  // Exactly pi: either sign of the axis is the same rotation.
  const Eigen::Vector3d pi_z(0, 0, M_PI);
  const Eigen::Vector3d back = LogSO3<double>(ExpSO3<double>(pi_z));
  EXPECT_NEAR(back.norm(), M_PI, 1e-12);
  EXPECT_LT(
      (ExpSO3<double>(back).toRotationMatrix() - ExpSO3<double>(pi_z).toRotationMatrix()).norm(),
      1e-12);
}

TEST(So3Test, RightJacobianMatchesCentralDifferences) {
  for (const Eigen::Vector3d& phi : TestRotationVectors()) {
    if (phi.norm() > 3.0)
      continue;  // Log jumps at pi: finite differences are meaningless there.
    const Eigen::Quaterniond q = ExpSO3<double>(phi);
    // Exp(phi + d) = Exp(phi) Exp(Jr d)  =>  Jr = d/dd Log(Exp(phi)^-1 Exp(phi + d)).
    const Eigen::MatrixXd Jr = CentralDifference(
        [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
          return LogSO3<double>(q.conjugate() * ExpSO3<double>(phi + Eigen::Vector3d(d)));
        },
        3);
    EXPECT_LT(RelativeError(RightJacobianSO3<double>(phi), Jr), 1e-8) << phi.transpose();
    EXPECT_LT(RelativeError(RightJacobianInvSO3<double>(phi) * RightJacobianSO3<double>(phi),
                            Eigen::Matrix3d::Identity()),
              1e-12);
    const Eigen::MatrixXd Jl = CentralDifference(
        [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
          return LogSO3<double>(ExpSO3<double>(phi + Eigen::Vector3d(d)) * q.conjugate());
        },
        3);
    EXPECT_LT(RelativeError(LeftJacobianSO3<double>(phi), Jl), 1e-8) << phi.transpose();
    EXPECT_LT(RelativeError(LeftJacobianInvSO3<double>(phi) * LeftJacobianSO3<double>(phi),
                            Eigen::Matrix3d::Identity()),
              1e-12);
  }
}

TEST(So3Test, JetLogOfExpHasIdentityDerivative) {
  using Jet = ceres::Jet<double, 3>;
  for (const Eigen::Vector3d& phi : TestRotationVectors()) {
    if (phi.norm() > 3.0)
      continue;
    Vec3T<Jet> p;
    for (int i = 0; i < 3; ++i)
      p[i] = Jet(phi[i], i);
    const Vec3T<Jet> back = LogSO3<Jet>(ExpSO3<Jet>(p));
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(back[i].a, phi[i], 1e-12);
      for (int j = 0; j < 3; ++j)
        EXPECT_NEAR(back[i].v[j], i == j ? 1.0 : 0.0, 1e-9);
    }
  }
}

std::vector<Vec6T<double>> TestTwists() {
  std::vector<Vec6T<double>> out;
  for (const Eigen::Vector3d& phi : TestRotationVectors()) {
    if (phi.norm() > 3.0)
      continue;
    Vec6T<double> xi;
    xi << 0.3 - phi.y(), -1.2, 0.7 + phi.x(), phi;
    out.push_back(xi);
  }
  return out;
}

TEST(Se3Test, ExpLogRoundTripAndExpMatchesTheMatrixExponential) {
  for (const Vec6T<double>& xi : TestTwists()) {
    const PoseT<double> T = ExpSE3<double>(xi);
    EXPECT_LT((LogSE3<double>(T) - xi).norm(), 1e-10) << xi.transpose();
    Eigen::Matrix4d X = Eigen::Matrix4d::Zero();
    X.topLeftCorner<3, 3>() = Hat<double>(xi.tail<3>());
    X.topRightCorner<3, 1>() = xi.head<3>();
    // Truncated power series of the 4x4 exponential: converges for these small twists.
    Eigen::Matrix4d E = Eigen::Matrix4d::Identity(), term = Eigen::Matrix4d::Identity();
    for (int k = 1; k < 40; ++k) {
      term = term * X / k;
      E += term;
    }
    EXPECT_LT((E.topLeftCorner<3, 3>() - T.R).norm(), 1e-12);
    EXPECT_LT((E.topRightCorner<3, 1>() - T.t).norm(), 1e-10);
  }
}

TEST(Se3Test, RightAndLeftJacobiansMatchCentralDifferences) {
  for (const Vec6T<double>& xi : TestTwists()) {
    const PoseT<double> T = ExpSE3<double>(xi);
    const Eigen::MatrixXd Jr = CentralDifference(
        [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
          return LogSE3<double>(T.Inverse() * ExpSE3<double>(xi + Vec6T<double>(d)));
        },
        6);
    EXPECT_LT(RelativeError(RightJacobianSE3<double>(xi), Jr), 1e-8)
        << xi.transpose() << "\n"
        << RightJacobianSE3<double>(xi) << "\n"
        << Jr;
    const Eigen::MatrixXd Jl = CentralDifference(
        [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
          return LogSE3<double>(ExpSE3<double>(xi + Vec6T<double>(d)) * T.Inverse());
        },
        6);
    EXPECT_LT(RelativeError(LeftJacobianSE3<double>(xi), Jl), 1e-8) << xi.transpose();
    EXPECT_LT(RelativeError(RightJacobianInvSE3<double>(xi) * RightJacobianSE3<double>(xi),
                            Mat6T<double>::Identity()),
              1e-12);
    EXPECT_LT(RelativeError(LeftJacobianInvSE3<double>(xi) * LeftJacobianSE3<double>(xi),
                            Mat6T<double>::Identity()),
              1e-12);
  }
}

// The Taylor branch of Q (theta < 0.1) and the closed form agree where they meet.
TEST(Se3Test, LeftJacobianIsContinuousAcrossTheSmallAngleBranch) {
  Vec6T<double> below, above;
  below << 0.4, -0.3, 1.1, Eigen::Vector3d(1.0, 2.0, -0.5).normalized() * (0.1 - 1e-9);
  above = below;
  above.tail<3>() = Eigen::Vector3d(1.0, 2.0, -0.5).normalized() * (0.1 + 1e-9);
  EXPECT_LT((LeftJacobianSE3<double>(below) - LeftJacobianSE3<double>(above)).norm(), 1e-8);
}

TEST(Se3Test, AdjointConjugatesExpAndSmallAdjointIsTheBracket) {
  std::mt19937 rng(4);
  for (int i = 0; i < 5; ++i) {
    Vec6T<double> a, b;
    a << testing::RandomVector(&rng, 1.0), testing::RandomVector(&rng, 1.0);
    b << testing::RandomVector(&rng, 0.5), testing::RandomVector(&rng, 0.5);
    const PoseT<double> T = ExpSE3<double>(a);
    // T Exp(b) T^-1 = Exp(Ad(T) b).
    const PoseT<double> lhs = T * ExpSE3<double>(b) * T.Inverse();
    const PoseT<double> rhs = ExpSE3<double>(AdjointSE3<double>(T) * b);
    EXPECT_LT((lhs.R - rhs.R).norm() + (lhs.t - rhs.t).norm(), 1e-12);
    // d/ds Ad(Exp(s a)) b at s = 0 = ad(a) b.
    const double h = 1e-6;
    const Vec6T<double> num = (AdjointSE3<double>(ExpSE3<double>(h * a)) * b -
                               AdjointSE3<double>(ExpSE3<double>(-h * a)) * b) /
                              (2 * h);
    EXPECT_LT((num - SmallAdjointSE3<double>(a) * b).norm(), 1e-8);
  }
}

}  // namespace
}  // namespace ctcal
