// What every residual of the continuous-time calibrator shares: the clock that turns a sample's
// stamp into the spline's normalised time, Ceres' row-major Jacobian layout, and the lifting of
// tangent-space Jacobians onto the ambient parameters of manifold blocks.
//
// Time (docs/residuals.md, "Time"): a residual is built for one fixed spline segment (first knot
// chosen by the pipeline from the initial time offset) and keeps the sample's stamp relative to
// that segment's start, t_rel = (t_stamp_ns - t_segment_ns) 1e-9 s, formed in integers so that
// long recordings keep nanosecond resolution. Inside the residual
//   u = (t_rel + shift) / dt,   shift = time_offset [+ v_meas line_delay]   (seconds),
// a smooth function of the offsets. While the offsets move, u may leave [0, 1] slightly: the
// segment's polynomial extrapolates smoothly, so the residual and its derivatives stay exact for
// the (slightly extrapolated) segment; the pipeline re-buckets such residuals after a solve.
//
// Manifolds and Jacobians: the analytic residuals compute Jacobians with respect to each block's
// tangent (the spline's knot tangents: So3RightManifold / Se3RightManifold; extrinsic and IMU
// rotations: So3LeftManifold) and hand Ceres J_ambient = J_tangent * MinusJacobian(x). Since
// MinusJacobian(x) * PlusJacobian(x) = I, Ceres' chain rule J_ambient * PlusJacobian(x) gives back
// exactly J_tangent. Gravity on ceres::SphereManifold<3> is the exception: its ambient Jacobian is
// the plain derivative with respect to the 3 numbers, and Ceres applies the sphere's PlusJacobian.
#pragma once

#include <ceres/dynamic_autodiff_cost_function.h>
#include <ceres/manifold.h>

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "ctcal/spline/bspline_basis.h"
#include "ctcal/spline/se3_spline.h"
#include "ctcal/spline/so3_manifold.h"

namespace ctcal {

// Where a sample sits on the segment its residual was built for (see the file comment).
struct SegmentClock {
  double t_rel_s = 0.0;  // stamp minus the segment's start time, seconds
  double inv_dt = 0.0;   // 1 / knot spacing, 1/s

  // The segment of knots first_index .. first_index + N - 1 starts at t0 + first_index * dt.
  static SegmentClock At(std::int64_t stamp_ns, const KnotTiming& timing, int first_index) {
    const std::int64_t start_ns =
        timing.t0_ns + static_cast<std::int64_t>(first_index) * timing.dt_ns;
    return SegmentClock{1e-9 * static_cast<double>(stamp_ns - start_ns), 1.0 / timing.dt_s()};
  }

  // u = (t_rel + shift_s) / dt, for double or ceres::Jet shifts.
  template <typename T>
  T U(const T& shift_s) const {
    return (T(t_rel_s) + shift_s) * T(inv_dt);
  }
  double U() const { return t_rel_s * inv_dt; }
};

namespace residual_internal {

// Ceres' layout of one Jacobian block: Rows x Cols, row-major (a column vector for Cols == 1,
// for which Eigen only accepts column-major storage, which is the same memory).
template <int Rows, int Cols>
using JacobianMap =
    Eigen::Map<Eigen::Matrix<double, Rows, Cols, Cols == 1 ? Eigen::ColMajor : Eigen::RowMajor>>;

template <int Rows>
using DynamicJacobianMap =
    Eigen::Map<Eigen::Matrix<double, Rows, Eigen::Dynamic, Eigen::RowMajor, Rows, 9>>;

// Writable views of Ceres' output blocks (functions, so that `Jacobian<2, 3>(ptr) = J;` is an
// expression rather than a declaration).
template <int Rows, int Cols>
JacobianMap<Rows, Cols> Jacobian(double* block) {
  return JacobianMap<Rows, Cols>(block);
}
template <int Rows>
DynamicJacobianMap<Rows> DynamicJacobian(double* block, int cols) {
  return DynamicJacobianMap<Rows>(block, Rows, cols);
}

// J_ambient (Rows x 4) of a quaternion block on So3LeftManifold from its tangent Jacobian.
template <int Rows>
void LiftLeftRotation(const Eigen::Matrix<double, Rows, 3>& J_tangent, const double* q,
                      double* J_ambient) {
  Eigen::Matrix<double, 3, 4, Eigen::RowMajor> M;
  So3LeftManifold().MinusJacobian(q, M.data());
  Jacobian<Rows, 4>(J_ambient) = J_tangent * M;
}

// Hands the spline's tangent Jacobian (Rows x 6N, layout of se3_spline.h) to the kNumBlocks
// trajectory blocks of a segment: jacobians[b] (nullptr = not wanted) receives the columns of
// block b times that block's MinusJacobian.
template <int N, Se3Representation Rep, int Rows>
void LiftTrajectoryJacobian(const Eigen::Matrix<double, Rows, 6 * N>& J_tangent,
                            double const* const* traj, double** jacobians) {
  using Spline = Se3Spline<N, Rep>;
  for (int b = 0; b < Spline::kNumBlocks; ++b) {
    if (jacobians[b] == nullptr)
      continue;
    const int col = Spline::TangentOffset(b);
    if constexpr (Rep == Se3Representation::kJoint) {
      Jacobian<Rows, 7>(jacobians[b]) =
          J_tangent.template middleCols<6>(col) * Se3RightManifold::MinusJacobianAt(traj[b]);
    } else if (b < N) {
      Jacobian<Rows, 4>(jacobians[b]) =
          J_tangent.template middleCols<3>(col) * So3RightManifold::MinusJacobianAt(traj[b]);
    } else {
      Jacobian<Rows, 3>(jacobians[b]) = J_tangent.template middleCols<3>(col);
    }
  }
}

// Whether any of jacobians[first .. first + count) is wanted.
inline bool AnyWanted(double** jacobians, int first, int count) {
  if (jacobians == nullptr)
    return false;
  for (int i = first; i < first + count; ++i) {
    if (jacobians[i] != nullptr)
      return true;
  }
  return false;
}

inline bool Wanted(double** jacobians, int index) {
  return jacobians != nullptr && index >= 0 && jacobians[index] != nullptr;
}

// One clear error for a parameter struct with the wrong number of knot blocks.
inline void CheckCount(const char* residual, const char* what, std::size_t got, int expected) {
  if (static_cast<int>(got) != expected)
    throw std::invalid_argument(std::string(residual) + ": expected " + std::to_string(expected) +
                                " " + what + " blocks, got " + std::to_string(got));
}

}  // namespace residual_internal

// Huber's loss on a squared whitened norm s with threshold a (a <= 0: plain L2), as the compressed
// blocks apply it (frame_corners_residual.h, inertial_block_residual.h): rho(s) = s for s <= a^2,
// else 2 a sqrt(s) - a^2, whose derivative rho'(s) is 1, else a / sqrt(s) (Ceres' HuberLoss, which
// halves the cost, holds rho(s) / 2).
struct HuberValue {
  double rho = 0.0;   // rho(s)
  double rho1 = 1.0;  // rho'(s)
};
inline HuberValue Huber(double s, double a) {
  if (!(a > 0.0 && s > a * a))
    return {s, 1.0};
  const double root = std::sqrt(s);
  return {2.0 * a * root - a * a, a / root};
}

// The Jet stride of the autodiff path (ceres::DynamicAutoDiffCostFunction): derivatives are
// propagated kAutoDiffStride parameters at a time.
inline constexpr int kAutoDiffStride = 8;

// The autodiff twin of an analytic residual: the same functor over the same blocks (takes
// ownership of `functor`).
template <typename Functor>
ceres::CostFunction* MakeDynamicAutoDiff(Functor* functor, const std::vector<int>& block_sizes,
                                         int num_residuals) {
  auto* cost = new ceres::DynamicAutoDiffCostFunction<Functor, kAutoDiffStride>(functor);
  for (const int size : block_sizes)
    cost->AddParameterBlock(size);
  cost->SetNumResiduals(num_residuals);
  return cost;
}

}  // namespace ctcal
