// Every corner of one camera frame of the camera-only calibration as one residual block: the
// corners compressed over the frame's camera pose and intrinsics (frame_corners_compression.h,
// derived in frame_corners_residual.h), chained to the board pose T_W_B[k], the camera's T_B_C and
// its intrinsics (camera_only_calibrator.h).
//
// Model: corner i predicts uv_i = pi(theta, p_C,i) with
//   p_C,i = R_C_W p_W,i + t_C_W,   R_C_W = R_B_C^T R_W_B^T,   t_C_W = -R_C_W p_W_B - R_B_C^T t_B_C,
// whitened by its sigma. The compression returns r = [z; last] with Jacobian [R; 0] in the
// frame-local x = (dtheta, dt, dparams), which perturbs p_C -> Exp(dtheta) p_C + dt. The chain
// rule to the blocks, from dp_C = -[p_C]x dtheta + dt:
//   T_W_B rotation (left, R_W_B -> Exp(d) R_W_B): R_C_W -> R_C_W Exp(-d), so with
//     a = p_W - p_W_B and R_C_W a = p_C + R_B_C^T t_B_C,
//     dp_C = R_C_W [a]x d = [p_C]x R_C_W d + [R_B_C^T t_B_C]x R_C_W d:
//     dtheta = -R_C_W,  dt = [R_B_C^T t_B_C]x R_C_W;
//   T_W_B position: dtheta = 0, dt = -R_C_W;
//   q_B_C (left, R_B_C -> Exp(d) R_B_C): dp_C = [p_C]x R_B_C^T d:  dtheta = -R_B_C^T, dt = 0;
//   t_B_C: dtheta = 0, dt = -R_B_C^T;
//   params: the identity on dparams.
// The block's Jacobian of each is R times these, lifted onto the ambient coordinates
// (residual_support.h). Cost, gradient and Gauss-Newton Hessian equal the per-corner blocks'
// (with Huber: Ceres' per-corner HuberLoss, reproduced by the compression's weights and
// remainder row), so Levenberg-Marquardt takes the same steps; the Jet work of every corner
// becomes one QR of the frame, and Ceres' Schur complement eliminates one 6-D pose per frame.
//
// The board pose is one parameter block of 7 doubles, [q_W_B (x, y, z, w), p_W_B], on
// BoardPoseManifold: one e-block per frame for the Schur eliminator (as two blocks, only one of
// them could be eliminated: a residual block may touch one e-block only).
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "ctcal/calibrator/residuals/frame_corners_compression.h"
#include "ctcal/calibrator/residuals/residual_support.h"
#include "ctcal/sensors/camera_model.h"
#include "ctcal/spline/so3_manifold.h"

namespace ctcal {

// [q_W_B, p_W_B]: the rotation on So3LeftManifold (SPEC's perturbation), the position Euclidean.
using BoardPoseManifold = ceres::ProductManifold<So3LeftManifold, ceres::EuclideanManifold<3>>;

template <class Model>
class BoardFrameCorners final
    : public ceres::SizedCostFunction<6 + Model::kNumParams + 1, 7, 4, 3, Model::kNumParams> {
 public:
  static constexpr int kNx = 6 + Model::kNumParams;
  static constexpr int kRows = kNx + 1;

  // `count` corners held by the caller (they must outlive the block); huber_threshold > 0: the
  // robust stage (threshold on a corner's whitened error norm), 0: plain L2.
  BoardFrameCorners(const CornerMeasurement* corners, int count, double huber_threshold)
      : corners_(corners), count_(count), huber_(huber_threshold) {}

  // Blocks: T_W_B (7), q_B_C (4), t_B_C (3), params.
  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    using residual_internal::Jacobian;
    const Eigen::Matrix3d R_W_B = Eigen::Map<const Eigen::Quaterniond>(p[0]).toRotationMatrix();
    const Eigen::Map<const Eigen::Vector3d> p_W_B(p[0] + 4);
    const Eigen::Matrix3d R_C_B =
        Eigen::Map<const Eigen::Quaterniond>(p[1]).toRotationMatrix().transpose();
    const Eigen::Map<const Eigen::Vector3d> t_B_C(p[2]);
    const Eigen::Matrix3d R_C_W = R_C_B * R_W_B.transpose();
    const Eigen::Vector3d t_C_W = -R_C_W * p_W_B - R_C_B * t_B_C;
    Eigen::Matrix<double, kNx, kNx> R;
    if (!CompressFrameCorners<Model>(corners_, count_, p[3], R_C_W, t_C_W, huber_, residuals, &R))
      return false;
    if (jacobians == nullptr)
      return true;
    // R's pose columns with the remainder row's zeros appended.
    Eigen::Matrix<double, kRows, 3> R_rot, R_t;
    R_rot.template topRows<kNx>() = R.template leftCols<3>();
    R_t.template topRows<kNx>() = R.template middleCols<3>(3);
    R_rot.template bottomRows<1>().setZero();
    R_t.template bottomRows<1>().setZero();
    Eigen::Matrix<double, 3, 4, Eigen::RowMajor> M;
    if (jacobians[0] != nullptr) {
      const Eigen::Matrix<double, kRows, 3> J_rot =
          -R_rot * R_C_W + R_t * (Hat<double>(Eigen::Vector3d(R_C_B * t_B_C)) * R_C_W);
      So3LeftManifold().MinusJacobian(p[0], M.data());
      auto J = Jacobian<kRows, 7>(jacobians[0]);
      J.template leftCols<4>() = J_rot * M;
      J.template rightCols<3>() = -R_t * R_C_W;
    }
    if (jacobians[1] != nullptr) {
      So3LeftManifold().MinusJacobian(p[1], M.data());
      Jacobian<kRows, 4>(jacobians[1]) = (-R_rot * R_C_B) * M;
    }
    if (jacobians[2] != nullptr)
      Jacobian<kRows, 3>(jacobians[2]) = -R_t * R_C_B;
    if (jacobians[3] != nullptr) {
      auto J = Jacobian<kRows, Model::kNumParams>(jacobians[3]);
      J.template topRows<kNx>() = R.template rightCols<Model::kNumParams>();
      J.template bottomRows<1>().setZero();
    }
    return true;
  }

 private:
  const CornerMeasurement* corners_;
  int count_;
  double huber_;
};

// The frame block for the camera model `type` on `count` corners held by the caller.
inline ceres::CostFunction* MakeBoardFrameCorners(CameraModelType type,
                                                  const CornerMeasurement* corners, int count,
                                                  double huber_threshold) {
  return VisitCameraModel(type, [&](auto model) -> ceres::CostFunction* {
    return new BoardFrameCorners<decltype(model)>(corners, count, huber_threshold);
  });
}

}  // namespace ctcal
