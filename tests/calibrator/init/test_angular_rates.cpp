// The base gyro's rate over an interval (BaseRateIntegral, used by the time-offset and hand-eye
// stages) against a direct integration of the same piecewise-linear rate, one Exp per piece; the
// cursor (queries in time order) against a fresh search; and the exact mean rate of a motion about
// one fixed axis.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "ctcal/calibrator/init/angular_rates.h"
#include "ctcal/calibrator/spline_init.h"
#include "ctcal/spline/so3.h"

namespace ctcal {
namespace {

double Seconds(std::int64_t t_ns) {
  return 1e-9 * static_cast<double>(t_ns);
}

// A 250 Hz gyro with 1 % jitter on its stamps and a rate of ~1 rad/s about changing axes.
std::vector<RateSample> Gyro(int samples) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-4e4, 4e4);
  std::vector<RateSample> base;
  for (int k = 0; k < samples; ++k) {
    const std::int64_t t_ns = 1000000000LL + 4000000LL * k + std::llround(jitter(rng));
    const double t = Seconds(t_ns);
    base.push_back(
        {t_ns,
         Eigen::Vector3d(std::sin(1.3 * t) + 0.5 * std::sin(3.1 * t + 1.0),
                         0.8 * std::cos(0.7 * t) * std::sin(2.3 * t), 0.6 * std::sin(4.7 * t)),
         0.0});
  }
  return base;
}

// The reference: the rate linear between samples (and between the interval's ends and the
// samples next to them), each piece integrated by Exp of its midpoint rate times its length.
Eigen::Vector3d DirectRateOver(const std::vector<RateSample>& base, double t0, double t1) {
  const auto rate_at = [&](double t) {
    std::size_t k = 0;
    while (k + 2 < base.size() && Seconds(base[k + 1].t_ns) <= t)
      ++k;
    const double ta = Seconds(base[k].t_ns), tb = Seconds(base[k + 1].t_ns);
    const double s = (t - ta) / (tb - ta);
    return Eigen::Vector3d((1.0 - s) * base[k].w_S + s * base[k + 1].w_S);
  };
  if (t1 <= t0)
    return rate_at(t0);
  std::vector<std::pair<double, Eigen::Vector3d>> knots = {{t0, rate_at(t0)}};
  for (const RateSample& r : base) {
    if (Seconds(r.t_ns) > t0 && Seconds(r.t_ns) < t1)
      knots.emplace_back(Seconds(r.t_ns), r.w_S);
  }
  knots.emplace_back(t1, rate_at(t1));
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  for (std::size_t i = 1; i < knots.size(); ++i) {
    const double dt = knots[i].first - knots[i - 1].first;
    q = q * ExpSO3<double>(Eigen::Vector3d(0.5 * (knots[i - 1].second + knots[i].second) * dt));
  }
  return LogSO3<double>(q.normalized()) / (t1 - t0);
}

TEST(BaseRateIntegral, MatchesTheDirectIntegrationOfEveryInterval) {
  const std::vector<RateSample> base = Gyro(3000);  // 12 s
  const BaseRateIntegral integral(base);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> start(Seconds(base.front().t_ns),
                                               Seconds(base.back().t_ns) - 0.2);
  std::uniform_real_distribution<double> span(0.0, 0.1);
  std::vector<std::pair<double, double>> queries;
  for (int i = 0; i < 400; ++i) {
    const double t0 = start(rng);
    queries.emplace_back(t0, t0 + span(rng));
  }
  // Ends on samples, both ends inside one piece, a camera interval (50 ms), the whole span, and
  // span 0 (the interpolated rate).
  const double s10 = Seconds(base[10].t_ns), s11 = Seconds(base[11].t_ns);
  queries.emplace_back(s10, Seconds(base[23].t_ns));
  queries.emplace_back(s10 + 1e-4, s11);
  queries.emplace_back(s10 + 1e-4, s11 - 1e-4);
  queries.emplace_back(s10, s10 + 0.05);
  queries.emplace_back(s10 + 2e-3, s10 + 2e-3);
  queries.emplace_back(Seconds(base.front().t_ns), Seconds(base.back().t_ns));
  std::sort(queries.begin(), queries.end());
  std::size_t cursor = 0;
  for (const auto& [t0, t1] : queries) {
    Eigen::Vector3d swept, fresh;
    ASSERT_TRUE(integral.RateOver(t0, t1, &swept, &cursor)) << t0;
    std::size_t none = 0;
    ASSERT_TRUE(integral.RateOver(t0, t1, &fresh, &none)) << t0;
    // The cursor only saves the search: the same samples, the same arithmetic.
    EXPECT_EQ(swept, fresh) << t0;
    // The integrated orientation differs from the direct product by rounding only (~1e-16 rad
    // per sample, a random walk over 3000 samples), divided by the span.
    EXPECT_LE((swept - DirectRateOver(base, t0, t1)).norm(), 1e-12 / std::max(t1 - t0, 1e-3))
        << "[" << t0 << ", " << t1 << "]";
  }
  // Outside the gyro's span: no rate.
  Eigen::Vector3d w;
  std::size_t c = 0;
  EXPECT_FALSE(integral.RateOver(Seconds(base.front().t_ns) - 1e-3, Seconds(base[5].t_ns), &w, &c));
  EXPECT_FALSE(integral.RateOver(Seconds(base.back().t_ns) - 0.01, Seconds(base.back().t_ns) + 1e-3,
                                 &w, &c));
}

// About a fixed axis the rotations commute, so the mean rate over [t0, t1] is the integral of the
// (piecewise-linear) rate divided by the span: the trapezoid rule on the samples is exact.
TEST(BaseRateIntegral, FixedAxisMeanRateIsExact) {
  const Eigen::Vector3d axis = Eigen::Vector3d(1.0, -2.0, 0.5).normalized();
  std::vector<RateSample> base;
  for (int k = 0; k < 500; ++k) {
    const double t = 2.0 + 0.004 * k;
    base.push_back({std::llround(t * 1e9), (0.1 + 0.4 * std::sin(9.0 * t)) * axis, 0.0});
  }
  const BaseRateIntegral integral(base);
  const double t0 = 2.1013, t1 = 2.1517;
  // The signed rate about the axis, linear between the samples' stamps.
  std::vector<double> t_k, r_k;
  for (const RateSample& r : base) {
    t_k.push_back(Seconds(r.t_ns));
    r_k.push_back(axis.dot(r.w_S));
  }
  const auto rate = [&](double t) {
    const std::size_t k =
        static_cast<std::size_t>(std::upper_bound(t_k.begin(), t_k.end(), t) - t_k.begin()) - 1;
    const double s = (t - t_k[k]) / (t_k[k + 1] - t_k[k]);
    return (1.0 - s) * r_k[k] + s * r_k[k + 1];
  };
  std::vector<double> knots = {t0};
  for (const double t : t_k) {
    if (t > t0 && t < t1)
      knots.push_back(t);
  }
  knots.push_back(t1);
  double angle = 0.0;  // trapezoid over the pieces of the linear interpolant: exact
  for (std::size_t i = 1; i < knots.size(); ++i)
    angle += 0.5 * (rate(knots[i - 1]) + rate(knots[i])) * (knots[i] - knots[i - 1]);
  Eigen::Vector3d w;
  std::size_t cursor = 0;
  ASSERT_TRUE(integral.RateOver(t0, t1, &w, &cursor));
  EXPECT_NEAR((w - angle / (t1 - t0) * axis).norm(), 0.0, 1e-12);
}

// A camera turning about a fixed axis by theta(t) = 0.3 t + 0.2 t^2 (rad), seen at 20 Hz with the
// view at 0.5 s missing: the rate between views k - stride and k is the angle they differ by over
// their time apart, stamped at the midpoint with that span, and a pair bridging the gap (longer
// than 1.5 stride frame periods) is left out. Stride 2 is the time-offset stage's retry on noisy
// corners.
TEST(RatesFromBoardViews, StrideSpansSeveralFramePeriods) {
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -1.0, 0.4).normalized();
  const auto theta = [](double t) { return 0.3 * t + 0.2 * t * t; };
  std::vector<BoardView> views;
  for (int k = 0; k <= 40; ++k) {
    if (k == 10)
      continue;
    BoardView v;
    v.t_ns = 50000000LL * k;
    const double t = Seconds(v.t_ns);
    // T_C_W's rotation is R_W_C^T with R_W_C = Exp(theta axis).
    v.T_C_W = Eigen::Isometry3d(ExpSO3<double>(Eigen::Vector3d(theta(t) * axis)).inverse());
    views.push_back(v);
  }
  for (const int stride : {1, 2, 4}) {
    const std::vector<RateSample> rates = RatesFromBoardViews(views, stride);
    // Pairs k - stride, k of the 40 views; the gap makes a pair containing it stride + 1 periods
    // long, over 1.5 stride periods for stride 1 only (2 > 1.5; 3, 5 are within 3, 6).
    const std::size_t bridging = stride == 1 ? 1 : 0;
    ASSERT_EQ(rates.size(), views.size() - static_cast<std::size_t>(stride) - bridging) << stride;
    for (const RateSample& r : rates) {
      const double t0 = Seconds(r.t_ns) - 0.5 * r.span, t1 = Seconds(r.t_ns) + 0.5 * r.span;
      EXPECT_LE(r.span, 1.5 * stride * 0.05 + 1e-12);
      EXPECT_GE(r.span, stride * 0.05 - 1e-12);
      EXPECT_NEAR((r.w_S - (theta(t1) - theta(t0)) / r.span * axis).norm(), 0.0, 1e-9)
          << "stride " << stride << " at " << r.t_ns;
    }
  }
}

}  // namespace
}  // namespace ctcal
