#include "ctcal/calibrator/knot_spacing.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <stdexcept>
#include <unsupported/Eigen/FFT>

namespace ctcal {

namespace {

// The longest length <= n with no prime factor above 5. Eigen's FFT (kissfft) costs O(n p) for a
// prime factor p of n: 10 min at 1 kHz (600001 = 19 * 23 * 1373 samples) took minutes, the
// 5-smooth prefix (at most a fraction of a percent shorter) takes milliseconds.
int SmoothLength(int n) {
  for (int m = n; m > 1; --m) {
    int k = m;
    for (const int p : {2, 3, 5}) {
      while (k % p == 0)
        k /= p;
    }
    if (k == 1)
      return m;
  }
  return n;
}

}  // namespace

double SignalBandwidthHz(const std::vector<Eigen::Vector3d>& signal, double rate_hz,
                         double noise_sigma, double energy_fraction) {
  if (signal.size() < 16)
    throw std::invalid_argument("bandwidth: need at least 16 samples");
  const int n = SmoothLength(static_cast<int>(signal.size()));
  // Half-spectrum bins k = 0 .. n/2 at k * rate / n. White noise of variance s^2 puts an
  // expected |X_k|^2 of n s^2 into every bin (unnormalised DFT), exponentially distributed. Merely
  // subtracting that mean would leave ~1/e of it per bin, which over thousands of bins swamps the
  // motion; a bin counts only when noise alone would exceed it with probability < 1 % over the
  // whole spectrum (P(|X|^2 > c mean) = exp(-c)).
  const int bins = n / 2 + 1;
  const double significance = std::log(3.0 * bins / 0.01);
  std::vector<double> power(bins, 0.0);
  Eigen::FFT<double> fft;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> x(n);
    double mean = 0.0;
    for (int i = 0; i < n; ++i)
      mean += signal[i](axis);
    mean /= n;
    for (int i = 0; i < n; ++i)
      x[i] = signal[i](axis) - mean;
    std::vector<std::complex<double>> spectrum;
    fft.fwd(spectrum, x);
    const double floor = n * noise_sigma * noise_sigma;
    for (int k = 1; k < bins; ++k) {
      const double p = std::norm(spectrum[k]);
      if (p > significance * floor)
        power[k] += p - floor;
    }
  }
  double total = 0.0;
  for (double p : power)
    total += p;
  // Parseval: the signal's variance is ~2 total / n^2. Below a micro-unit RMS there is no motion
  // to resolve (only rounding), and the widest spacing is right.
  if (2.0 * total / (static_cast<double>(n) * n) < 1e-12)
    return 0.0;
  double cumulative = 0.0;
  for (int k = 1; k < bins; ++k) {
    cumulative += power[k];
    if (cumulative >= energy_fraction * total)
      return k * rate_hz / n;
  }
  return 0.5 * rate_hz;
}

MotionBandwidth ChooseKnotSpacing(const std::vector<std::int64_t>& t_ns,
                                  const std::vector<Eigen::Vector3d>& gyro,
                                  const std::vector<Eigen::Vector3d>& accel,
                                  double gyro_noise_sigma, double accel_noise_sigma,
                                  const KnotSpacingOptions& options) {
  if (t_ns.size() != gyro.size() || t_ns.size() != accel.size() || t_ns.size() < 16) {
    throw std::invalid_argument("knot spacing: need at least 16 IMU samples with gyro and accel");
  }
  const double duration_s = 1e-9 * static_cast<double>(t_ns.back() - t_ns.front());
  if (!(duration_s > 0.0))
    throw std::invalid_argument("knot spacing: IMU time span is zero");
  // The FFT assumes uniform sampling; small jitter only smears the spectrum slightly.
  const double rate_hz = static_cast<double>(t_ns.size() - 1) / duration_s;

  MotionBandwidth out;
  out.gyro_hz = SignalBandwidthHz(gyro, rate_hz, gyro_noise_sigma, options.energy_fraction);
  out.accel_hz = SignalBandwidthHz(accel, rate_hz, accel_noise_sigma, options.energy_fraction);
  const double f = std::max(out.gyro_hz, out.accel_hz);
  const double spacing = f > 0.0 ? 1.0 / (options.knots_per_period * f) : options.max_spacing_s;
  out.knot_spacing_s = std::clamp(spacing, options.min_spacing_s, options.max_spacing_s);
  return out;
}

}  // namespace ctcal
