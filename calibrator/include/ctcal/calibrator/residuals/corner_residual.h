// Reprojection residual of one target corner seen by a camera (global or rolling shutter).
//
// Model (SPEC sections 1, 2, 4). The corner was read out at camera-clock time t_S + v_meas * l
// (image stamp t_S, measured pixel row v_meas, line delay l), i.e. at base-clock time
//   t = t_S + time_offset + v_meas * line_delay,
// when the base IMU had pose T_W_B(t) = (R_W_B, p_W_B) from the trajectory spline. With the
// camera extrinsics T_B_C = (R_B_C, t_B_C):
//   p_B = R_W_B^T (p_W - p_W_B),   x = p_B - t_B_C,   p_C = R_B_C^T x,
//   uv_pred = project(params, p_C),                   r = (uv_meas - uv_pred) / sigma.
// The corner detector's noise is isotropic with standard deviation sigma px, so r ~ N(0, I_2).
//
// Jacobians (P = d uv_pred / d p_C, the camera model's J_uv_p; dr = -P/sigma dp_C):
//   knots (right perturbation R_W_B -> R_W_B Exp(dtheta), J_R, J_p from the spline):
//     R_W_B^T -> Exp(-dtheta) R_W_B^T gives dp_B = [p_B]x dtheta - R_W_B^T dp_W_B, so
//     d p_C / d knots = R_B_C^T ([p_B]x J_R - R_W_B^T J_p);
//   q_B_C (left perturbation R_B_C = Exp(d) R_hat): R_B_C^T x -> R_hat^T Exp(-d) x, so
//     d p_C / d d = R_B_C^T [x]x;
//   t_B_C: d p_C / d t_B_C = -R_B_C^T;
//   time: dR_W_B/dt = R_W_B [w_B]x and dp_W_B/dt = v_W give
//     d p_C / dt = R_B_C^T (-w_B x p_B - R_W_B^T v_W),
//     d t / d time_offset = 1,  d t / d line_delay = v_meas;
//   params: d r / d params = -J_uv_params / sigma.
//
// A projection outside the model's valid region (behind the camera, beyond a fisheye's field of
// view, where radtan folds over) makes Evaluate return false. Ceres then rejects the step that
// led there and shrinks the trust region, instead of being fed a residual with a meaningless value
// and Jacobian; at the initial point every corner projects validly because the pipeline builds the
// residual only for corners that do.
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <vector>

#include "ctcal/calibrator/residuals/residual_support.h"
#include "ctcal/sensors/camera_model.h"

namespace ctcal {

struct CornerMeasurement {
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();  // the corner on the target (= world frame)
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();   // measured pixel
  double sigma_px = 1.0;                          // its standard deviation per axis
};

// A corner as a long recording holds it (32 bytes instead of a CornerMeasurement's 48 plus a
// stamp and an id): the board point by its id in the board's corner table, the image stamp by
// the frame's index in a table of frame stamps. 10 min of two cameras hold 2.9 M corners
// (docs/performance.md, step 7g).
struct HeldCorner {
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();  // measured pixel
  double sigma_px = 1.0;                         // its standard deviation per axis
  std::int32_t corner_id = 0;                    // index into the board's corner table
  std::int32_t frame = 0;                        // index into the camera's frame stamps
};

// The measurement of a held corner, the board point read from `board_W` (indexed by corner id).
inline CornerMeasurement MeasurementOf(const HeldCorner& c, const Eigen::Vector3d* board_W) {
  CornerMeasurement m;
  m.p_W = board_W[c.corner_id];
  m.uv = c.uv;
  m.sigma_px = c.sigma_px;
  return m;
}

// The model's arithmetic from the base's pose on (file comment): p_B, x = p_B - t_B_C and p_C of
// the corner, and its whitened residual r = (uv_meas - project(params, p_C)) / sigma, with the
// projection's Jacobians where asked for. False where the projection is invalid. Shared by
// CornerResidual::Analytic and the per-frame evaluation of a camera's corners
// (SplineProblem::EvaluateCameraCorners), which evaluates the pose once per frame: one arithmetic,
// the same bits.
struct CornerPoints {
  Eigen::Vector3d p_B, x, p_C;
};
template <class Model>
inline bool WhitenedCornerResidual(
    const CornerMeasurement& m, const Eigen::Matrix3d& R_W_B, const Eigen::Vector3d& p_W_B,
    const Eigen::Matrix3d& R_B_C, const Eigen::Vector3d& t_B_C, const double* params,
    CornerPoints* points, Eigen::Vector2d* r, Eigen::Matrix<double, 2, 3>* J_uv_p = nullptr,
    Eigen::Matrix<double, 2, Model::kNumParams>* J_uv_params = nullptr) {
  points->p_B = R_W_B.transpose() * (m.p_W - p_W_B);
  points->x = points->p_B - t_B_C;
  points->p_C = R_B_C.transpose() * points->x;
  Eigen::Vector2d uv;
  if (!Model::template Project<double>(params, points->p_C, &uv, J_uv_p, J_uv_params))
    return false;
  *r = (m.uv - uv) * (1.0 / m.sigma_px);
  return true;
}

template <int N, Se3Representation Rep>
class CornerResidual {
 public:
  using Spline = Se3Spline<N, Rep>;
  static constexpr int kNumResiduals = 2;
  // Block order of the contract: traj, q_B_C, t_B_C, time_offset, line_delay, params.
  static constexpr int kNumTrajBlocks = Spline::kNumBlocks;
  static constexpr int kQ_B_C = kNumTrajBlocks;
  static constexpr int kT_B_C = kQ_B_C + 1;
  static constexpr int kTimeOffset = kT_B_C + 1;
  static constexpr int kLineDelay = kTimeOffset + 1;
  static constexpr int kParams = kLineDelay + 1;
  static constexpr int kNumBlocks = kParams + 1;

  struct Parameters {
    std::vector<double*> traj;  // Spline::SegmentBlocks(first_index), kNumTrajBlocks pointers
    double* q_B_C = nullptr;
    double* t_B_C = nullptr;
    double* time_offset = nullptr;
    double* line_delay = nullptr;
    double* params = nullptr;
  };

  // The parameter blocks in the order every cost function of this type expects them.
  static std::vector<double*> Blocks(const Parameters& p) {
    residual_internal::CheckCount("CornerResidual", "trajectory", p.traj.size(), kNumTrajBlocks);
    std::vector<double*> blocks(p.traj);
    blocks.insert(blocks.end(), {p.q_B_C, p.t_B_C, p.time_offset, p.line_delay, p.params});
    return blocks;
  }

  static std::vector<int> BlockSizes(int num_camera_params) {
    std::vector<int> sizes;
    for (int b = 0; b < kNumTrajBlocks; ++b)
      sizes.push_back(Spline::AmbientSize(b));
    sizes.insert(sizes.end(), {4, 3, 1, 1, num_camera_params});
    return sizes;
  }

  // p_C of the model above on any scalar, from the blocks up to line_delay (params unused).
  template <typename T>
  static Vec3T<T> PointInCamera(T const* const* p, const CornerMeasurement& m,
                                const SegmentClock& clock) {
    const T shift = p[kTimeOffset][0] + T(m.uv.y()) * p[kLineDelay][0];
    Se3Kinematics<T> kin;
    Spline::template EvaluateSegment<T>(p, clock.U(shift), T(clock.inv_dt), 0, nullptr, &kin);
    const Mat3T<T> R_B_C = Eigen::Map<const QuatT<T>>(p[kQ_B_C]).toRotationMatrix();
    const Eigen::Map<const Vec3T<T>> t_B_C(p[kT_B_C]);
    const Vec3T<T> p_B = kin.R_W_B.transpose() * (m.p_W.cast<T>() - kin.p_W_B);
    return R_B_C.transpose() * (p_B - t_B_C);
  }

  // (a) The templated functor: the model above on any scalar (the autodiff path).
  template <class Model>
  struct Functor {
    CornerMeasurement m;
    SegmentClock clock;

    template <typename T>
    bool operator()(T const* const* p, T* residuals) const {
      const Vec3T<T> p_C = PointInCamera<T>(p, m, clock);
      Eigen::Matrix<T, 2, 1> uv;
      if (!Model::template Project<T>(p[kParams], p_C, &uv))
        return false;
      const T inv_sigma = T(1.0 / m.sigma_px);
      residuals[0] = (T(m.uv.x()) - uv.x()) * inv_sigma;
      residuals[1] = (T(m.uv.y()) - uv.y()) * inv_sigma;
      return true;
    }
  };

  // (b) The analytic cost function: the same residual with the Jacobians derived above.
  template <class Model>
  class Analytic final : public ceres::CostFunction {
   public:
    Analytic(const CornerMeasurement& m, const SegmentClock& clock) : m_(m), clock_(clock) {
      set_num_residuals(kNumResiduals);
      *mutable_parameter_block_sizes() = BlockSizes(Model::kNumParams);
    }

    bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
      using namespace residual_internal;
      using Block = typename Spline::template Jacobians<double>::Block;
      const bool want_traj = AnyWanted(jacobians, 0, kNumTrajBlocks);
      const bool want_time = Wanted(jacobians, kTimeOffset) || Wanted(jacobians, kLineDelay);

      const double v_meas = m_.uv.y();
      const double shift = p[kTimeOffset][0] + v_meas * p[kLineDelay][0];
      Se3Kinematics<double> kin;
      Block J_R_knots, J_p_knots;
      typename Spline::template Jacobians<double> J_kin;
      J_kin.J_R_knots = &J_R_knots;
      J_kin.J_p_knots = &J_p_knots;
      Spline::template EvaluateSegment<double>(p, clock_.U(shift), clock_.inv_dt, want_time ? 1 : 0,
                                               nullptr, &kin, want_traj ? &J_kin : nullptr);

      const Eigen::Matrix3d R_B_C =
          Eigen::Map<const Eigen::Quaterniond>(p[kQ_B_C]).toRotationMatrix();
      const Eigen::Vector3d t_B_C = Eigen::Map<const Eigen::Vector3d>(p[kT_B_C]);
      CornerPoints points;
      Eigen::Vector2d r;
      Eigen::Matrix<double, 2, 3> J_uv_p;
      Eigen::Matrix<double, 2, Model::kNumParams> J_uv_params;
      const bool want_params = Wanted(jacobians, kParams);
      if (!WhitenedCornerResidual<Model>(m_, kin.R_W_B, kin.p_W_B, R_B_C, t_B_C, p[kParams],
                                         &points, &r, jacobians != nullptr ? &J_uv_p : nullptr,
                                         want_params ? &J_uv_params : nullptr))
        return false;
      residuals[0] = r[0];
      residuals[1] = r[1];
      if (jacobians == nullptr)
        return true;
      const Eigen::Vector3d& p_B = points.p_B;
      const Eigen::Vector3d& x = points.x;
      const double inv_sigma = 1.0 / m_.sigma_px;

      const Eigen::Matrix<double, 2, 3> J_r_pC = -inv_sigma * J_uv_p;
      const Eigen::Matrix<double, 2, 3> J_r_pB = J_r_pC * R_B_C.transpose();
      if (want_traj) {
        const Eigen::Matrix<double, 2, 6 * N> J_r_knots =
            J_r_pB * (Hat<double>(p_B) * J_R_knots - kin.R_W_B.transpose() * J_p_knots);
        LiftTrajectoryJacobian<N, Rep, 2>(J_r_knots, p, jacobians);
      }
      if (jacobians[kQ_B_C] != nullptr)
        LiftLeftRotation<2>(J_r_pB * Hat<double>(x), p[kQ_B_C], jacobians[kQ_B_C]);
      if (jacobians[kT_B_C] != nullptr)
        Jacobian<2, 3>(jacobians[kT_B_C]) = -J_r_pB;
      if (want_time) {
        const Eigen::Vector2d J_r_t =
            J_r_pB * (-kin.w_B.cross(p_B) - kin.R_W_B.transpose() * kin.v_W);
        if (jacobians[kTimeOffset] != nullptr)
          Jacobian<2, 1>(jacobians[kTimeOffset]) = J_r_t;
        if (jacobians[kLineDelay] != nullptr)
          Jacobian<2, 1>(jacobians[kLineDelay]) = v_meas * J_r_t;
      }
      if (want_params)
        Jacobian<2, Model::kNumParams>(jacobians[kParams]) = -inv_sigma * J_uv_params;
      return true;
    }

   private:
    CornerMeasurement m_;
    SegmentClock clock_;
  };

  // The autodiff cost function of the functor over the same blocks.
  template <class Model>
  static ceres::CostFunction* MakeAutoDiff(const CornerMeasurement& m, const SegmentClock& clock) {
    return MakeDynamicAutoDiff(new Functor<Model>{m, clock}, BlockSizes(Model::kNumParams),
                               kNumResiduals);
  }
};

// The cost function of one corner: analytic (default) or autodiff, for the camera model `type`.
template <int N, Se3Representation Rep>
ceres::CostFunction* MakeCornerResidual(bool analytic, CameraModelType type,
                                        const CornerMeasurement& m, const SegmentClock& clock) {
  return VisitCameraModel(type, [&](auto model) -> ceres::CostFunction* {
    using Model = decltype(model);
    using R = CornerResidual<N, Rep>;
    if (analytic)
      return new typename R::template Analytic<Model>(m, clock);
    return R::template MakeAutoDiff<Model>(m, clock);
  });
}

#define CTCAL_CORNER_RESIDUAL_EXTERN(N, REP)                                          \
  extern template ceres::CostFunction* MakeCornerResidual<N, Se3Representation::REP>( \
      bool, CameraModelType, const CornerMeasurement&, const SegmentClock&);
CTCAL_CORNER_RESIDUAL_EXTERN(4, kSplit)
CTCAL_CORNER_RESIDUAL_EXTERN(5, kSplit)
CTCAL_CORNER_RESIDUAL_EXTERN(6, kSplit)
CTCAL_CORNER_RESIDUAL_EXTERN(4, kJoint)
CTCAL_CORNER_RESIDUAL_EXTERN(5, kJoint)
CTCAL_CORNER_RESIDUAL_EXTERN(6, kJoint)
#undef CTCAL_CORNER_RESIDUAL_EXTERN

}  // namespace ctcal
