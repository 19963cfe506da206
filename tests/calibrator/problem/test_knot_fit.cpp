// The knot spacing by fit (knot_fit.h): slow motion under white noise takes a coarse spacing (the
// inertial residuals keep their redundancy), a recording with a fast segment a finer one that
// still fits it, and the choice is the coarsest candidate within the tolerance.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "ctcal/calibrator/knot_fit.h"

namespace ctcal {
namespace {

struct Signals {
  std::vector<std::int64_t> t_ns;
  std::vector<Eigen::Vector3d> gyro, accel;
};

// 20 s at 200 Hz: a 0.5 Hz motion everywhere, plus `fast_hz` in [fast_from, fast_to] s; white
// noise of 0.002 rad/s and 0.03 m/s^2 (EuRoC's ADIS16448 at 200 Hz).
Signals Make(double fast_hz, double fast_from, double fast_to, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss;
  Signals s;
  for (int i = 0; i < 4000; ++i) {
    const double t = i / 200.0;
    s.t_ns.push_back(1000000000LL + 5000000LL * i);
    Eigen::Vector3d w, a;
    for (int k = 0; k < 3; ++k) {
      double slow = std::sin(2 * M_PI * 0.5 * t + k);
      // Faded in and out over 1 s (raised cosine): a step would be a misfit at every spacing.
      const double in = std::clamp(t - fast_from, 0.0, 1.0),
                   out = std::clamp(fast_to - t, 0.0, 1.0);
      const double envelope = 0.25 * (1.0 - std::cos(M_PI * in)) * (1.0 - std::cos(M_PI * out));
      slow += 0.5 * envelope * std::sin(2 * M_PI * fast_hz * t + 2 * k);
      w(k) = slow + 0.002 * gauss(rng);
      a(k) = 3.0 * slow + 9.81 * (k == 2) + 0.03 * gauss(rng);
    }
    s.gyro.push_back(w);
    s.accel.push_back(a);
  }
  return s;
}

void ExpectCoarsestWithinTolerance(const KnotFitChoice& c, const KnotFitOptions& o) {
  ASSERT_FALSE(c.candidates.empty());
  for (std::size_t j = 0; j < c.candidates.size(); ++j) {
    if (c.candidates[j].spacing_s <= c.knot_spacing_s + 1e-12) {
      EXPECT_LE(c.candidates[j].share_excess, o.misfit_tolerance) << c.candidates[j].spacing_s;
    } else {
      // The first candidate past the choice fails (the search stops there).
      EXPECT_GT(c.candidates[j].share_excess, o.misfit_tolerance) << c.candidates[j].spacing_s;
      break;
    }
  }
}

TEST(KnotFit, SlowMotionTakesACoarseSpacing) {
  const Signals s = Make(0.0, 0.0, 0.0, 1);
  const KnotFitOptions o;
  const KnotFitChoice c = ChooseKnotSpacingByFit(s.t_ns, s.gyro, s.accel, o);
  ExpectCoarsestWithinTolerance(c, o);
  // A 0.5 Hz sine is fitted to the noise far beyond 10 samples per knot.
  EXPECT_GE(c.knot_spacing_s, 0.05);
}

TEST(KnotFit, AFastSegmentRefinesTheSpacingUntilItFits) {
  const KnotFitOptions o;
  const Signals slow = Make(0.0, 0.0, 0.0, 2);
  // 2 Hz during 8 of the 20 s (4 of the 10 windows: more than the quarter the rule may leave out).
  const Signals fast = Make(2.0, 4.0, 12.0, 2);
  const KnotFitChoice cs = ChooseKnotSpacingByFit(slow.t_ns, slow.gyro, slow.accel, o);
  const KnotFitChoice cf = ChooseKnotSpacingByFit(fast.t_ns, fast.gyro, fast.accel, o);
  ExpectCoarsestWithinTolerance(cf, o);
  EXPECT_LT(cf.knot_spacing_s, 0.6 * cs.knot_spacing_s);
  // Still several samples per knot: the inertial residuals keep redundancy.
  EXPECT_GE(cf.knot_spacing_s, 0.01);
}

TEST(KnotFit, ABriefFastSegmentDoesNotSetTheSpacingAlone) {
  // 2 Hz during 2 of the 20 s: one window, left to the noise estimation's per-window weights.
  const KnotFitOptions o;
  const Signals slow = Make(0.0, 0.0, 0.0, 3);
  const Signals brief = Make(2.0, 8.0, 10.0, 3);
  const KnotFitChoice cs = ChooseKnotSpacingByFit(slow.t_ns, slow.gyro, slow.accel, o);
  const KnotFitChoice cb = ChooseKnotSpacingByFit(brief.t_ns, brief.gyro, brief.accel, o);
  EXPECT_NEAR(cb.knot_spacing_s, cs.knot_spacing_s, 0.2 * cs.knot_spacing_s);
}

TEST(KnotFit, BadInputIsRefused) {
  const Signals s = Make(0.0, 0.0, 0.0, 4);
  std::vector<Eigen::Vector3d> short_accel(s.accel.begin(), s.accel.begin() + 10);
  EXPECT_THROW(ChooseKnotSpacingByFit(s.t_ns, s.gyro, short_accel), std::invalid_argument);
  KnotFitOptions o;
  o.order = 2;
  EXPECT_THROW(ChooseKnotSpacingByFit(s.t_ns, s.gyro, s.accel, o), std::invalid_argument);
}

}  // namespace
}  // namespace ctcal
