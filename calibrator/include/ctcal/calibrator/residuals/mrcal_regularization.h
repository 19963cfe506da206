// mrcal's regularisation of an mrcal lens's parameters (MrcalLens::MakeRegularization), one
// residual block per camera whose intrinsics are estimated, in the camera-only and the
// visual-inertial problem alike. Without it a rational OPENCV8's radial numerator and denominator
// trade against each other and against the focal length (the covariance calls them
// undetermined), and a splined model's control points outside the observed area are free.
//
// Residual: r_i = w_i (theta_i - target_i) for the regularised parameters (w_i > 0), so
// d r_i / d theta_j = w_i [i == j]. The corners are whitened, r = (pi - uv) / sigma, each
// squared residual expecting 1; MakeRegularization chooses w_i on that scale.
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <utility>
#include <vector>

#include "ctcal/sensors/mrcal_lens.h"

namespace ctcal {

class MrcalRegularizationCost final : public ceres::CostFunction {
 public:
  explicit MrcalRegularizationCost(MrcalLens::Regularization reg) : reg_(std::move(reg)) {
    for (Eigen::Index i = 0; i < reg_.weight.size(); ++i)
      if (reg_.weight(i) > 0.0)
        index_.push_back(static_cast<int>(i));
    set_num_residuals(static_cast<int>(index_.size()));
    *mutable_parameter_block_sizes() = {static_cast<int>(reg_.weight.size())};
  }
  int NumTerms() const { return static_cast<int>(index_.size()); }

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    const auto n = static_cast<Eigen::Index>(reg_.weight.size());
    for (std::size_t k = 0; k < index_.size(); ++k)
      residuals[k] = reg_.weight(index_[k]) * (p[0][index_[k]] - reg_.target(index_[k]));
    if (jacobians && jacobians[0]) {
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> J(
          jacobians[0], static_cast<Eigen::Index>(index_.size()), n);
      J.setZero();
      for (std::size_t k = 0; k < index_.size(); ++k)
        J(static_cast<Eigen::Index>(k), index_[k]) = reg_.weight(index_[k]);
    }
    return true;
  }

 private:
  MrcalLens::Regularization reg_;
  std::vector<int> index_;
};

}  // namespace ctcal
