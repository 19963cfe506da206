// Random-walk tie between two consecutive knots of a bias spline.
//
// Model (inertial_noise.h, Kalibr's IMU noise model): a bias is a Wiener process of density
// sigma_bc (the sensor's *_random_walk), so over the knot spacing dt_b its change is
// N(0, sigma_bc^2 dt_b I). Treating consecutive knots as bias states dt_b apart,
//   r = (b_{k+1} - b_k) / (sigma_bc sqrt(dt_b))   ~ N(0, I_3),
// d r / d b_k = -I / (sigma_bc sqrt(dt_b)),  d r / d b_{k+1} = +I / (sigma_bc sqrt(dt_b)).
// (A spline's knots are not its values, so for order Nb > 2 this is the usual approximation of
// the continuous prior integral |db/dt|^2 / sigma_bc^2 dt; it is exact for Nb = 2.)
#pragma once

#include <ceres/ceres.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "ctcal/calibrator/residuals/residual_support.h"

namespace ctcal {

class BiasRandomWalkResidual {
 public:
  static constexpr int kNumResiduals = 3;
  static constexpr int kB0 = 0;
  static constexpr int kB1 = 1;

  struct Parameters {
    double* b_k = nullptr;
    double* b_k1 = nullptr;
  };
  static std::vector<double*> Blocks(const Parameters& p) { return {p.b_k, p.b_k1}; }

  // random_walk: sigma_bc (units/s/sqrt(s)); dt_b: the knot spacing in seconds.
  static double Weight(double random_walk, double dt_b) {
    if (!(random_walk > 0.0) || !(dt_b > 0.0) || !std::isfinite(random_walk * dt_b))
      throw std::invalid_argument(
          "BiasRandomWalkResidual: random walk and knot spacing must be "
          "positive and finite, got " +
          std::to_string(random_walk) + ", " + std::to_string(dt_b));
    return 1.0 / (random_walk * std::sqrt(dt_b));
  }

  // (a) The templated functor.
  struct Functor {
    double weight;
    template <typename T>
    bool operator()(const T* b_k, const T* b_k1, T* residuals) const {
      for (int i = 0; i < 3; ++i)
        residuals[i] = (b_k1[i] - b_k[i]) * T(weight);
      return true;
    }
  };

  // (b) The analytic cost function.
  class Analytic final : public ceres::SizedCostFunction<3, 3, 3> {
   public:
    explicit Analytic(double weight) : weight_(weight) {}
    bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
      for (int i = 0; i < 3; ++i)
        residuals[i] = (p[kB1][i] - p[kB0][i]) * weight_;
      if (jacobians == nullptr)
        return true;
      using residual_internal::Jacobian;
      if (jacobians[kB0] != nullptr)
        Jacobian<3, 3>(jacobians[kB0]) = -weight_ * Eigen::Matrix3d::Identity();
      if (jacobians[kB1] != nullptr)
        Jacobian<3, 3>(jacobians[kB1]) = weight_ * Eigen::Matrix3d::Identity();
      return true;
    }

   private:
    double weight_;
  };
};

inline ceres::CostFunction* MakeBiasRandomWalkResidual(bool analytic, double random_walk,
                                                       double dt_b) {
  const double weight = BiasRandomWalkResidual::Weight(random_walk, dt_b);
  if (analytic)
    return new BiasRandomWalkResidual::Analytic(weight);
  return new ceres::AutoDiffCostFunction<BiasRandomWalkResidual::Functor, 3, 3, 3>(
      new BiasRandomWalkResidual::Functor{weight});
}

}  // namespace ctcal
