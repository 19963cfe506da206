// Fitting splines to data, for initialisation and for the demo:
//   FitSe3Spline: a pose trajectory from timestamped poses T_W_B (e.g. camera poses mapped to B),
//   FitSo3SplineToAngularVelocity: an orientation trajectory from gyro readings w_B and the
//     orientation at the first reading (gyros alone give no absolute orientation).
// Both solve a nonlinear least-squares problem with Ceres on the spline's own right manifolds and
// analytic Jacobians (the residuals below are small models of the calibrator's), plus a smoothness
// regulariser on the second differences of the knots:
//   r_k = (Log(X_k^-1 X_{k+1}) - Log(X_{k-1}^-1 X_k)) / (dt^2 sigma_acc),
// the discrete second derivative of the knot sequence, i.e. an acceleration prior with standard
// deviation sigma_acc that keeps knots without data (gaps, ends) determined and damps noise.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "ctcal/spline/se3_spline.h"
#include "ctcal/spline/so3_spline.h"

namespace ctcal {

struct PoseSample {
  std::int64_t t_ns = 0;
  Eigen::Quaterniond q_W_B = Eigen::Quaterniond::Identity();
  Eigen::Vector3d p_W_B = Eigen::Vector3d::Zero();
};

struct AngularVelocitySample {
  std::int64_t t_ns = 0;
  Eigen::Vector3d w_B = Eigen::Vector3d::Zero();
};

struct SplineFitOptions {
  std::int64_t dt_ns = 50'000'000;         // knot spacing
  double rotation_sigma = 1e-3;            // rad, per axis, of a pose sample's orientation
  double position_sigma = 1e-3;            // m, per axis, of a pose sample's position
  double angular_velocity_sigma = 1e-2;    // rad/s, per axis, of a gyro sample
  double initial_rotation_sigma = 1e-4;    // rad, of the given orientation at the first gyro sample
  double linear_acceleration_sigma = 1e3;  // m/s^2, smoothness prior (weak by default)
  double angular_acceleration_sigma = 1e3;  // rad/s^2, smoothness prior (weak by default)
  int max_iterations = 50;
  int num_threads = 1;
};

struct SplineFitReport {
  int num_knots = 0;
  int iterations = 0;
  double initial_cost = 0.0;
  double final_cost = 0.0;
  bool converged = false;
};

// The spline starts at the first sample's time and covers the last one. Throws
// std::invalid_argument for fewer than two samples, unsorted times or a non-positive dt_ns.
template <int N, Se3Representation Rep = Se3Representation::kSplit>
Se3Spline<N, Rep> FitSe3Spline(const std::vector<PoseSample>& samples,
                               const SplineFitOptions& options, SplineFitReport* report = nullptr);

template <int N>
So3Spline<N> FitSo3SplineToAngularVelocity(const std::vector<AngularVelocitySample>& samples,
                                           const Eigen::Quaterniond& q_W_B_first,
                                           const SplineFitOptions& options,
                                           SplineFitReport* report = nullptr);

}  // namespace ctcal
