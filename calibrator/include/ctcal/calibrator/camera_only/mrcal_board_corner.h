// The camera-only corner residual for an mrcal lens (camera_model mrcal); mrcal's regularisation
// of its parameters is residuals/mrcal_regularization.h.
//
// Residual (the same as the fixed models' BoardCornerResidual, camera_only_calibrator.cpp):
//   p_C = BoardPointInCamera(p_W, T_W_B, T_B_C),   r = (pi(theta, p_C) - uv) / sigma.
// The projection pi and its gradients d pi / d p_C (2x3) and d pi / d theta (2xN) are mrcal's
// (mrcal_project); only the rigid part p_C(q_W_B, p_W_B, q_B_C, p_B_C) is differentiated here, by
// forward-mode autodiff on its 14 inputs. The chain rule then gives
//   d r / d pose block = (d pi / d p_C) (d p_C / d block) / sigma,   d r / d theta = d pi / d theta
//   / sigma,
// one mrcal call per corner and evaluation, whatever N (a splined model has hundreds of
// parameters, so autodiff through them would cost N / 4 passes).
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Geometry>
#include <memory>

#include "ctcal/sensors/mrcal_lens.h"

namespace ctcal {

// p_B = R_W_B^T (p_W - p_W_B),  p_C = R_B_C^T (p_B - p_B_C); quaternions Eigen's x, y, z, w.
template <typename T>
Eigen::Matrix<T, 3, 1> BoardPointInCamera(const Eigen::Vector3d& p_W, const T* q_W_B,
                                          const T* p_W_B, const T* q_B_C, const T* p_B_C) {
  const Eigen::Map<const Eigen::Quaternion<T>> R_W_B(q_W_B);
  const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_W_B(p_W_B);
  const Eigen::Map<const Eigen::Quaternion<T>> R_B_C(q_B_C);
  const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_B_C(p_B_C);
  const Eigen::Matrix<T, 3, 1> p_B = R_W_B.conjugate() * (p_W.cast<T>() - t_W_B);
  return R_B_C.conjugate() * (p_B - t_B_C);
}

// Blocks: q_W_B (4), p_W_B (3), q_B_C (4), p_B_C (3), theta (lens->NumParams()).
class MrcalBoardCornerCost final : public ceres::CostFunction {
 public:
  MrcalBoardCornerCost(std::shared_ptr<const MrcalLens> lens, const Eigen::Vector3d& p_W,
                       const Eigen::Vector2d& uv, double sigma)
      : lens_(std::move(lens)), p_W_(p_W), uv_(uv), inv_sigma_(1.0 / sigma) {
    set_num_residuals(2);
    *mutable_parameter_block_sizes() = {4, 3, 4, 3, lens_->NumParams()};
  }

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    using Jet = ceres::Jet<double, 14>;
    constexpr int kOffset[4] = {0, 4, 7, 11};
    constexpr int kSize[4] = {4, 3, 4, 3};
    Jet x[4][4];
    for (int b = 0; b < 4; ++b)
      for (int i = 0; i < kSize[b]; ++i)
        x[b][i] = Jet(p[b][i], kOffset[b] + i);
    const Eigen::Matrix<Jet, 3, 1> p_C = BoardPointInCamera<Jet>(p_W_, x[0], x[1], x[2], x[3]);
    const Eigen::Vector3d p_C_value(p_C(0).a, p_C(1).a, p_C(2).a);
    Eigen::Vector2d uv;
    Eigen::Matrix<double, 2, 3> J_uv_p;
    Eigen::Matrix<double, 2, Eigen::Dynamic> J_uv_theta;
    const bool want = jacobians != nullptr;
    if (!lens_->Project(p[4], p_C_value, &uv, want ? &J_uv_p : nullptr,
                        want && jacobians[4] ? &J_uv_theta : nullptr))
      return false;
    residuals[0] = (uv.x() - uv_.x()) * inv_sigma_;
    residuals[1] = (uv.y() - uv_.y()) * inv_sigma_;
    if (!want)
      return true;
    Eigen::Matrix<double, 3, 14> J_p_x;
    for (int r = 0; r < 3; ++r)
      J_p_x.row(r) = p_C(r).v.transpose();
    const Eigen::Matrix<double, 2, 14> J = inv_sigma_ * J_uv_p * J_p_x;
    for (int b = 0; b < 4; ++b) {
      if (!jacobians[b])
        continue;
      Eigen::Map<Eigen::Matrix<double, 2, Eigen::Dynamic, Eigen::RowMajor>> out(jacobians[b], 2,
                                                                                kSize[b]);
      out = J.middleCols(kOffset[b], kSize[b]);
    }
    if (jacobians[4]) {
      Eigen::Map<Eigen::Matrix<double, 2, Eigen::Dynamic, Eigen::RowMajor>> out(jacobians[4], 2,
                                                                                lens_->NumParams());
      out = inv_sigma_ * J_uv_theta;
    }
    return true;
  }

 private:
  std::shared_ptr<const MrcalLens> lens_;
  Eigen::Vector3d p_W_;
  Eigen::Vector2d uv_;
  double inv_sigma_;
};

}  // namespace ctcal
