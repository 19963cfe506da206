// The calibrator estimates every sensor's noise from the data (variance component estimation,
// docs/noise_estimation.md): on a simulated recording of the default rig whose rig file states
// every noise 0.3x or 3x the simulator's truth (the cameras' per-corner sigmas as a detector
// would state them, the inertial sensors' white-noise densities), `noise_estimated` is the truth
// within 5 %; `--noise stated` keeps the stated noise and writes no estimate.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "../simulated_recording.h"
#include "ctcal/calibrator/spline_calibrator.h"

namespace ctcal {
namespace {

// The recording with every stated noise `factor` times the truth.
SimulatedRecording Misstated(double factor) {
  SimulatedRecording r = SimulateTable4(sim::Scenario::kFull, 12.0, 21);
  for (SensorConfig& s : r.guess.sensors) {
    s.pixel_sigma *= factor;
    s.noise.gyroscope_noise_density *= factor;
    s.noise.accelerometer_noise_density *= factor;
  }
  for (auto& [name, d] : r.data) {
    for (CornerObservation& c : d.corners) {
      if (c.sigma)
        *c.sigma *= factor;
    }
  }
  return r;
}

SplineCalibratorOptions Options() {
  SplineCalibratorOptions o;
  o.threads = 2;
  o.report_data = false;
  o.compute_covariance = false;
  o.estimate_noise = true;  // `--noise estimate` (off by default until validated)
  o.knot_spacing_by_fit = true;
  return o;
}

void ExpectTruthWithinFivePercent(double factor) {
  const SimulatedRecording r = Misstated(factor);
  const SplineCalibrationResult out = CalibrateSpline(r.guess, r.data, Options(), test::Quiet());
  EXPECT_GE(out.noise_rounds, 1);
  for (const SensorConfig& truth : r.truth.sensors) {
    const SensorConfig* s = out.result.Find(truth.name);
    ASSERT_NE(s, nullptr) << truth.name;
    if (truth.type == SensorType::kCamera) {
      ASSERT_TRUE(s->pixel_sigma_estimated.has_value()) << truth.name;
      // pixel_sigma_estimated: the median of the corners' estimated sigmas.
      EXPECT_NEAR(*s->pixel_sigma_estimated / truth.pixel_sigma, 1.0, 0.05) << truth.name;
      continue;
    }
    ASSERT_TRUE(s->noise_estimated.has_value()) << truth.name;
    // `noise:` stays the stated one.
    EXPECT_DOUBLE_EQ(s->noise.gyroscope_noise_density,
                     factor * truth.noise.gyroscope_noise_density);
    EXPECT_NEAR(s->noise_estimated->gyroscope_noise_density / truth.noise.gyroscope_noise_density,
                1.0, 0.05)
        << truth.name << " gyro";
    if (truth.type == SensorType::kImu) {
      EXPECT_NEAR(
          s->noise_estimated->accelerometer_noise_density / truth.noise.accelerometer_noise_density,
          1.0, 0.05)
          << truth.name << " accel";
    }
    // The random walks are kept as stated.
    EXPECT_DOUBLE_EQ(s->noise_estimated->gyroscope_random_walk, truth.noise.gyroscope_random_walk);
  }
  // Whitened by the estimate, every sensor's residuals are near 1 (below it by the share of their
  // degrees of freedom the trajectory takes).
  for (const auto& [name, res] : out.result.residuals)
    EXPECT_NEAR(*res.rms_whitened, 0.9, 0.15) << name;
}

// Stated 3x too small, the stages' outlier gate removes half of the good corners (their whitened
// residuals are 3.3x): the estimation puts them back, starts from each camera's robust scale and
// gates again at every round (before: 0.53x the truth from the truncated half).
TEST(NoiseEstimation, RecoversTheTruthStatedThreeTimesTooSmall) {
  ExpectTruthWithinFivePercent(0.3);
}

TEST(NoiseEstimation, RecoversTheTruthStatedThreeTimesTooLarge) {
  ExpectTruthWithinFivePercent(3.0);
}

TEST(NoiseEstimation, StatedKeepsTheStatedNoise) {
  const SimulatedRecording r = Misstated(3.0);
  SplineCalibratorOptions o = Options();
  o.estimate_noise = false;
  const SplineCalibrationResult out = CalibrateSpline(r.guess, r.data, o, test::Quiet());
  EXPECT_EQ(out.noise_rounds, 0);
  for (const SensorConfig& s : out.result.sensors) {
    EXPECT_FALSE(s.noise_estimated.has_value()) << s.name;
    EXPECT_FALSE(s.pixel_sigma_estimated.has_value()) << s.name;
  }
  // Stated 3x the truth: the whitened residuals are ~1/3.
  for (const auto& [name, res] : out.result.residuals)
    EXPECT_LT(*res.rms_whitened, 0.45) << name;
}

// Blur: from the middle of the recording on, every corner of cam0 carries 2.5x the noise its
// sigma states (extra Gaussian noise added to the simulated corners). The per-frame weights find
// each frame's level: clean frames ~1x, blurred ~2.5x the stated sigma.
// (Before every corner was gated again at each round's weights: the blurred frames' corners beyond
// the gate at the stated noise stayed out and their level came out 1.67x, not 2.5x.)
TEST(NoiseEstimation, PerFrameWeightsRecoverABlurSchedule) {
  SimulatedRecording r = SimulateTable4(sim::Scenario::kFull, 12.0, 22);
  std::vector<CornerObservation>& corners = r.data.at("cam0").corners;
  ASSERT_FALSE(corners.empty());
  const std::int64_t middle = (corners.front().t_ns + corners.back().t_ns) / 2;
  std::mt19937 rng(7);
  std::normal_distribution<double> gauss;
  const double extra = std::sqrt(2.5 * 2.5 - 1.0);
  for (CornerObservation& c : corners) {
    if (c.t_ns < middle)
      continue;
    const double sigma = c.sigma.value_or(1.0);
    c.u += extra * sigma * gauss(rng);
    c.v += extra * sigma * gauss(rng);
  }
  SplineCalibratorOptions o = Options();
  o.frame_weight_prior = 10.0;
  const SplineCalibrationResult out = CalibrateSpline(r.guess, r.data, o, test::Quiet());
  const double stated = r.truth.Find("cam0")->pixel_sigma;
  std::vector<double> clean, blurred;
  for (const auto& [t_ns, sigma] : out.frame_sigma_px.at("cam0"))
    (t_ns < middle ? clean : blurred).push_back(sigma / stated);
  ASSERT_GT(clean.size(), 50u);
  ASSERT_GT(blurred.size(), 50u);
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  EXPECT_NEAR(median(clean), 1.0, 0.1);
  EXPECT_NEAR(median(blurred), 2.5, 0.25);
  // cam1 has no blur: its frames stay at the stated level.
  std::vector<double> other;
  for (const auto& [t_ns, sigma] : out.frame_sigma_px.at("cam1"))
    other.push_back(sigma / r.truth.Find("cam1")->pixel_sigma);
  EXPECT_NEAR(median(other), 1.0, 0.1);
}

}  // namespace
}  // namespace ctcal
