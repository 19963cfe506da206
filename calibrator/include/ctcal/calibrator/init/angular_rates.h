// Angular-rate signals of every sensor type in one form, for the time-offset and hand-eye stages:
// gyro readings as they are, and a camera's rate from consecutive board poses.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "ctcal/calibrator/spline_init.h"
#include "ctcal/sensors/dataset.h"

namespace ctcal {

// An angular rate of sensor S in its own frame, stamped on its own clock. span = 0: an
// instantaneous reading (a gyro); span > 0: the mean rate over [t - span/2, t + span/2], i.e.
// Log(R_S(t0)^T R_S(t1)) / span (a camera between two views).
struct RateSample {
  std::int64_t t_ns = 0;
  Eigen::Vector3d w_S = Eigen::Vector3d::Zero();
  double span = 0.0;  // seconds
};

std::vector<RateSample> RatesFromImu(const std::vector<ImuSample>& samples);
std::vector<RateSample> RatesFromGyro(const std::vector<GyroSample>& samples);

// Mean rate of the camera between consecutive views (at most 1.5 median frame periods apart),
// stamped at their midpoint: w_C = Log(R_W_C(t0)^T R_W_C(t1)) / (t1 - t0). Finite differences
// of poses rather than a fitted spline: between two views this is exact for the rotation the
// camera made, and the base rate is integrated over the same interval (BaseRateIntegral), so the
// two sides compare the same quantity without a smoothing prior. With `stride` > 1 the views are
// k - stride and k (at most 1.5 stride median periods apart): a pose's noise then weighs 1/stride
// as much in the rate, for noisy corners, at the price of a rate averaged over a longer span.
std::vector<RateSample> RatesFromBoardViews(const std::vector<BoardView>& views, int stride = 1);

// Per-axis median of the readings: the approximate gyro bias of a recording whose rotations go
// back and forth (a hand-held wave), good enough to centre the rate magnitude for correlation.
Eigen::Vector3d MedianRate(const std::vector<RateSample>& rates);

// The base gyro prepared for the many rate queries of the time-offset and hand-eye stages (one
// per sensor sample and searched lag). The orientation is integrated over the samples once,
// R(t_k) = R(t_k-1) Exp((w_k-1 + w_k) / 2 (t_k - t_k-1)) with the rate linear between samples
// (second order per piece), so the rotation over an interval is R(t_a)^T R(t_b) between its
// inner samples times the two partial pieces at its ends: O(1) per query instead of one Exp per
// gyro sample inside it (~12 per camera interval at 250 Hz).
class BaseRateIntegral {
 public:
  explicit BaseRateIntegral(const std::vector<RateSample>& base);

  // The base's mean rate over [t0, t1] (base clock, s): Log(R(t0)^T R(t1)) / (t1 - t0); t1 <= t0:
  // the rate linearly interpolated at t0. False when the interval is not inside the gyro's time
  // span. `cursor` is a sample index kept by the caller between queries (start at 0): queries
  // whose times increase then cost O(1) instead of a search.
  bool RateOver(double t0, double t1, Eigen::Vector3d* w_B, std::size_t* cursor) const;

 private:
  std::size_t Locate(double t, std::size_t* cursor) const;  // last sample with t_k <= t
  Eigen::Vector3d RateAt(std::size_t k, double t) const;    // interpolated in [t_k, t_k+1]

  std::vector<double> t_;                                                            // s
  std::vector<Eigen::Vector3d> w_;                                                   // rad/s
  std::vector<Eigen::Quaterniond, Eigen::aligned_allocator<Eigen::Quaterniond>> q_;  // R(t_k)
};

}  // namespace ctcal
