// Cross-validation inside the calibration (calibrator/cross_validation.h) on simulated recordings
// of the default rig: without model error the reported sigma stays the formal one (within 10 %)
// and still covers the truth; with a model error the stated noise does not contain (every frame's
// corners shifted together, as a frame-time jitter on a moving camera does) the formal sigma
// fails against the truth and the reported one covers it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <string>

#include "../simulated_recording.h"
#include "ctcal/calibrator/cross_validation.h"
#include "ctcal/sensors/compare.h"

namespace ctcal {
namespace {

using test::Quiet;

struct Outcome {
  RigConfig formal;    // the full calibration as solved
  RigConfig reported;  // with the model error of the cross-validation
  CalibrationCrossValidation xv;
};

Outcome CalibrateAndCrossValidate(const SimulatedRecording& rec) {
  SplineCalibratorOptions options;
  options.threads = 2;
  options.report_data = false;
  CrossValidationOptions xv_options;
  const SubsetSplit split = SplitIntoSubsets(rec.guess, rec.data, xv_options, options.min_views);
  EXPECT_EQ(split.why_not, "");
  Outcome o;
  o.formal = CalibrateSpline(rec.guess, rec.data, options, Quiet()).result;
  o.xv = CrossValidateSubsets(o.formal, split, options, Quiet());
  EXPECT_TRUE(o.xv.ran) << o.xv.why_not;
  o.reported = o.formal;
  ApplyModelError(o.xv.versus_full, &o.reported);
  std::printf("%s", FormatCalibrationCrossValidation(o.xv).c_str());
  return o;
}

struct Coverage {
  double within_3 = 0.0;  // fraction of |error / sigma| <= 3
  double rms = 0.0;       // rms of error / sigma
};

Coverage CoverageOf(const RigConfig& truth, const RigConfig& result) {
  const Comparison c = CompareRigs(truth, result);
  double sum = 0.0;
  int n = 0, within = 0;
  for (const ComparisonRow& row : c.rows) {
    if (!row.error_over_sigma || row.name.rfind("gravity_W", 0) == 0)
      continue;
    sum += *row.error_over_sigma * *row.error_over_sigma;
    within += std::abs(*row.error_over_sigma) <= 3.0;
    ++n;
  }
  return {static_cast<double>(within) / n, std::sqrt(sum / n)};
}

TEST(CrossValidation, WithoutModelErrorTheSigmaStaysFormal) {
  const SimulatedRecording rec = SimulateTable4(sim::Scenario::kFull, 24.0, 7);
  const Outcome o = CalibrateAndCrossValidate(rec);
  double worst = 1.0;
  for (const SensorConfig& s : o.reported.sensors) {
    const SensorConfig& f = *o.formal.Find(s.name);
    for (const auto& [key, sigma] : s.sigma.values) {
      for (std::size_t i = 0; i < sigma.size(); ++i) {
        if (std::isfinite(sigma[i]))
          worst = std::max(worst, sigma[i] / f.sigma.values.at(key)[i]);
      }
    }
  }
  EXPECT_TRUE(o.xv.versus_full.summary.rig_passed);
  EXPECT_LE(worst, 1.10) << "reported sigma / formal";
  const Coverage c = CoverageOf(rec.truth, o.reported);
  std::printf("no model error: reported / formal <= %.3f, %.1f %% within 3 sigma, rms %.2f\n",
              worst, 100.0 * c.within_3, c.rms);
  // Wave 1's accuracy checks on the reported sigma.
  EXPECT_GE(c.within_3, 0.97);
  EXPECT_GE(c.rms, 0.75);
}

// (Before the rig's test, only the groups failing their own Bonferroni-limited test were widened:
// 92.6 % within 3 sigma. A 1-dof group such as a time offset needs r > 11.6 for that.)
TEST(CrossValidation, ModelErrorFailsTheFormalSigmaAndTheReportedOneCoversIt) {
  SimulatedRecording rec = SimulateTable4(sim::Scenario::kFull, 24.0, 7);
  // Every frame's corners moved by one shift ~ N(0, 0.5 px) per axis: what a frame stamped a few
  // ms off does on a camera moving at ~100 px/s. The stated 1 px per corner is independent
  // noise, so the formal sigma cannot contain it.
  std::mt19937_64 rng(99);
  std::normal_distribution<double> shift(0.0, 0.5);
  for (auto& [name, d] : rec.data) {
    std::int64_t frame = -1;
    double du = 0.0, dv = 0.0;
    for (CornerObservation& c : d.corners) {
      if (c.t_ns != frame) {
        frame = c.t_ns;
        du = shift(rng);
        dv = shift(rng);
      }
      c.u += du;
      c.v += dv;
    }
  }
  const Outcome o = CalibrateAndCrossValidate(rec);
  const Coverage formal = CoverageOf(rec.truth, o.formal);
  const Coverage reported = CoverageOf(rec.truth, o.reported);
  std::printf("model error: formal %.1f %% within 3 sigma, rms %.2f; reported %.1f %%, rms %.2f\n",
              100.0 * formal.within_3, formal.rms, 100.0 * reported.within_3, reported.rms);
  EXPECT_FALSE(o.xv.versus_full.summary.passed);
  EXPECT_FALSE(o.xv.versus_full.summary.rig_passed);
  // Every group gets its own model error once the rig fails, also one that passed alone.
  int widened_passing = 0;
  for (const CrossValGroup& g : o.xv.versus_full.groups)
    widened_passing += g.passed && g.model_ratio > 0.0;
  EXPECT_GT(widened_passing, 0);
  EXPECT_LT(formal.within_3, 0.9);
  EXPECT_GE(reported.within_3, 0.97);
  EXPECT_LE(reported.rms, 1.5);
}

}  // namespace
}  // namespace ctcal
