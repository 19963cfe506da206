// The residual of the intrinsics initialisation's refinement (camera_init.cpp): one board corner
// seen in one view, with analytic Jacobians (the Jets of an autodiff version were most of the
// refinement's time).
#pragma once

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "ctcal/spline/so3.h"

namespace ctcal {

// Blocks: the camera model's parameters, the board's pose in the camera as a quaternion q_C_W
// (Eigen's storage order x, y, z, w; on ceres::EigenQuaternionManifold) and a translation t_C_W.
//   p_C = q_C_W * p_W + t_C_W,  r = pi(params, p_C) - uv
// with Model::Project's pi and its analytic d pi/d p_C and d pi/d params, so
//   dr/d params = d pi/d params,  dr/d t = d pi/d p_C,  dr/d q = d pi/d p_C  d p_C/d q.
// d p_C/d q is that of the formula Eigen evaluates for q * p (Quaternion::_transformVector, which
// assumes |q| = 1), written with q = (v, w):
//   u = 2 v x p,  q * p = p + w u + v x u
// so, with [a]x the cross-product matrix (a x b = [a]x b, and a x b = -[b]x a):
//   d(q * p)/d w = u
//   d(q * p)/d v = w du/dv - [u]x + [v]x du/dv,  du/dv = -2 [p]x
//                = -2 w [p]x - [u]x - 2 [v]x [p]x.
// These are the ambient (4-coefficient) derivatives, as Ceres expects of a block on a manifold:
// it maps them to the 3-dimensional tangent with the manifold's PlusJacobian.
// Evaluate returns false where the model cannot project p_C (the solver then rejects the step).
template <class Model>
class CornerReprojection final : public ceres::SizedCostFunction<2, Model::kNumParams, 4, 3> {
 public:
  CornerReprojection(const Eigen::Vector3d& p_W, const Eigen::Vector2d& uv) : p_W_(p_W), uv_(uv) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const Eigen::Map<const Eigen::Quaterniond> q_C_W(parameters[1]);
    const Eigen::Map<const Eigen::Vector3d> t_C_W(parameters[2]);
    return Compute(parameters[0], q_C_W, t_C_W, p_W_, uv_, residuals,
                   jacobians != nullptr ? jacobians[0] : nullptr,
                   jacobians != nullptr ? jacobians[1] : nullptr,
                   jacobians != nullptr ? jacobians[2] : nullptr);
  }

  // The residual and the Jacobians that are asked for (row-major 2 x kNumParams, 2 x 4, 2 x 3),
  // without Ceres (the intrinsics refinement's own solver calls this).
  static bool Compute(const double* params, const Eigen::Quaterniond& q_C_W,
                      const Eigen::Vector3d& t_C_W, const Eigen::Vector3d& p_W,
                      const Eigen::Vector2d& uv, double* residuals, double* J_params_out,
                      double* J_q_out, double* J_t_out) {
    const Eigen::Vector3d p_C = q_C_W * p_W + t_C_W;
    const bool J_params = J_params_out != nullptr;
    const bool J_pose = J_q_out != nullptr || J_t_out != nullptr;
    Eigen::Vector2d uv_hat;
    Eigen::Matrix<double, 2, 3> J_uv_p;
    Eigen::Matrix<double, 2, Model::kNumParams> J_uv_params;
    if (!Model::Project(params, p_C, &uv_hat, J_pose ? &J_uv_p : nullptr,
                        J_params ? &J_uv_params : nullptr))
      return false;
    Eigen::Map<Eigen::Vector2d> r(residuals);
    r = uv_hat - uv;
    if (J_params) {
      Eigen::Map<Eigen::Matrix<double, 2, Model::kNumParams, Eigen::RowMajor>> J(J_params_out);
      J = J_uv_params;
    }
    if (J_q_out != nullptr) {
      const Eigen::Vector3d v = q_C_W.vec();
      const Eigen::Vector3d u = 2.0 * v.cross(p_W);
      const Eigen::Matrix3d P = Hat<double>(p_W);
      Eigen::Matrix<double, 3, 4> J_p_q;
      J_p_q.leftCols<3>() = -2.0 * q_C_W.w() * P - Hat<double>(u) - 2.0 * Hat<double>(v) * P;
      J_p_q.col(3) = u;
      Eigen::Map<Eigen::Matrix<double, 2, 4, Eigen::RowMajor>> J(J_q_out);
      J = J_uv_p * J_p_q;
    }
    if (J_t_out != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> J(J_t_out);
      J = J_uv_p;
    }
    return true;
  }

 private:
  Eigen::Vector3d p_W_;
  Eigen::Vector2d uv_;
};

}  // namespace ctcal
