// Knot spacing of the trajectory spline from the bandwidth of the motion.
//
// The simulator's (and reality's) trajectory is not a spline, so a knot spacing too wide for the
// motion leaves a model error in every residual that no noise model accounts for: biased estimates
// and overconfident sigmas. Too narrow a spacing costs time and lets the spline fit noise between
// camera frames. The motion's bandwidth is measured from the base IMU: the frequency below which
// a given fraction of the angular-velocity and specific-force signal energy lies, after removing
// the white-noise floor that the sensor's noise density predicts.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace ctcal {

struct KnotSpacingOptions {
  // Fraction of the (noise-free) signal energy the spline must be able to represent.
  double energy_fraction = 0.995;
  // Knots per period of the bandwidth frequency. A uniform cubic B-spline attenuates a sinusoid of
  // period P by < 1 % when P spans at least ~6 knots, but the accelerometers see the position
  // spline's second derivative (piecewise linear for order 4): at 8 knots per period their
  // whitened RMS was 1.51 on the demo rig, at 14 it is 1.04 for the same time
  // (docs/knot_study.md).
  double knots_per_period = 14.0;
  double min_spacing_s = 0.005;
  double max_spacing_s = 0.1;
};

struct MotionBandwidth {
  double gyro_hz = 0.0;   // bandwidth of the angular velocity
  double accel_hz = 0.0;  // bandwidth of the specific force
  double knot_spacing_s = 0.0;
};

// `t_ns` strictly increasing (the base IMU's samples); `gyro` and `accel` the raw readings;
// `gyro_noise_sigma` / `accel_noise_sigma` the per-sample white-noise sigmas (0 = no floor
// removed).
MotionBandwidth ChooseKnotSpacing(const std::vector<std::int64_t>& t_ns,
                                  const std::vector<Eigen::Vector3d>& gyro,
                                  const std::vector<Eigen::Vector3d>& accel,
                                  double gyro_noise_sigma, double accel_noise_sigma,
                                  const KnotSpacingOptions& options = {});

// The frequency below which `energy_fraction` of the energy of `signal` (uniformly sampled at
// `rate_hz`, mean removed, per-sample white noise of `noise_sigma` subtracted) lies.
double SignalBandwidthHz(const std::vector<Eigen::Vector3d>& signal, double rate_hz,
                         double noise_sigma, double energy_fraction);

}  // namespace ctcal
