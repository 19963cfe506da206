#include "ctcal/calibrator/init/time_offset_init.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>

#include "ctcal/calibrator/init/inertial_init.h"
#include "ctcal/sensors/parallel_for.h"

namespace ctcal {

namespace {

constexpr const char* kStage = "time offset";

struct Correlation {
  double value = -1.0;
  int samples = 0;
};

// Pearson correlation of the sensor's rate magnitudes with the base's at the shifted times.
Correlation CorrelateAt(const BaseRateIntegral& base, const std::vector<double>& sensor_t,
                        const std::vector<double>& sensor_span,
                        const std::vector<double>& sensor_mag, double lag) {
  double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
  int n = 0;
  std::size_t cursor = 0;
  for (std::size_t k = 0; k < sensor_t.size(); ++k) {
    const double t = sensor_t[k] + lag;
    Eigen::Vector3d w_B;
    if (!base.RateOver(t - 0.5 * sensor_span[k], t + 0.5 * sensor_span[k], &w_B, &cursor))
      continue;
    const double x = sensor_mag[k];
    const double y = w_B.norm();
    sx += x;
    sy += y;
    sxx += x * x;
    syy += y * y;
    sxy += x * y;
    ++n;
  }
  Correlation c;
  c.samples = n;
  if (n < 3)
    return c;
  const double cov = sxy - sx * sy / n;
  const double vx = sxx - sx * sx / n;
  const double vy = syy - sy * sy / n;
  if (vx <= 0.0 || vy <= 0.0)
    return c;
  c.value = cov / std::sqrt(vx * vy);
  return c;
}

}  // namespace

TimeOffsetResult InitTimeOffset(const std::string& sensor_name,
                                const std::vector<RateSample>& base_rates,
                                const std::vector<RateSample>& sensor_rates,
                                const TimeOffsetOptions& options, const InitLog& log) {
  if (static_cast<int>(sensor_rates.size()) < options.min_samples)
    throw InitError(kStage, sensor_name,
                    "only " + std::to_string(sensor_rates.size()) + " rate samples (need " +
                        std::to_string(options.min_samples) + ")");
  if (base_rates.size() < 2)
    throw InitError(kStage, sensor_name, "the base gyroscope has fewer than 2 samples");

  // Gyro biases shift the magnitudes unevenly; a camera's rate has none.
  const Eigen::Vector3d bias_B =
      options.remove_median_bias ? MedianRate(base_rates) : Eigen::Vector3d::Zero();
  std::vector<RateSample> base = base_rates;
  for (RateSample& r : base)
    r.w_S -= bias_B;
  const BaseRateIntegral base_integral(base_rates);
  std::optional<BaseRateIntegral> centred;
  if (options.remove_median_bias)
    centred.emplace(base);
  const BaseRateIntegral& correlated = centred ? *centred : base_integral;
  std::vector<RateSample> gyro_part;
  for (const RateSample& r : sensor_rates)
    if (r.span == 0.0)
      gyro_part.push_back(r);
  const Eigen::Vector3d bias_S =
      options.remove_median_bias ? MedianRate(gyro_part) : Eigen::Vector3d::Zero();

  std::vector<double> sensor_t, sensor_span, sensor_mag;
  double sum = 0, sum_sq = 0;
  for (const RateSample& r : sensor_rates) {
    sensor_t.push_back(InitSeconds(r.t_ns));
    sensor_span.push_back(r.span);
    const double m = (r.span == 0.0 ? (r.w_S - bias_S) : r.w_S).norm();
    sensor_mag.push_back(m);
    sum += m;
    sum_sq += m * m;
  }
  const double n = static_cast<double>(sensor_mag.size());
  TimeOffsetResult result;
  result.rate_std = std::sqrt(std::max(0.0, sum_sq / n - (sum / n) * (sum / n)));
  if (result.rate_std < options.min_rate_std)
    throw InitError(
        kStage, sensor_name,
        FormatInitLine("ambiguous correlation: no rotation (rate magnitude std %.4f rad/s < "
                       "%.4f)",
                       result.rate_std, options.min_rate_std));

  // Coarse search on the lag grid.
  const int half = static_cast<int>(std::round(options.max_offset / options.coarse_step));
  std::vector<double> corr(static_cast<std::size_t>(2 * half + 1));
  ParallelFor(options.threads, corr.size(), [&](std::size_t i) {
    corr[i] = CorrelateAt(correlated, sensor_t, sensor_span, sensor_mag,
                          (static_cast<int>(i) - half) * options.coarse_step)
                  .value;
  });
  const int p = static_cast<int>(std::max_element(corr.begin(), corr.end()) - corr.begin());
  // The main lobe: from the peak down to the first local minimum on each side.
  int lo = p, hi = p;
  while (lo > 0 && corr[static_cast<std::size_t>(lo - 1)] <= corr[static_cast<std::size_t>(lo)])
    --lo;
  while (hi + 1 < static_cast<int>(corr.size()) &&
         corr[static_cast<std::size_t>(hi + 1)] <= corr[static_cast<std::size_t>(hi)])
    ++hi;
  result.secondary_correlation = 0.0;
  for (int i = 0; i < static_cast<int>(corr.size()); ++i) {
    if (i >= lo && i <= hi)
      continue;
    const double c = corr[static_cast<std::size_t>(i)];
    const bool left_ok = i == 0 || corr[static_cast<std::size_t>(i - 1)] <= c;
    const bool right_ok =
        i + 1 == static_cast<int>(corr.size()) || corr[static_cast<std::size_t>(i + 1)] <= c;
    // A distinct peak: the correlation falls by min_secondary_prominence between it and the
    // main one (noise ripples on the broad lobe of a slow motion do not).
    double valley = c;
    for (int j = std::min(i, p); j <= std::max(i, p); ++j)
      valley = std::min(valley, corr[static_cast<std::size_t>(j)]);
    if (left_ok && right_ok && c - valley >= options.min_secondary_prominence &&
        c > result.secondary_correlation) {
      result.secondary_correlation = c;
      result.secondary_offset = (i - half) * options.coarse_step;
    }
  }
  const double coarse_lag = (p - half) * options.coarse_step;
  result.peak_correlation = corr[static_cast<std::size_t>(p)];
  if (p == 0 || p + 1 == static_cast<int>(corr.size()))
    throw InitError(
        kStage, sensor_name,
        FormatInitLine("correlation peak at the search boundary (%+.1f ms, max +-%.0f ms): "
                       "the offset is larger than the search range or the motion has no "
                       "distinct features",
                       coarse_lag * 1e3, options.max_offset * 1e3));
  if (result.peak_correlation < options.min_peak_correlation)
    throw InitError(
        kStage, sensor_name,
        FormatInitLine("ambiguous correlation: peak %.3f < %.2f at %+.1f ms (rates do not "
                       "match: wrong sensor data or too little rotation)",
                       result.peak_correlation, options.min_peak_correlation, coarse_lag * 1e3));
  if (result.secondary_correlation > options.max_secondary_ratio * result.peak_correlation)
    throw InitError(
        kStage, sensor_name,
        FormatInitLine(
            "ambiguous correlation: peaks %.3f at %+.1f ms and %.3f at %+.1f ms (periodic "
            "or featureless motion)",
            result.peak_correlation, coarse_lag * 1e3, result.secondary_correlation,
            result.secondary_offset * 1e3));

  // Fine grid around the coarse peak, then a parabola through the best point's neighbours.
  const int fine_half = static_cast<int>(std::ceil(2.0 * options.coarse_step / options.fine_step));
  std::vector<double> fine(static_cast<std::size_t>(2 * fine_half + 1));
  ParallelFor(options.threads, fine.size(), [&](std::size_t i) {
    fine[i] = CorrelateAt(correlated, sensor_t, sensor_span, sensor_mag,
                          coarse_lag + (static_cast<int>(i) - fine_half) * options.fine_step)
                  .value;
  });
  int q = static_cast<int>(std::max_element(fine.begin(), fine.end()) - fine.begin());
  q = std::clamp(q, 1, 2 * fine_half - 1);
  const double ym = fine[static_cast<std::size_t>(q - 1)];
  const double y0 = fine[static_cast<std::size_t>(q)];
  const double yp = fine[static_cast<std::size_t>(q + 1)];
  const double denom = ym - 2.0 * y0 + yp;
  const double delta = denom < 0.0 ? std::clamp(0.5 * (ym - yp) / denom, -0.5, 0.5) : 0.0;
  result.time_offset = coarse_lag + (q - fine_half + delta) * options.fine_step;
  result.correlation_offset = result.time_offset;
  if (options.refine_half_width > 0.0) {
    // Magnitudes discard the direction and the correlation lobe of a slow wave is wide, so small
    // bias and noise distortions move its peak by a millisecond or more. The vector model of
    // stage 4 (w_B = R_B_S w_S + c, bias term included) is sharper: its residual, minimised
    // over R_B_S and c, is minimal at the true offset.
    HandEyeOptions hand_eye;
    hand_eye.min_pairs = options.min_samples;
    hand_eye.min_excitation = 0.0;
    auto cost = [&](double lag) {
      try {
        const double rms =
            InitRotationHandEye(sensor_name, base_integral, sensor_rates, lag, hand_eye, {})
                .rms_rad_s;
        return rms * rms;
      } catch (const InitError&) {
        return std::numeric_limits<double>::infinity();
      }
    };
    const int m = static_cast<int>(std::round(options.refine_half_width / options.refine_step));
    std::vector<double> costs(static_cast<std::size_t>(2 * m + 1));
    ParallelFor(options.threads, costs.size(), [&](std::size_t i) {
      costs[i] = cost(result.time_offset + (static_cast<int>(i) - m) * options.refine_step);
    });
    int b = static_cast<int>(std::min_element(costs.begin(), costs.end()) - costs.begin());
    if (std::isfinite(costs[static_cast<std::size_t>(b)]) && b > 0 && b < 2 * m) {
      const double cm = costs[static_cast<std::size_t>(b - 1)];
      const double c0 = costs[static_cast<std::size_t>(b)];
      const double cp = costs[static_cast<std::size_t>(b + 1)];
      const double den = cm - 2.0 * c0 + cp;
      const double shift = den > 0.0 ? std::clamp(0.5 * (cm - cp) / den, -0.5, 0.5) : 0.0;
      result.time_offset += (b - m + shift) * options.refine_step;
    }
  }
  const Correlation at_peak =
      CorrelateAt(correlated, sensor_t, sensor_span, sensor_mag, result.time_offset);
  result.peak_correlation = std::max(result.peak_correlation, at_peak.value);
  result.samples = at_peak.samples;
  result.summary = sensor_name + ": " +
                   FormatInitLine(
                       "time offset %+.3f ms (correlation %.4f, next peak %.3f at %+.1f ms, "
                       "%d samples)",
                       result.time_offset * 1e3, result.peak_correlation,
                       result.secondary_correlation, result.secondary_offset * 1e3, result.samples);
  if (log)
    log(result.summary);
  return result;
}

}  // namespace ctcal
