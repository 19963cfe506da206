// Every board corner of one global-shutter camera frame as one residual block, compressed into a
// square-root information factor over the frame-local variables before the chain rule to the
// spline (docs/calibrator.md, "Speed").
//
// Model. All corners of a global-shutter frame (line_delay 0 and not estimated) were exposed at
// the same base-clock time t = t_S + time_offset, so they share the camera pose
//   T_C_W = T_B_C^-1 T_W_B(t)^-1:   p_C,i = R_C_W p_W,i + t_C_W,   R_C_W = R_B_C^T R_W_B^T,
// and the camera's intrinsics. Corner i has the whitened residual of corner_residual.h,
//   e_i = (uv_i - project(params, p_C,i)) / sigma_i   (2 rows, ~N(0, I)).
// Frame-local variables x = (dtheta, dt, dparams) perturb the camera pose on the left,
// p_C -> Exp(dtheta) p_C + dt, and the intrinsics, so that (P_i = d uv / d p_C at corner i)
//   J_i = d e_i / d x = -1/sigma_i [P_i [-[p_C,i]x, I],  d uv_i / d params]        (2 x n_x).
//
// Compression. Stack e (2M) and J (2M x n_x) over the M corners and factor the augmented
// matrix [J | e] = Q [R  z; 0  rho; 0  0] (Householder's QR, or the same R, z, |rho| from the
// Cholesky factor of [J | e]^T [J | e]: frame_corners_compression.h). Then z = Q1^T e, |rho| =
// ||Q2^T e|| and the block returns r = [z; |rho|] (n_x + 1 rows) with the Jacobian [R; 0] with
// respect to x:
//   ||r||^2 = ||e||^2                  (Q is orthogonal: the cost is exact),
//   [R; 0]^T r = R^T z = J^T e         (the gradient is exact),
//   R^T R = J^T J                      (the Gauss-Newton Hessian is exact).
// [R; 0] is the Gauss-Newton Jacobian of r: the exact derivative differs by terms proportional
// to Q2^T e (the rotation of Q with x), which Gauss-Newton drops for the per-corner blocks too.
//
// Robust stage (Huber, threshold a, on s_i = ||e_i||^2: rho(s) = s for s <= a^2, else
// 2 a sqrt(s) - a^2). Ceres' per-corner HuberLoss scales the residual and Jacobian of corner i by
// sqrt(rho'(s_i)) (its corrector drops the curvature term when rho'' <= 0), so the per-corner
// cost is 1/2 sum rho(s_i), the gradient sum rho'(s_i) J_i^T e_i and the Hessian
// sum rho'(s_i) J_i^T J_i. The frame block scales the rows of corner i by w_i = sqrt(rho'(s_i))
// before the factorisation, which reproduces that gradient and Hessian exactly, and puts the
// remainder of the cost into the last row:
//   last^2 = rho^2 + sum_i (rho(s_i) - rho'(s_i) s_i),
// so that ||r||^2 = ||Q^T (w e)||^2 + sum (rho - rho' s) = sum rho(s_i). The remainder is >= 0:
// it is 0 inside the threshold, and beyond it rho' = a / sqrt(s) gives
// rho - rho' s = 2 a sqrt(s) - a^2 - a sqrt(s) = a (sqrt(s) - a) > 0.
//
// Chain rule to the blocks (once per frame), from the knots' right perturbation R_W_B ->
// R_W_B Exp(J_R dk), p_W_B -> p_W_B + J_p dk (the spline's tangent Jacobians) and
// p_B = R_W_B^T (p_W - p_W_B) = R_B_C p_C + t_B_C:
//   dp_C = R_B_C^T ([p_B]x J_R dk - R_W_B^T J_p dk), and with [p_B]x a = -[a]x (R_B_C p_C + t_B_C),
//   knots:  dtheta = -R_B_C^T J_R,  dt = R_B_C^T [t_B_C]x J_R - R_C_W J_p;
//   q_B_C (left, R_B_C = Exp(d) R_hat: dp_C = [p_C]x R_B_C^T d):  dtheta = -R_B_C^T, dt = 0;
//   t_B_C:  dtheta = 0, dt = -R_B_C^T;
//   time_offset (J_R dk -> w_B dt_s, J_p dk -> v_W dt_s):
//           dtheta = -R_B_C^T w_B, dt = R_B_C^T [t_B_C]x w_B - R_C_W v_W;
//   params: the identity on dparams.
// The block's Jacobian of each parameter block is R times these (then lifted onto the manifold's
// ambient coordinates as in residual_support.h).
//
// Split rows (FrameRows::kPose + FrameRows::kIntrinsics, docs/performance.md step 7e). R is upper
// triangular with the pose columns first, so its rows 6 .. kNx - 1 are zero in the pose columns:
// they depend on the intrinsics' columns only. Ceres stores a residual block's Jacobian densely
// over all of its parameter blocks (15 rows x 39 tangent columns for pinhole-radtan on a cubic
// split spline), so the frame can be handed over as two blocks: the pose rows [R_pp R_pi | z_p]
// over every block (6 rows) and the intrinsic rows [R_ii | z_i; 0 | last] over `params` only
// (kNx - 5 rows): 6 x 39 + 9 x 8 instead of 15 x 39 values (-48 %), with the same cost, gradient
// and Gauss-Newton Hessian (the row sets are disjoint). The intrinsic rows' values still depend
// on the pose, which that block reads from the pose blocks' own memory: this is exact only when
// Ceres writes every evaluation point there before evaluating, which it does when the problem
// has an EvaluationCallback (the contract of ceres::EvaluationCallback); the calibrator sets one.
// Each of the two blocks factors the frame on its own (no state is shared between blocks, which
// Ceres evaluates on several threads in any order); a residual-only evaluation (Ceres' candidate
// steps) returns the whole cost from the pose rows, r = [sqrt(sum rho); 0], and zeros from the
// intrinsic rows, without a second factorisation. So does the unsplit block: a candidate's cost
// is all that evaluation is for, and sum rho(s_i) needs neither the Jacobians nor the factor.
//
// A corner that does not project validly makes Evaluate return false (see corner_residual.h).
// The autodiff path (--autodiff) keeps one Jet block per corner (CornerResidual's functor): the
// QR of Jets would be the same residual at a much higher price, and the per-corner blocks are the
// reference the compressed blocks are tested against.
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <vector>

#include "ctcal/calibrator/residuals/corner_residual.h"
#include "ctcal/calibrator/residuals/frame_corners_compression.h"
#include "ctcal/calibrator/residuals/residual_support.h"
#include "ctcal/sensors/camera_model.h"

namespace ctcal {

// Which rows of a frame's factor a block holds (file comment): all, or one half of the split.
enum class FrameRows { kAll, kPose, kIntrinsics };

template <int N, Se3Representation Rep>
class FrameCornersResidual {
 public:
  using Spline = Se3Spline<N, Rep>;
  // Block order: traj, q_B_C, t_B_C, time_offset, params (no line_delay: global shutter).
  static constexpr int kNumTrajBlocks = Spline::kNumBlocks;
  static constexpr int kQ_B_C = kNumTrajBlocks;
  static constexpr int kT_B_C = kQ_B_C + 1;
  static constexpr int kTimeOffset = kT_B_C + 1;
  static constexpr int kParams = kTimeOffset + 1;
  static constexpr int kNumBlocks = kParams + 1;

  struct Parameters {
    std::vector<double*> traj;  // Spline::SegmentBlocks(first_index), kNumTrajBlocks pointers
    double* q_B_C = nullptr;
    double* t_B_C = nullptr;
    double* time_offset = nullptr;
    double* params = nullptr;
  };

  static std::vector<double*> Blocks(const Parameters& p) {
    residual_internal::CheckCount("FrameCornersResidual", "trajectory", p.traj.size(),
                                  kNumTrajBlocks);
    std::vector<double*> blocks(p.traj);
    blocks.insert(blocks.end(), {p.q_B_C, p.t_B_C, p.time_offset, p.params});
    return blocks;
  }

  static std::vector<int> BlockSizes(int num_camera_params) {
    std::vector<int> sizes;
    for (int b = 0; b < kNumTrajBlocks; ++b)
      sizes.push_back(Spline::AmbientSize(b));
    sizes.insert(sizes.end(), {4, 3, 1, num_camera_params});
    return sizes;
  }

  // Rows of the block: the frame-local dimension 6 + params, plus the remainder row.
  static constexpr int NumResiduals(int num_camera_params) { return 6 + num_camera_params + 1; }

  template <class Model>
  class Analytic final : public ceres::CostFunction {
   public:
    static constexpr int kNx = 6 + Model::kNumParams;  // frame-local variables
    using MatX = Eigen::Matrix<double, kNx, kNx>;

    // corners: every corner of the frame (same stamp); huber_threshold > 0: the robust stage
    // (threshold on the whitened corner residual's norm), 0: plain L2.
    Analytic(std::vector<CornerMeasurement> corners, const SegmentClock& clock,
             double huber_threshold)
        : owned_(std::move(corners)),
          num_corners_(static_cast<int>(owned_.size())),
          clock_(clock),
          huber_(huber_threshold) {
      SetRows(FrameRows::kAll, {});
    }
    // The same on `count` corners held by the caller, which must outlive the block, with their
    // board points in `board_W` (indexed by corner id, also held by the caller): a long
    // recording's millions of corners are then held once and compactly (docs/performance.md,
    // steps 7 and 7g).
    // rows: kAll, or one half of the split (file comment); kIntrinsics reads the pose from
    // `blocks` (Blocks(), the memory Ceres writes each evaluation point into) and has the
    // parameter block `params` only.
    Analytic(const HeldCorner* corners, int count, const Eigen::Vector3d* board_W,
             const SegmentClock& clock, double huber_threshold, FrameRows rows = FrameRows::kAll,
             const std::vector<double*>& blocks = {})
        : held_(corners),
          board_W_(board_W),
          num_corners_(count),
          clock_(clock),
          huber_(huber_threshold) {
      SetRows(rows, blocks);
    }
    Analytic(const Analytic&) = delete;
    Analytic& operator=(const Analytic&) = delete;

    int NumCorners() const { return num_corners_; }

    bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
      if (rows_ == FrameRows::kAll)
        return EvaluateRows<0, kNx + 1>(p, residuals, jacobians);
      if (rows_ == FrameRows::kPose)
        return EvaluateRows<0, 6>(p, residuals, jacobians);
      // The intrinsic rows: the pose from its blocks' memory, the intrinsics from Ceres.
      if (jacobians == nullptr) {
        std::fill_n(residuals, kNx - 5, 0.0);
        return true;
      }
      const double* q[kNumBlocks];
      for (int b = 0; b < kParams; ++b)
        q[b] = pose_[static_cast<std::size_t>(b)];
      q[kParams] = p[0];
      double* J[kNumBlocks] = {};
      J[kParams] = jacobians[0];
      return EvaluateRows<6, kNx - 5>(q, residuals, J);
    }

   private:
    void SetRows(FrameRows rows, const std::vector<double*>& blocks) {
      rows_ = rows;
      if (rows == FrameRows::kIntrinsics) {
        residual_internal::CheckCount("FrameCornersResidual", "blocks", blocks.size(), kNumBlocks);
        pose_.assign(blocks.begin(), blocks.begin() + kParams);
        set_num_residuals(kNx - 5);
        *mutable_parameter_block_sizes() = {Model::kNumParams};
        return;
      }
      set_num_residuals(rows == FrameRows::kPose ? 6 : kNx + 1);
      *mutable_parameter_block_sizes() = BlockSizes(Model::kNumParams);
    }

    // Rows R0 .. R0 + Rows - 1 of the factor [R | z; 0 | last] (row kNx is the remainder row),
    // over every block (p, jacobians: all kNumBlocks of them).
    template <int R0, int Rows>
    bool EvaluateRows(double const* const* p, double* residuals, double** jacobians) const {
      using namespace residual_internal;
      using Block = typename Spline::template Jacobians<double>::Block;
      const bool want_traj = AnyWanted(jacobians, 0, kNumTrajBlocks);
      const bool want_time = Wanted(jacobians, kTimeOffset);

      Se3Kinematics<double> kin;
      Block J_R_knots, J_p_knots;
      typename Spline::template Jacobians<double> J_kin;
      J_kin.J_R_knots = &J_R_knots;
      J_kin.J_p_knots = &J_p_knots;
      Spline::template EvaluateSegment<double>(p, clock_.U(p[kTimeOffset][0]), clock_.inv_dt,
                                               want_time ? 1 : 0, nullptr, &kin,
                                               want_traj ? &J_kin : nullptr);
      const Eigen::Matrix3d R_C_B =
          Eigen::Map<const Eigen::Quaterniond>(p[kQ_B_C]).toRotationMatrix().transpose();
      const Eigen::Map<const Eigen::Vector3d> t_B_C(p[kT_B_C]);
      const Eigen::Matrix3d R_C_W = R_C_B * kin.R_W_B.transpose();
      const Eigen::Vector3d t_C_W = -R_C_W * kin.p_W_B - R_C_B * t_B_C;

      if (jacobians == nullptr) {
        // Residual only (a candidate step's cost): the whole cost in the first row, summed over
        // the corners without the factorisation (file comment).
        double cost = 0.0;
        const bool projected =
            held_ != nullptr
                ? FrameCornersCostOf<Model>(num_corners_, HeldCornerAt{held_, board_W_}, p[kParams],
                                            R_C_W, t_C_W, huber_, &cost)
                : FrameCornersCostOf<Model>(num_corners_, OwnedCornerAt{owned_.data()}, p[kParams],
                                            R_C_W, t_C_W, huber_, &cost);
        std::fill_n(residuals, Rows, 0.0);
        residuals[0] = std::sqrt(cost);
        return projected;
      }
      // [J | e] of every corner, weighted for the robust stage, compressed to [R | z] and the
      // remainder row (frame_corners_compression.h; this file's comment derives it).
      MatX R;
      double r[kNx + 1];
      const bool projected =
          held_ != nullptr
              ? CompressFrameCornersOf<Model>(num_corners_, HeldCornerAt{held_, board_W_},
                                              p[kParams], R_C_W, t_C_W, huber_, r, &R)
              : CompressFrameCorners<Model>(owned_, p[kParams], R_C_W, t_C_W, huber_, r, &R);
      if (!projected)
        return false;
      std::copy(r + R0, r + R0 + Rows, residuals);

      // d x / d block (6 x tangent) for the pose part; then R * that, lifted.
      const Eigen::Matrix<double, kNx, 6> R_pose = R.template leftCols<6>();
      const Eigen::Matrix3d tBC_hat = Hat<double>(Eigen::Vector3d(t_B_C));
      if (want_traj) {
        Eigen::Matrix<double, 6, 6 * N> J_x_knots;
        J_x_knots.template topRows<3>() = -R_C_B * J_R_knots;
        J_x_knots.template bottomRows<3>() = R_C_B * tBC_hat * J_R_knots - R_C_W * J_p_knots;
        const Eigen::Matrix<double, kNx, 6 * N> J_t = R_pose * J_x_knots;
        LiftTrajectoryJacobian<N, Rep, Rows>(PaddedRows<6 * N, R0, Rows>(J_t), p, jacobians);
      }
      if (Wanted(jacobians, kQ_B_C)) {
        const Eigen::Matrix<double, kNx, 3> J_t = -R_pose.template leftCols<3>() * R_C_B;
        LiftLeftRotation<Rows>(PaddedRows<3, R0, Rows>(J_t), p[kQ_B_C], jacobians[kQ_B_C]);
      }
      if (Wanted(jacobians, kT_B_C)) {
        const Eigen::Matrix<double, kNx, 3> J_t = -R_pose.template rightCols<3>() * R_C_B;
        Jacobian<Rows, 3>(jacobians[kT_B_C]) = PaddedRows<3, R0, Rows>(J_t);
      }
      if (want_time) {
        Eigen::Matrix<double, 6, 1> J_x_t;
        J_x_t.template head<3>() = -R_C_B * kin.w_B;
        J_x_t.template tail<3>() = R_C_B * tBC_hat * kin.w_B - R_C_W * kin.v_W;
        const Eigen::Matrix<double, kNx, 1> J_t = R_pose * J_x_t;
        Jacobian<Rows, 1>(jacobians[kTimeOffset]) = PaddedRows<1, R0, Rows>(J_t);
      }
      if (Wanted(jacobians, kParams)) {
        const Eigen::Matrix<double, kNx, Model::kNumParams> J_t =
            R.template rightCols<Model::kNumParams>();
        Jacobian<Rows, Model::kNumParams>(jacobians[kParams]) =
            PaddedRows<Model::kNumParams, R0, Rows>(J_t);
      }
      return true;
    }

    // Rows R0 .. R0 + Rows - 1 of a kNx-row Jacobian with the remainder row's zeros appended.
    template <int Cols, int R0, int Rows>
    static Eigen::Matrix<double, Rows, Cols> PaddedRows(const Eigen::Matrix<double, kNx, Cols>& J) {
      Eigen::Matrix<double, kNx + 1, Cols> out;
      out.template topRows<kNx>() = J;
      out.template bottomRows<1>().setZero();
      return out.template middleRows<Rows>(R0);
    }

    std::vector<CornerMeasurement> owned_;  // empty when the caller holds the corners
    const HeldCorner* held_ = nullptr;      // the caller's corners, else nullptr
    const Eigen::Vector3d* board_W_ = nullptr;
    int num_corners_;
    SegmentClock clock_;
    double huber_;
    FrameRows rows_ = FrameRows::kAll;
    std::vector<const double*> pose_;  // kIntrinsics: the pose blocks' memory (Blocks() order)
  };
};

// The compressed block of one global-shutter frame for the camera model `type` (analytic only;
// the autodiff path uses per-corner blocks, see the file comment). huber_threshold 0: plain L2.
template <int N, Se3Representation Rep>
ceres::CostFunction* MakeFrameCornersResidual(CameraModelType type,
                                              std::vector<CornerMeasurement> corners,
                                              const SegmentClock& clock, double huber_threshold) {
  return VisitCameraModel(type, [&](auto model) -> ceres::CostFunction* {
    using Model = decltype(model);
    return new typename FrameCornersResidual<N, Rep>::template Analytic<Model>(
        std::move(corners), clock, huber_threshold);
  });
}

// The same on `count` corners held by the caller (not copied) with their board points in
// `board_W` (indexed by corner id): both must outlive the block.
// rows: the whole factor, or one half of the split (file comment; kIntrinsics reads the pose from
// `blocks`, FrameCornersResidual::Blocks(), and its only parameter block is `params`).
template <int N, Se3Representation Rep>
ceres::CostFunction* MakeFrameCornersResidual(CameraModelType type, const HeldCorner* corners,
                                              int count, const Eigen::Vector3d* board_W,
                                              const SegmentClock& clock, double huber_threshold,
                                              FrameRows rows = FrameRows::kAll,
                                              const std::vector<double*>& blocks = {}) {
  return VisitCameraModel(type, [&](auto model) -> ceres::CostFunction* {
    using Model = decltype(model);
    return new typename FrameCornersResidual<N, Rep>::template Analytic<Model>(
        corners, count, board_W, clock, huber_threshold, rows, blocks);
  });
}

#define CTCAL_FRAME_CORNERS_RESIDUAL_EXTERN(N, REP)                                         \
  extern template ceres::CostFunction* MakeFrameCornersResidual<N, Se3Representation::REP>( \
      CameraModelType, std::vector<CornerMeasurement>, const SegmentClock&, double);        \
  extern template ceres::CostFunction* MakeFrameCornersResidual<N, Se3Representation::REP>( \
      CameraModelType, const HeldCorner*, int, const Eigen::Vector3d*, const SegmentClock&, \
      double, FrameRows, const std::vector<double*>&);
CTCAL_FRAME_CORNERS_RESIDUAL_EXTERN(4, kSplit)
CTCAL_FRAME_CORNERS_RESIDUAL_EXTERN(5, kSplit)
CTCAL_FRAME_CORNERS_RESIDUAL_EXTERN(6, kSplit)
CTCAL_FRAME_CORNERS_RESIDUAL_EXTERN(4, kJoint)
CTCAL_FRAME_CORNERS_RESIDUAL_EXTERN(5, kJoint)
CTCAL_FRAME_CORNERS_RESIDUAL_EXTERN(6, kJoint)
#undef CTCAL_FRAME_CORNERS_RESIDUAL_EXTERN

}  // namespace ctcal
