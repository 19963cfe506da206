#include "ctcal/calibrator/init/angular_rates.h"

#include <algorithm>
#include <cmath>

#include "ctcal/spline/so3.h"

namespace ctcal {

namespace {

double Seconds(std::int64_t t_ns) {
  return static_cast<double>(t_ns) * 1e-9;
}

// Linear interpolation of the rate at time t (s); false outside the samples' span.
bool InterpolateRate(const std::vector<RateSample>& rates, double t, Eigen::Vector3d* w) {
  if (rates.size() < 2 || t < Seconds(rates.front().t_ns) || t > Seconds(rates.back().t_ns))
    return false;
  const auto it =
      std::lower_bound(rates.begin(), rates.end(), t,
                       [](const RateSample& r, double value) { return Seconds(r.t_ns) < value; });
  if (it == rates.begin()) {
    *w = it->w_S;
    return true;
  }
  const RateSample& b = *it;
  const RateSample& a = *(it - 1);
  const double ta = Seconds(a.t_ns), tb = Seconds(b.t_ns);
  const double s = tb > ta ? (t - ta) / (tb - ta) : 0.0;
  *w = (1.0 - s) * a.w_S + s * b.w_S;
  return true;
}

}  // namespace

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

std::vector<RateSample> RatesFromBoardViews(const std::vector<BoardView>& views) {
  std::vector<RateSample> rates;
  if (views.size() < 2)
    return rates;
  std::vector<std::int64_t> gaps;
  for (std::size_t k = 1; k < views.size(); ++k)
    gaps.push_back(views[k].t_ns - views[k - 1].t_ns);
  std::nth_element(gaps.begin(), gaps.begin() + static_cast<long>(gaps.size() / 2), gaps.end());
  const double max_gap = 1.5 * static_cast<double>(gaps[gaps.size() / 2]);
  for (std::size_t k = 1; k < views.size(); ++k) {
    const std::int64_t dt_ns = views[k].t_ns - views[k - 1].t_ns;
    if (dt_ns <= 0 || static_cast<double>(dt_ns) > max_gap)
      continue;
    // R_W_C(t0)^T R_W_C(t1) = R_C_W(t0) R_C_W(t1)^T.
    const Eigen::Matrix3d dR = views[k - 1].T_C_W.linear() * views[k].T_C_W.linear().transpose();
    const double span = static_cast<double>(dt_ns) * 1e-9;
    rates.push_back(
        {views[k - 1].t_ns + dt_ns / 2, LogSO3<double>(Eigen::Quaterniond(dR)) / span, span});
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

bool RateOfBaseOver(const std::vector<RateSample>& base, double t0, double t1,
                    Eigen::Vector3d* w_B) {
  if (t1 <= t0)
    return InterpolateRate(base, t0, w_B);
  Eigen::Vector3d w0, w1;
  if (!InterpolateRate(base, t0, &w0) || !InterpolateRate(base, t1, &w1))
    return false;
  // Breakpoints: the interval's ends and every gyro sample inside; on each piece the rate is
  // linear, so its midpoint value integrates it to second order.
  auto it = std::upper_bound(base.begin(), base.end(), t0, [](double value, const RateSample& r) {
    return value < Seconds(r.t_ns);
  });
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  double ta = t0;
  Eigen::Vector3d wa = w0;
  while (true) {
    double tb;
    Eigen::Vector3d wb;
    if (it != base.end() && Seconds(it->t_ns) < t1) {
      tb = Seconds(it->t_ns);
      wb = it->w_S;
      ++it;
    } else {
      tb = t1;
      wb = w1;
    }
    q = q * ExpSO3<double>(Eigen::Vector3d(0.5 * (wa + wb) * (tb - ta)));
    ta = tb;
    wa = wb;
    if (tb >= t1)
      break;
  }
  *w_B = LogSO3<double>(q.normalized()) / (t1 - t0);
  return true;
}

}  // namespace ctcal
