// Noise of an inertial sensor with Kalibr's keys (SPEC section 3), and the discrete-time
// quantities the residuals are whitened with.
//
// Kalibr's model (its wiki, "IMU Noise Model"): per axis, white noise of density sigma_c and a
// bias driven by white noise of density sigma_bc (a Wiener process). Sampled at rate 1/dt,
//   white noise of one sample:  sigma_d = sigma_c / sqrt(dt) = sigma_c sqrt(rate),
//   bias change over dt:        sigma_bd = sigma_bc sqrt(dt).
// A continuous-time bias b(t) (a spline) is instead tied by the prior
//   integral |db/dt|^2 / sigma_bc^2 dt,
// whose square-root weight is 1/sigma_bc (Kalibr's BSplineEuclideanMotionError with W = 1/rw^2).
#pragma once

#include <cmath>

namespace ctcal {

struct InertialNoise {
  double gyroscope_noise_density = 0.0;      // rad/s/sqrt(Hz)
  double gyroscope_random_walk = 0.0;        // rad/s^2/sqrt(Hz)
  double accelerometer_noise_density = 0.0;  // m/s^2/sqrt(Hz)  (unused by a gyro-only sensor)
  double accelerometer_random_walk = 0.0;    // m/s^3/sqrt(Hz)
  double update_rate = 0.0;                  // Hz

  // Throws std::invalid_argument naming the key ("noise.update_rate: ...") for a value that is
  // not positive and finite. A gyro-only sensor passes has_accelerometer = false.
  void Validate(bool has_accelerometer = true) const;

  // White noise of one sample: a density integrated over the sample period 1/rate.
  double GyroSampleSigma() const { return gyroscope_noise_density * std::sqrt(update_rate); }
  double AccelSampleSigma() const { return accelerometer_noise_density * std::sqrt(update_rate); }
  // Standard deviation of the bias change over dt seconds (a Wiener process).
  double GyroBiasSigma(double dt) const { return gyroscope_random_walk * std::sqrt(dt); }
  double AccelBiasSigma(double dt) const { return accelerometer_random_walk * std::sqrt(dt); }
  // Square-root information of a residual (b_{k+1} - b_k) between discrete bias states dt apart.
  double GyroBiasStepWeight(double dt) const { return 1.0 / GyroBiasSigma(dt); }
  double AccelBiasStepWeight(double dt) const { return 1.0 / AccelBiasSigma(dt); }
  // Square-root weight of the continuous bias-rate prior: a quadrature node of width h
  // contributes the residual sqrt(h) * weight * db/dt.
  double GyroBiasRateWeight() const { return 1.0 / gyroscope_random_walk; }
  double AccelBiasRateWeight() const { return 1.0 / accelerometer_random_walk; }
};

// EuRoC's ADIS16448 as Kalibr's imu.yaml for EuRoC gives it (Table 4 of the MVIS paper), sampled
// at rate_hz: the simulator's default rig and a plausible IMU for tests.
inline InertialNoise EurocAdis16448Noise(double rate_hz) {
  InertialNoise n;
  n.gyroscope_noise_density = 1.6968e-04;
  n.gyroscope_random_walk = 1.9393e-05;
  n.accelerometer_noise_density = 2.0e-3;
  n.accelerometer_random_walk = 3.0e-3;
  n.update_rate = rate_hz;
  return n;
}

}  // namespace ctcal
