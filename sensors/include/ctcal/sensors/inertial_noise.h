// Noise of an inertial sensor with Kalibr's keys (SPEC section 3), and the discrete-time
// quantities the residuals are whitened with.
#pragma once

#include <cmath>

namespace ctcal {

struct InertialNoise {
  double gyroscope_noise_density = 0.0;      // rad/s/sqrt(Hz)
  double gyroscope_random_walk = 0.0;        // rad/s^2/sqrt(Hz)
  double accelerometer_noise_density = 0.0;  // m/s^2/sqrt(Hz)  (unused by a gyro-only sensor)
  double accelerometer_random_walk = 0.0;    // m/s^3/sqrt(Hz)
  double update_rate = 0.0;                  // Hz

  // White noise of one sample: a density integrated over the sample period 1/rate.
  double GyroSampleSigma() const { return gyroscope_noise_density * std::sqrt(update_rate); }
  double AccelSampleSigma() const { return accelerometer_noise_density * std::sqrt(update_rate); }
  // Standard deviation of the bias change over dt seconds (a Wiener process).
  double GyroBiasSigma(double dt) const { return gyroscope_random_walk * std::sqrt(dt); }
  double AccelBiasSigma(double dt) const { return accelerometer_random_walk * std::sqrt(dt); }
};

}  // namespace ctcal
