// The visual-inertial (spline) calibrator with an mrcal lens: the default rig with cam0's lens a
// rational OPENCV8 (camera_model mrcal), simulated and calibrated from table4 guesses, recovers
// every estimated parameter within 4 sigma; the discrete method refuses the lens by name.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "ctcal/calibrator/discrete_calibrator.h"
#include "ctcal/calibrator/spline_calibrator.h"
#include "ctcal/sensors/camera_model.h"
#include "ctcal/sensors/compare.h"
#include "ctcal/sensors/mrcal_lens.h"
#include "ctcal/sensors/projection_diff.h"
#include "simulated_recording.h"

namespace ctcal {
namespace {

using test::Quiet;

SimulatedRecording SimulateMrcalRig(double duration, std::uint64_t seed) {
  RigConfig rig = sim::DefaultRig();
  SensorConfig& cam0 = *rig.Find("cam0");
  cam0.camera_model = "mrcal";
  cam0.distortion_model = "LENSMODEL_OPENCV8";
  cam0.intrinsics = {458.654, 457.296, 367.215, 248.375, -0.2834, 0.07396,
                     1.9e-4,  1.8e-5,  0.01,    0.02,    -0.03,   0.015};
  cam0.distortion_coeffs.clear();
  return SimulateTable4(sim::Scenario::kFull, duration, seed, rig);
}

// (Before the visual-inertial problem had mrcal's regularisation, fx, fy, k1, k2 and k3..k6 came
// out undetermined, sigma inf: the rational model's numerator, denominator and focal length trade
// against each other.)
TEST(SplineCalibratorMrcal, Opencv8CameraRecoveredWithinFourSigma) {
  const SimulatedRecording rec = SimulateMrcalRig(8.0, 11);
  ASSERT_EQ(rec.guess.Find("cam0")->camera_model, "mrcal");
  SplineCalibratorOptions options;
  options.threads = 2;
  options.report_data = false;
  const SplineCalibrationResult r = CalibrateSpline(rec.guess, rec.data, options, Quiet());
  const Comparison c = CompareRigs(rec.truth, r.result);
  int cam0_rows = 0;
  for (const ComparisonRow& row : c.rows) {
    if (row.name.rfind("cam0.", 0) == 0)
      ++cam0_rows;
    if (row.name.rfind("cam0.intrinsics", 0) == 0)
      std::printf("%s: %.6f truth %.6f sigma %.6f\n", row.name.c_str(), row.estimate, row.truth,
                  row.sigma.value_or(NAN));
    if (!row.error_over_sigma.has_value())
      continue;
    EXPECT_LT(std::abs(*row.error_over_sigma), 4.0)
        << row.name << ": error " << row.error << ", sigma " << *row.sigma;
  }
  // 12 intrinsics, R_B_S and t_B_S (3 + 3), time_offset.
  EXPECT_EQ(cam0_rows, 12 + 6 + 1);
  for (const ComparisonRow& row : c.rows) {
    if (row.name.rfind("cam0.intrinsics", 0) == 0) {
      EXPECT_TRUE(row.error_over_sigma.has_value()) << row.name << " undetermined";
    }
  }
  EXPECT_NEAR(*r.result.residuals.at("cam0").rms_whitened, 1.0, 0.1);
}

// A splined stereographic lens in the visual-inertial problem: the rig's OPENCV8 cam0 fitted by
// a splined model that starts from the lens's focal length and centre with zero control points.
// The fit reaches the noise and reproduces the true lens over the observed part of the image (mean
// projection difference below a fifth of the 1 px corner noise), and cam0's extrinsics and time
// offset are recovered within 4 sigma.
TEST(SplineCalibratorMrcal, SplinedLensInTheVisualInertialProblem) {
  SimulatedRecording rec = SimulateMrcalRig(4.0, 12);
  const std::string spline = "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=12_Ny=9_fov_x_deg=120";
  SensorConfig& cam0 = *rec.guess.Find("cam0");
  const int n = MrcalLens::FromName(spline)->NumParams();
  std::vector<double> start(static_cast<std::size_t>(n), 0.0);
  std::copy(cam0.intrinsics.begin(), cam0.intrinsics.begin() + 4, start.begin());
  cam0.distortion_model = spline;
  cam0.intrinsics = start;
  cam0.prior_sigma.values.erase("intrinsics");  // the OPENCV8 guess's 12 prior sigmas
  SplineCalibratorOptions options;
  options.threads = 2;
  options.report_data = false;
  const SplineCalibrationResult r = CalibrateSpline(rec.guess, rec.data, options, Quiet());
  const SensorConfig& est = *r.result.Find("cam0");
  ASSERT_EQ(est.distortion_model, spline);
  EXPECT_NEAR(*r.result.residuals.at("cam0").rms_whitened, 1.0, 0.1);
  std::vector<Eigen::Vector2d> observed;
  for (const CornerObservation& c : rec.data.at("cam0").corners)
    observed.emplace_back(c.u, c.v);
  ProjectionDiffOptions diff_options;
  diff_options.observed = observed;
  const auto camera = [](const SensorConfig& s) {
    return CameraModel::Create(s.camera_model, s.intrinsics, s.distortion_model,
                               s.distortion_coeffs, Eigen::Vector2i(s.width, s.height));
  };
  const ProjectionDiff d =
      DiffProjections(camera(*rec.truth.Find("cam0")), camera(est), diff_options);
  std::printf("splined fit vs the true OPENCV8: mean %.4f px, max %.4f px over %d grid points\n",
              d.mean_px, d.max_px, d.points);
  // The corners have 1 px noise: on average the fit is within a fifth of it.
  EXPECT_LT(d.mean_px, 0.2);
  // The poses against the truth (its lens given the fit's parameters: only the models differ).
  RigConfig truth = rec.truth;
  SensorConfig& true_cam0 = *truth.Find("cam0");
  true_cam0.distortion_model = est.distortion_model;
  true_cam0.intrinsics = est.intrinsics;
  const Comparison c = CompareRigs(truth, r.result);
  for (const ComparisonRow& row : c.rows) {
    const bool pose = row.name.rfind("cam0.R_B_S", 0) == 0 ||
                      row.name.rfind("cam0.t_B_S", 0) == 0 || row.name == "cam0.time_offset";
    if (!pose)
      continue;
    ASSERT_TRUE(row.error_over_sigma.has_value()) << row.name;
    EXPECT_LT(std::abs(*row.error_over_sigma), 4.0) << row.name;
  }
}

TEST(SplineCalibratorMrcal, DiscreteMethodRefusesTheLensByName) {
  const SimulatedRecording rec = SimulateMrcalRig(2.0, 3);
  DiscreteCalibratorOptions options;
  try {
    CalibrateDiscrete(rec.guess, rec.data, options, Quiet());
    FAIL() << "expected an error";
  } catch (const std::exception& e) {
    EXPECT_STREQ(e.what(), "sensors.cam0: camera_model mrcal runs with --method spline only");
  }
}

}  // namespace
}  // namespace ctcal
