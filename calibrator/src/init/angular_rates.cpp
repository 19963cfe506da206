#include "ctcal/calibrator/init/angular_rates.h"
#include "ctcal/calibrator/init/init_log.h"

#include <algorithm>
#include <cmath>

#include "ctcal/spline/so3.h"

namespace ctcal {

std::vector<RateSample> RatesFromImu(const std::vector<ImuSample>& samples) {
  std::vector<RateSample> rates;
  rates.reserve(samples.size());
  for (const ImuSample& s : samples)
    rates.push_back({s.t_ns, s.w_m, 0.0});
  return rates;
}

std::vector<RateSample> RatesFromGyro(const std::vector<GyroSample>& samples) {
  std::vector<RateSample> rates;
  rates.reserve(samples.size());
  for (const GyroSample& s : samples)
    rates.push_back({s.t_ns, s.w_m, 0.0});
  return rates;
}

std::vector<RateSample> RatesFromBoardViews(const std::vector<BoardView>& views, int stride) {
  std::vector<RateSample> rates;
  const std::size_t step = static_cast<std::size_t>(std::max(stride, 1));
  if (views.size() < step + 1)
    return rates;
  std::vector<std::int64_t> gaps;
  for (std::size_t k = 1; k < views.size(); ++k)
    gaps.push_back(views[k].t_ns - views[k - 1].t_ns);
  std::nth_element(gaps.begin(), gaps.begin() + static_cast<long>(gaps.size() / 2), gaps.end());
  const double max_gap =
      1.5 * static_cast<double>(step) * static_cast<double>(gaps[gaps.size() / 2]);
  for (std::size_t k = step; k < views.size(); ++k) {
    const BoardView& v0 = views[k - step];
    const std::int64_t dt_ns = views[k].t_ns - v0.t_ns;
    if (dt_ns <= 0 || static_cast<double>(dt_ns) > max_gap)
      continue;
    // R_W_C(t0)^T R_W_C(t1) = R_C_W(t0) R_C_W(t1)^T.
    const Eigen::Matrix3d dR = v0.T_C_W.linear() * views[k].T_C_W.linear().transpose();
    const double span = static_cast<double>(dt_ns) * 1e-9;
    rates.push_back({v0.t_ns + dt_ns / 2, LogSO3<double>(Eigen::Quaterniond(dR)) / span, span});
  }
  return rates;
}

Eigen::Vector3d MedianRate(const std::vector<RateSample>& rates) {
  Eigen::Vector3d median = Eigen::Vector3d::Zero();
  if (rates.empty())
    return median;
  std::vector<double> axis(rates.size());
  for (int i = 0; i < 3; ++i) {
    for (std::size_t k = 0; k < rates.size(); ++k)
      axis[k] = rates[k].w_S[i];
    std::nth_element(axis.begin(), axis.begin() + static_cast<long>(axis.size() / 2), axis.end());
    median[i] = axis[axis.size() / 2];
  }
  return median;
}

BaseRateIntegral::BaseRateIntegral(const std::vector<RateSample>& base) {
  t_.reserve(base.size());
  w_.reserve(base.size());
  q_.reserve(base.size());
  for (const RateSample& r : base) {
    const double t = InitSeconds(r.t_ns);
    q_.push_back(q_.empty() ? Eigen::Quaterniond::Identity()
                            : (q_.back() * ExpSO3<double>(Eigen::Vector3d(
                                               0.5 * (w_.back() + r.w_S) * (t - t_.back()))))
                                  .normalized());
    t_.push_back(t);
    w_.push_back(r.w_S);
  }
}

std::size_t BaseRateIntegral::Locate(double t, std::size_t* cursor) const {
  std::size_t k = std::min(*cursor, t_.size() - 1);
  if (t_[k] > t) {
    k = static_cast<std::size_t>(
            std::upper_bound(t_.begin(), t_.begin() + static_cast<long>(k), t) - t_.begin()) -
        1;
  } else {
    // A few steps forward (the next query of a sweep), else a search over the rest.
    int steps = 0;
    while (k + 1 < t_.size() && t_[k + 1] <= t && ++steps < 16)
      ++k;
    if (steps == 16)
      k = static_cast<std::size_t>(
              std::upper_bound(t_.begin() + static_cast<long>(k), t_.end(), t) - t_.begin()) -
          1;
  }
  *cursor = k;
  return k;
}

Eigen::Vector3d BaseRateIntegral::RateAt(std::size_t k, double t) const {
  if (k + 1 == t_.size())
    return w_[k];
  const double s = t_[k + 1] > t_[k] ? (t - t_[k]) / (t_[k + 1] - t_[k]) : 0.0;
  return (1.0 - s) * w_[k] + s * w_[k + 1];
}

bool BaseRateIntegral::RateOver(double t0, double t1, Eigen::Vector3d* w_B,
                                std::size_t* cursor) const {
  if (t_.size() < 2 || t0 < t_.front() || t0 > t_.back())
    return false;
  const std::size_t k0 = Locate(t0, cursor);
  if (t1 <= t0) {
    *w_B = RateAt(k0, t0);
    return true;
  }
  if (t1 > t_.back())
    return false;
  std::size_t scan = k0;
  const std::size_t k1 = Locate(t1, &scan);
  const Eigen::Vector3d w0 = RateAt(k0, t0), w1 = RateAt(k1, t1);
  // The samples strictly inside (t0, t1): a .. b.
  const std::size_t a = k0 + 1;
  const std::size_t b = t_[k1] < t1 ? k1 : k1 - 1;
  Eigen::Quaterniond q;
  if (a > b) {
    q = ExpSO3<double>(Eigen::Vector3d(0.5 * (w0 + w1) * (t1 - t0)));
  } else {
    q = ExpSO3<double>(Eigen::Vector3d(0.5 * (w0 + w_[a]) * (t_[a] - t0))) *
        (q_[a].conjugate() * q_[b]) *
        ExpSO3<double>(Eigen::Vector3d(0.5 * (w_[b] + w1) * (t1 - t_[b])));
  }
  *w_B = LogSO3<double>(q.normalized()) / (t1 - t0);
  return true;
}

}  // namespace ctcal
