// Knot spacing from how well a spline of that spacing fits the base IMU's own signals, window by
// window (docs/noise_estimation.md, "Knot spacing").
//
// Too fine a spacing gives the trajectory so many knots that they absorb much of the inertial
// noise: the IMU residuals keep only a small share of their degrees of freedom (EuRoC imu_april at
// the bandwidth rule's 7 ms: 32 % redundancy, whitened RMS sqrt(0.32) = 0.57 with the right
// noise). Too coarse a spacing leaves spline misfit where the motion is fast. Uniform knots (the
// trajectory spline's), so the spacing is the largest one at which every window's signal is still
// fitted to its noise:
//
//   for each candidate dt (a geometric ladder), least-squares fit of a uniform B-spline of order
//   N - 1 (the angular velocity of an order-N rotation spline) to every gyro axis and of order N -
//   2 (the acceleration of an order-N position spline) to every accelerometer axis; per window w of
//   `window_s` the redundancy-corrected variance s_w^2(dt) = RSS_w / (n_w (1 - M / n)) (M
//   coefficients over n samples);
//   the chosen dt is the largest with s_w^2(dt) <= (1 + misfit_tolerance) min_dt' s_w^2(dt') for
//   both signals in `window_share` of the windows: coarsening until the windows' residuals start
//   to grow. Not in every window: a window with vibration faster than any knot spacing resolves
//   (EuRoC imu_april 4-8 s: accelerometer residuals 2x the others' even at 2 samples per knot)
//   would pull the whole recording to the finest spacing; the noise estimation weights such a
//   window by its own variance instead (docs/noise_estimation.md).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace ctcal {

struct KnotFitOptions {
  int order = 4;                   // the trajectory spline's order N
  double window_s = 2.0;           // windows the misfit is judged in
  double misfit_tolerance = 0.15;  // allowed excess of a window's variance over its smallest
  double window_share = 0.75;      // share of the windows that must fit within the tolerance
  double min_spacing_s = 0.005;
  double max_spacing_s = 0.1;
  double ladder_ratio = 1.15;  // consecutive candidate spacings
};

struct KnotFitCandidate {
  double spacing_s = 0.0;
  // The largest s_w^2(dt) / min_dt' s_w^2(dt') - 1 over the windows, per signal.
  double gyro_excess = 0.0;
  double accel_excess = 0.0;
  int worst_window = 0;  // of the larger excess
  // The window_share quantile over the windows of max(gyro, accel) excess: what the rule judges.
  double share_excess = 0.0;
};

struct KnotFitChoice {
  double knot_spacing_s = 0.0;
  std::vector<KnotFitCandidate> candidates;  // the ladder, finest first
};

// `t_ns` strictly increasing (the base IMU's samples, uniformly sampled up to jitter), `gyro` and
// `accel` the raw readings. Throws std::invalid_argument for fewer than 64 samples or mismatched
// sizes. A last window shorter than half of window_s joins the one before.
KnotFitChoice ChooseKnotSpacingByFit(const std::vector<std::int64_t>& t_ns,
                                     const std::vector<Eigen::Vector3d>& gyro,
                                     const std::vector<Eigen::Vector3d>& accel,
                                     const KnotFitOptions& options = {});

}  // namespace ctcal
