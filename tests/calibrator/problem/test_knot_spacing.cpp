// The bandwidth estimate must find the highest frequency that carries real energy, and ignore the
// white noise the sensor's density predicts.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "ctcal/calibrator/knot_spacing.h"

namespace ctcal {
namespace {

std::vector<Eigen::Vector3d> Sines(const std::vector<double>& freqs_hz, double rate_hz, int n,
                                   double noise_sigma, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0.0, noise_sigma);
  std::vector<Eigen::Vector3d> out(n);
  for (int i = 0; i < n; ++i) {
    const double t = i / rate_hz;
    for (int axis = 0; axis < 3; ++axis) {
      double v = 0.3 * axis;  // a mean that must not count as energy
      for (double f : freqs_hz)
        v += std::sin(2 * M_PI * f * t + axis);
      out[i](axis) = v + (noise_sigma > 0 ? gauss(rng) : 0.0);
    }
  }
  return out;
}

TEST(KnotSpacing, BandwidthIsTheHighestEnergeticFrequency) {
  const double rate = 200.0;
  const auto signal = Sines({0.5, 1.5, 3.0}, rate, 4000, 0.0, 1);
  const double f = SignalBandwidthHz(signal, rate, 0.0, 0.995);
  EXPECT_NEAR(f, 3.0, 0.1);
}

TEST(KnotSpacing, NoiseFloorIsRemoved) {
  const double rate = 200.0;
  // Noise power (0.2^2 * 100 Hz bandwidth) comparable with the signal's, spread up to 100 Hz:
  // without the floor the 99.5 % frequency would be near Nyquist.
  const auto signal = Sines({0.7, 2.0}, rate, 6000, 0.2, 2);
  EXPECT_GT(SignalBandwidthHz(signal, rate, 0.0, 0.995), 50.0);
  EXPECT_NEAR(SignalBandwidthHz(signal, rate, 0.2, 0.995), 2.0, 0.5);
}

TEST(KnotSpacing, SpacingFollowsTheFasterOfGyroAndAccel) {
  const double rate = 250.0;
  const int n = 5000;
  std::vector<std::int64_t> t(n);
  for (int i = 0; i < n; ++i)
    t[i] = 1'000'000'000LL + static_cast<std::int64_t>(i * 4'000'000LL);
  const auto gyro = Sines({1.0}, rate, n, 0.0, 3);
  const auto accel = Sines({0.5, 2.5}, rate, n, 0.0, 4);
  KnotSpacingOptions options;
  const MotionBandwidth bw = ChooseKnotSpacing(t, gyro, accel, 0.0, 0.0, options);
  EXPECT_NEAR(bw.gyro_hz, 1.0, 0.1);
  EXPECT_NEAR(bw.accel_hz, 2.5, 0.1);
  EXPECT_NEAR(bw.knot_spacing_s, 1.0 / (options.knots_per_period * 2.5), 0.003);
}

// 10 min at 1 kHz has 600001 = 19 * 23 * 1373 samples, a length on which the FFT is O(n * 1373)
// (minutes); the analysed 5-smooth prefix gives the same bandwidth in milliseconds.
TEST(KnotSpacing, LongRecordingOfAwkwardLengthIsAnalysedQuickly) {
  const double rate = 1000.0;
  const auto signal = Sines({1.0, 3.0}, rate, 600001, 0.0, 5);
  EXPECT_NEAR(SignalBandwidthHz(signal, rate, 0.0, 0.995), 3.0, 0.05);
}

TEST(KnotSpacing, StaticDataGetsTheWidestSpacingAndBadInputThrows) {
  const int n = 100;
  std::vector<std::int64_t> t(n);
  for (int i = 0; i < n; ++i)
    t[i] = i * 5'000'000LL;
  const std::vector<Eigen::Vector3d> still(n, Eigen::Vector3d(0, 0, 9.81));
  const MotionBandwidth bw = ChooseKnotSpacing(t, still, still, 0.0, 0.0);
  EXPECT_DOUBLE_EQ(bw.knot_spacing_s, KnotSpacingOptions().max_spacing_s);
  EXPECT_THROW(ChooseKnotSpacing({0, 1}, {{0, 0, 0}, {0, 0, 0}}, {{0, 0, 0}, {0, 0, 0}}, 0, 0),
               std::invalid_argument);
}

}  // namespace
}  // namespace ctcal
