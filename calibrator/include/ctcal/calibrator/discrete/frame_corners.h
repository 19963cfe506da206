// Every board corner of one global-shutter camera frame of the discrete problem as one residual
// block: the corners compressed over the frame's camera pose and intrinsics
// (frame_corners_compression.h, derived in frame_corners_residual.h), chained to the blocks the
// interpolated pose reads (keyframe states, gravity, base intrinsics for A.1, T_B_C, time offset).
//
// Model: the per-corner DiscreteCornerFunctor's with line_delay 0, so that every corner of the
// frame reads the base pose at the same base-clock time t = stamp + time_offset:
//   T_C_W = T_B_C^-1 T_W_B(t)^-1,   R_C_W = R_B_C^T R_W_B^T,   t_C_W = -R_C_W p_W_B - R_B_C^T
//   t_B_C,
// T_W_B(t) from BaseMotionAt (A.1 or A.2). The frame block's residual is r = [z; last] of the
// compression, with Jacobian [R; 0] in x = (dtheta, dt, dparams), where x perturbs T_C_W on the
// left: R_C_W -> Exp(dtheta) R_C_W, t_C_W -> Exp(dtheta) t_C_W + dt. The chain rule to a block b
// is d x / d b of the pose:
//   dtheta = vee(dR_C_W R_C_W^T),   dt = d t_C_W - dtheta x t_C_W,
// computed once per frame by automatic differentiation of CameraPoseTangent, whose value is the
// pose's own left-tangent at the current point:
//   dtheta = 2 vec(q_C_W(b) q_C_W(b_hat)^-1),   dt = t_C_W(b) - dtheta x t_C_W(b_hat)
// (the quaternion product is the identity at b = b_hat, where the derivative of 2 vec(.) is the
// rotation vector's). Cost, gradient and Gauss-Newton Hessian equal those of the per-corner blocks
// (tests/calibrator/discrete/test_discrete_frame_corners.cpp); the Jet work drops from every corner
// (~65 parameters each) to one 6-output pose per frame.
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "ctcal/calibrator/discrete/discrete_residuals.h"
#include "ctcal/calibrator/residuals/frame_corners_compression.h"
#include "ctcal/spline/bspline_basis.h"

namespace ctcal::discrete {

// The blocks of a frame's camera pose (indices into its BlockList).
struct FramePoseIndex {
  int q_B_C = -1, t_B_C = -1, time_offset = -1;
};

// T_C_W of the frame stamped `stamp` (camera clock, s relative to the problem's t0).
template <typename T>
void CameraPoseAt(const BaseSource& src, const FramePoseIndex& c, double stamp, T const* const* x,
                  QuatT<T>* q_C_W, Vec3T<T>* t_C_W) {
  const BaseMotion<T> b = BaseMotionAt<T>(src, x, T(stamp) + x[c.time_offset][0]);
  const Eigen::Map<const QuatT<T>> q_B_C(x[c.q_B_C]);
  *q_C_W = q_B_C.conjugate() * b.q_W_B.conjugate();
  *t_C_W =
      -(*q_C_W * b.p_W_B) - q_B_C.conjugate() * Vec3T<T>(Eigen::Map<const Vec3T<T>>(x[c.t_B_C]));
}

// The left-tangent of T_C_W at the current blocks (file comment): 6 outputs whose derivatives are
// d x / d block.
struct CameraPoseTangent {
  BaseSource src;
  FramePoseIndex c;
  double stamp = 0.0;

  template <typename T>
  bool operator()(T const* const* x, T* out) const {
    QuatT<T> q;
    Vec3T<T> t;
    CameraPoseAt<T>(src, c, stamp, x, &q, &t);
    const QuatT<T> q_hat(T(ScalarPart(q.w())), T(ScalarPart(q.x())), T(ScalarPart(q.y())),
                         T(ScalarPart(q.z())));
    const Vec3T<T> t_hat(T(ScalarPart(t.x())), T(ScalarPart(t.y())), T(ScalarPart(t.z())));
    const Vec3T<T> dtheta = T(2.0) * (q * q_hat.conjugate()).vec();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> tangent(out);
    tangent.template head<3>() = dtheta;
    tangent.template tail<3>() = t - dtheta.cross(t_hat);
    return true;
  }
};

// Blocks: the pose blocks of `list` (BaseSource, q_B_C, t_B_C, time_offset) then the camera's
// intrinsics last (`params_index` == the list's last index).
template <class Model>
class DiscreteFrameCorners final : public ceres::CostFunction {
 public:
  static constexpr int kNx = 6 + Model::kNumParams;

  // huber_threshold > 0: the robust stage, 0: plain L2 (frame_corners_residual.h).
  DiscreteFrameCorners(std::vector<CornerMeasurement> corners, double stamp, const BaseSource& src,
                       const FramePoseIndex& c, const BlockList& list, double huber_threshold)
      : corners_(std::move(corners)), stamp_(stamp), src_(src), c_(c), huber_(huber_threshold) {
    set_num_residuals(kNx + 1);
    *mutable_parameter_block_sizes() = list.sizes();
    const std::vector<int> pose_sizes(list.sizes().begin(), list.sizes().end() - 1);
    pose_.reset(MakeDynamicAutoDiff(new CameraPoseTangent{src, c, stamp}, pose_sizes, 6));
  }

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    const int n = static_cast<int>(parameter_block_sizes().size());
    QuatT<double> q_C_W;
    Eigen::Vector3d t_C_W;
    CameraPoseAt<double>(src_, c_, stamp_, p, &q_C_W, &t_C_W);
    Eigen::Matrix<double, kNx, kNx> R;
    if (!CompressFrameCorners<Model>(corners_, p[n - 1], q_C_W.toRotationMatrix(), t_C_W, huber_,
                                     residuals, &R))
      return false;
    if (jacobians == nullptr)
      return true;
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    // d x / d block of the pose blocks whose Jacobian is wanted.
    std::vector<RowMajor> J_x(static_cast<std::size_t>(n - 1));
    std::vector<double*> J_x_ptr(static_cast<std::size_t>(n - 1), nullptr);
    bool any = false;
    for (int b = 0; b + 1 < n; ++b) {
      if (jacobians[b] == nullptr)
        continue;
      J_x[static_cast<std::size_t>(b)].resize(6,
                                              parameter_block_sizes()[static_cast<std::size_t>(b)]);
      J_x_ptr[static_cast<std::size_t>(b)] = J_x[static_cast<std::size_t>(b)].data();
      any = true;
    }
    if (any) {
      double x6[6];
      if (!pose_->Evaluate(p, x6, J_x_ptr.data()))
        return false;
    }
    for (int b = 0; b + 1 < n; ++b) {
      if (jacobians[b] == nullptr)
        continue;
      const int size = parameter_block_sizes()[static_cast<std::size_t>(b)];
      Eigen::Map<RowMajor> J(jacobians[b], kNx + 1, size);
      J.topRows(kNx) = R.template leftCols<6>() * J_x[static_cast<std::size_t>(b)];
      J.bottomRows(1).setZero();
    }
    if (jacobians[n - 1] != nullptr) {
      Eigen::Map<RowMajor> J(jacobians[n - 1], kNx + 1, Model::kNumParams);
      J.topRows(kNx) = R.template rightCols<Model::kNumParams>();
      J.bottomRows(1).setZero();
    }
    return true;
  }

 private:
  std::vector<CornerMeasurement> corners_;
  double stamp_;
  BaseSource src_;
  FramePoseIndex c_;
  double huber_;
  std::unique_ptr<ceres::CostFunction> pose_;
};

// The frame block for the camera model `type`; `list` holds the pose blocks then the intrinsics.
ceres::CostFunction* MakeDiscreteFrameCorners(CameraModelType type,
                                              std::vector<CornerMeasurement> corners, double stamp,
                                              const BaseSource& src, const FramePoseIndex& c,
                                              const BlockList& list, double huber_threshold);

}  // namespace ctcal::discrete
