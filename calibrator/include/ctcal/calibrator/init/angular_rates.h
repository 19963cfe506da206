// Angular-rate signals of every sensor type in one form, for the time-offset and hand-eye stages:
// gyro readings as they are, and a camera's rate from consecutive board poses.
#pragma once

#include <Eigen/Core>
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
// camera made, and the base rate is integrated over the same interval (RateOfBaseOver), so the
// two sides compare the same quantity without a smoothing prior.
std::vector<RateSample> RatesFromBoardViews(const std::vector<BoardView>& views);

// Per-axis median of the readings: the approximate gyro bias of a recording whose rotations go
// back and forth (a hand-held wave), good enough to centre the rate magnitude for correlation.
Eigen::Vector3d MedianRate(const std::vector<RateSample>& rates);

// The base's rate over [t0, t1] (base clock, seconds) from its gyro: Log of the product of
// Exp(w dt) with w linearly interpolated, divided by t1 - t0; span 0 (t0 == t1) interpolates.
// False when the interval is not inside the gyro's time span.
bool RateOfBaseOver(const std::vector<RateSample>& base, double t0, double t1,
                    Eigen::Vector3d* w_B);

}  // namespace ctcal
