// Noise conversions of SPEC section 3 (Kalibr's continuous-time densities -> discrete sigmas and
// bias weights), and validation of the noise keys.
#include "ctcal/sensors/inertial_noise.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>

namespace ctcal {
namespace {

using ::testing::HasSubstr;

InertialNoise Euroc() {
  return EurocAdis16448Noise(200.0);
}

TEST(InertialNoise, DiscreteWhiteNoiseSigma) {
  const InertialNoise n = Euroc();
  // sigma_d = sigma_c * sqrt(rate): 1.6968e-4 * sqrt(200) = 2.39964...e-3.
  EXPECT_NEAR(n.GyroSampleSigma(), 2.399637e-3, 1e-9);
  EXPECT_NEAR(n.AccelSampleSigma(), 2.828427e-2, 1e-8);
}

// Averaging k samples of the discrete white noise is the same as sampling at rate/k: the
// densities describe the sensor, the sigma follows the rate.
TEST(InertialNoise, SampleSigmaScalesWithRate) {
  InertialNoise fast = Euroc(), slow = Euroc();
  slow.update_rate = fast.update_rate / 4.0;
  EXPECT_NEAR(fast.GyroSampleSigma() / std::sqrt(4.0), slow.GyroSampleSigma(), 1e-18);
}

TEST(InertialNoise, BiasRandomWalk) {
  const InertialNoise n = Euroc();
  EXPECT_NEAR(n.GyroBiasSigma(0.005), 1.9393e-05 * std::sqrt(0.005), 1e-20);
  EXPECT_NEAR(n.AccelBiasSigma(4.0), 6.0e-3, 1e-18);
  // A Wiener process: steps add in variance, so N steps of dt equal one step of N dt.
  const double dt = 0.005;
  const int N = 200;
  EXPECT_NEAR(std::sqrt(N) * n.GyroBiasSigma(dt), n.GyroBiasSigma(N * dt), 1e-18);
  EXPECT_NEAR(n.GyroBiasStepWeight(dt) * n.GyroBiasSigma(dt), 1.0, 1e-15);
}

// A Monte-Carlo check of the discrete walk: 4000 walks of 100 steps of sigma GyroBiasSigma(dt)
// end with the standard deviation rw * sqrt(100 dt), within 5 % (4000 samples: ~1.1 % std).
TEST(InertialNoise, SimulatedWalkHasTheStatedSpread) {
  const InertialNoise n = Euroc();
  const double dt = 0.01;
  std::mt19937 rng(3);
  std::normal_distribution<double> normal(0.0, n.GyroBiasSigma(dt));
  double sum2 = 0.0;
  const int walks = 4000;
  for (int w = 0; w < walks; ++w) {
    double b = 0.0;
    for (int k = 0; k < 100; ++k)
      b += normal(rng);
    sum2 += b * b;
  }
  EXPECT_NEAR(std::sqrt(sum2 / walks) / (n.gyroscope_random_walk * std::sqrt(100 * dt)), 1.0, 0.05);
}

// The continuous bias-rate prior and the discrete step prior agree on a straight-line bias:
// integral over dt of (s / rw)^2 equals ((s dt) / (rw sqrt(dt)))^2.
TEST(InertialNoise, RateAndStepWeightsAgree) {
  const InertialNoise n = Euroc();
  const double dt = 0.37, slope = 2e-4;
  const double continuous = dt * std::pow(slope * n.AccelBiasRateWeight(), 2);
  const double discrete = std::pow(slope * dt * n.AccelBiasStepWeight(dt), 2);
  EXPECT_NEAR(continuous / discrete, 1.0, 1e-14);
  EXPECT_NEAR(n.GyroBiasRateWeight(), 1.0 / 1.9393e-05, 1e-9);
}

std::string ValidationError(const InertialNoise& n, bool has_accelerometer = true) {
  try {
    n.Validate(has_accelerometer);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(InertialNoise, ValidationNamesTheKey) {
  EXPECT_EQ(ValidationError(Euroc()), "(accepted)");
  InertialNoise n = Euroc();
  n.update_rate = 0.0;
  EXPECT_THAT(ValidationError(n), HasSubstr("noise.update_rate: must be a positive finite number"));
  n = Euroc();
  n.gyroscope_random_walk = -1e-5;
  EXPECT_THAT(ValidationError(n), HasSubstr("noise.gyroscope_random_walk"));
  n = Euroc();
  n.accelerometer_noise_density = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT(ValidationError(n), HasSubstr("noise.accelerometer_noise_density"));
  // A gyro-only sensor needs no accelerometer keys.
  n.accelerometer_random_walk = 0.0;
  EXPECT_EQ(ValidationError(n, /*has_accelerometer=*/false), "(accepted)");
}

}  // namespace
}  // namespace ctcal
