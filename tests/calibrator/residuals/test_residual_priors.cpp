// Priors and the bias random walk: values in the stated conventions (the rotation prior's tangent
// is the full angle of the LEFT perturbation, component for component), whitening, analytic
// Jacobians against autodiff and central differences, and one clear error for bad sigmas.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>

#include "ctcal/calibrator/residuals/bias_random_walk_residual.h"
#include "ctcal/calibrator/residuals/prior_residuals.h"
#include "residual_test_utils.h"

namespace ctcal {
namespace {

// Log(Exp(d) R0 R0^T) = d exactly: the prior's residual is the left tangent d over sigma, for
// large angles too.
TEST(RotationPrior, ResidualIsTheLeftTangentOverSigma) {
  std::mt19937 rng(1);
  const Eigen::Quaterniond q0 = testing::RandomRotation(&rng, 3.0);
  const Eigen::Vector3d sigma(0.01, 0.02, 0.5);
  for (const double angle : {1e-6, 0.01, 0.5, 2.0}) {
    const Eigen::Vector3d d = testing::RandomVector(&rng, 1.0).normalized() * angle;
    Eigen::Quaterniond q = (ExpSO3<double>(d) * q0).normalized();
    for (const bool analytic : {true, false}) {
      std::unique_ptr<ceres::CostFunction> cost(MakeRotationPrior(analytic, q0, sigma));
      const testing::Evaluation e = testing::EvaluateCost(*cost, {q.coeffs().data()}, false);
      EXPECT_LT((e.r - d.cwiseQuotient(sigma)).norm(), 1e-9 * std::max(1.0, e.r.norm()))
          << "angle " << angle << (analytic ? " analytic" : " autodiff");
    }
  }
}

TEST(RotationPrior, AnalyticMatchesAutoDiffAndCentralDifferences) {
  std::mt19937 rng(2);
  const Eigen::Quaterniond q0 = testing::RandomRotation(&rng, 3.0);
  const Eigen::Vector3d sigma(0.01, 0.02, 0.03);
  Eigen::Quaterniond q = (ExpSO3<double>(Eigen::Vector3d(0.3, -0.2, 0.4)) * q0).normalized();
  std::unique_ptr<ceres::CostFunction> analytic(MakeRotationPrior(true, q0, sigma));
  std::unique_ptr<ceres::CostFunction> autodiff(MakeRotationPrior(false, q0, sigma));
  testing::ExpectAnalyticMatchesAutoDiffAndNumeric(*analytic, *autodiff, {q.coeffs().data()},
                                                   {testing::LeftRotationManifold()}, "rotation");
}

TEST(VectorPrior, WhitenedDifferenceAndJacobians) {
  Eigen::VectorXd x0(4), sigma(4), x(4);
  x0 << 1.0, -2.0, 0.5, 3.0;
  sigma << 0.1, 0.2, 1e-4, 10.0;
  x << 1.1, -2.4, 0.5003, -7.0;
  std::unique_ptr<ceres::CostFunction> analytic(MakeVectorPrior(true, x0, sigma));
  std::unique_ptr<ceres::CostFunction> autodiff(MakeVectorPrior(false, x0, sigma));
  const testing::Evaluation e = testing::EvaluateCost(*analytic, {x.data()});
  Eigen::VectorXd expected(4);
  expected << 1.0, -2.0, 3.0, -1.0;
  EXPECT_LT((e.r - expected).norm(), 1e-9);
  testing::ExpectAnalyticMatchesAutoDiffAndNumeric(*analytic, *autodiff, {x.data()}, {nullptr},
                                                   "vector");
}

TEST(Priors, RejectBadSigmas) {
  EXPECT_THROW(MakeRotationPrior(true, Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 0, 1)),
               std::invalid_argument);
  EXPECT_THROW(MakeVectorPrior(true, Eigen::VectorXd::Zero(2), Eigen::VectorXd::Ones(3)),
               std::invalid_argument);
  EXPECT_THROW(MakeVectorPrior(true, Eigen::VectorXd::Zero(1), Eigen::VectorXd::Constant(1, NAN)),
               std::invalid_argument);
}

// r = (b_k+1 - b_k) / (sigma_bc sqrt(dt_b)): a step of one random-walk sigma is a residual of 1.
TEST(BiasRandomWalkResidual, WhitenedByTheRandomWalkOverTheKnotSpacing) {
  const double random_walk = 3e-3;
  const double dt_b = 0.25;
  const double step_sigma = random_walk * std::sqrt(dt_b);
  Eigen::Vector3d b0(0.1, -0.2, 0.3);
  Eigen::Vector3d b1 = b0 + Eigen::Vector3d(step_sigma, -2.0 * step_sigma, 0.0);
  for (const bool analytic : {true, false}) {
    std::unique_ptr<ceres::CostFunction> cost(
        MakeBiasRandomWalkResidual(analytic, random_walk, dt_b));
    const testing::Evaluation e =
        testing::EvaluateCost(*cost, BiasRandomWalkResidual::Blocks({b0.data(), b1.data()}), false);
    EXPECT_LT((e.r - Eigen::Vector3d(1.0, -2.0, 0.0)).norm(), 1e-9);
  }
  std::unique_ptr<ceres::CostFunction> analytic(
      MakeBiasRandomWalkResidual(true, random_walk, dt_b));
  std::unique_ptr<ceres::CostFunction> autodiff(
      MakeBiasRandomWalkResidual(false, random_walk, dt_b));
  testing::ExpectAnalyticMatchesAutoDiffAndNumeric(*analytic, *autodiff, {b0.data(), b1.data()},
                                                   {nullptr, nullptr}, "bias random walk");
  EXPECT_THROW(MakeBiasRandomWalkResidual(true, 0.0, dt_b), std::invalid_argument);
  EXPECT_THROW(MakeBiasRandomWalkResidual(true, random_walk, -1.0), std::invalid_argument);
}

}  // namespace
}  // namespace ctcal
