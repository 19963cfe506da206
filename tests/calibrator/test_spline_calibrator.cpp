// End to end: the continuous-time calibrator on a short simulated recording of the default rig
// (full scenario, table4 guesses) must recover every estimated parameter within 4 sigma with small
// sigmas (the shape of basalt's test_spline_opt), and bad input must stop with one message naming
// the sensor.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "ctcal/calibrator/spline_calibrator.h"
#include "ctcal/sensors/compare.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig_yaml.h"
#include "estimate_agreement.h"
#include "simulated_recording.h"

namespace ctcal {
namespace {

using test::InputErrorOf;
using test::Quiet;

// The full scenario of the default rig with table4 guesses, simulated once per process.
std::string SimulatedData(int seed, double duration) {
  return test::SimulateOnce(
      "ctcal_spline_" + std::to_string(seed) + "_" + std::to_string(static_cast<int>(duration)),
      test::FullTable4Args(seed, duration));
}

TEST(SplineCalibrator, RecoversEveryParameterWithinFourSigma) {
  const test::Recording l = test::LoadRecording(SimulatedData(11, 12.0));
  SplineCalibratorOptions options;
  options.threads = 2;
  const SplineCalibrationResult r = CalibrateSpline(l.rig, l.data, options, Quiet());

  const Comparison c = CompareRigs(l.truth, r.result);
  // imu0 Dw 6 + Da 6 + Tg 9 + R_I_a 3; imu1 the same + R_B_S, t_B_S, time_offset; gyro0 Dw 6 +
  // R_B_S + time_offset; two cameras 8 intrinsics + 7 extrinsics/offset each; gravity 3.
  ASSERT_EQ(c.summary.count, 24 + 31 + 10 + 15 + 15 + 3);
  // In 12 s the board never reaches the outer field of cam1's wide equidistant lens (fu ~ 190 px
  // on 512 px), so its high-order Kannala-Brandt terms k2..k4 are nearly collinear and fall under
  // the null-eigenvalue rule (1e-9 of the largest, docs/calibrator.md). Nothing else may.
  const auto may_be_undetermined = [](const std::string& name) {
    return name.rfind("cam1.distortion_coeffs[", 0) == 0 && name != "cam1.distortion_coeffs[0]";
  };
  int undetermined = 0;
  for (const ComparisonRow& row : c.rows) {
    if (!row.error_over_sigma.has_value()) {
      ++undetermined;
      EXPECT_TRUE(may_be_undetermined(row.name)) << row.name << " has no finite sigma";
    }
  }
  EXPECT_LE(undetermined, 3);
  EXPECT_EQ(c.summary.no_sigma, 0);
  for (const ComparisonRow& row : c.rows) {
    if (!row.error_over_sigma.has_value())
      continue;  // checked above
    EXPECT_LT(std::abs(*row.error_over_sigma), 4.0)
        << row.name << ": error " << row.error << ", sigma " << *row.sigma;
    // Sensible sigmas for 12 s of the default rig: rotations < 0.05 deg, translations < 2 mm,
    // time offsets < 0.3 ms, focal lengths < 1 px.
    const std::string& n = row.name;
    const double s = *row.sigma;
    EXPECT_GT(s, 0.0) << n;
    if (row.rotation && n.find("R_B_S") != std::string::npos) {
      EXPECT_LT(s * 180.0 / M_PI, 0.05) << n;
    }
    if (n.find("t_B_S") != std::string::npos) {
      EXPECT_LT(s, 2e-3) << n;
    }
    if (n.find("time_offset") != std::string::npos) {
      EXPECT_LT(s, 3e-4) << n;
    }
    if (n.find("intrinsics[0]") != std::string::npos) {
      EXPECT_LT(s, 1.0) << n;
    }
  }
  // Whitened residuals of a consistent fit are ~N(0, 1).
  for (const auto& [name, res] : r.result.residuals) {
    ASSERT_TRUE(res.rms_whitened.has_value()) << name;
    EXPECT_NEAR(*res.rms_whitened, 1.0, 0.1) << name;
  }
  // The statistics' corner residuals (the pose evaluated once per frame, spline_problem_solve.h
  // EvaluateCameraCorners) against the report data's (the trajectory evaluated for each corner and
  // the camera's own projection, report_data_builder.cpp): the same inliers, the same RMS.
  ASSERT_EQ(r.report_data.corners.size(), 2u);
  for (const auto& [name, rows] : r.report_data.corners) {
    double sum = 0.0;
    std::int64_t inliers = 0;
    for (const report::CornerResidual& row : rows) {
      if (row.outlier || !std::isfinite(row.whitened))
        continue;
      sum += row.whitened * row.whitened;
      ++inliers;
    }
    const SensorResiduals& res = r.result.residuals.at(name);
    EXPECT_EQ(res.count, 2 * inliers) << name;
    EXPECT_NEAR(*res.rms_whitened, std::sqrt(sum / static_cast<double>(2 * inliers)),
                1e-9 * *res.rms_whitened)
        << name;
  }
  ASSERT_TRUE(r.result.solver.has_value());
  EXPECT_EQ(r.result.solver->method, "spline");
  EXPECT_GT(r.iterations, 0);
  // The simulator's corners carry no outliers: the 99.9 % gate removes about 0.1 %.
  for (const CameraOutliers& o : r.outliers)
    EXPECT_LT(o.removed, o.corners / 200) << o.camera;
}

// The 12 s recording (seed 11) calibrated with the default options (`fast`) and with `change`
// applied to them (`ref`): the pairs the tests below compare.
struct FastAndReference {
  SplineCalibrationResult fast, ref;
};
template <class Change>
FastAndReference CalibrateFastAndReference(Change&& change) {
  const test::Recording l = test::LoadRecording(SimulatedData(11, 12.0));
  SplineCalibratorOptions options;
  options.threads = 2;
  options.report_data = false;
  SplineCalibratorOptions reference = options;
  change(&reference);
  return {CalibrateSpline(l.rig, l.data, options, Quiet()),
          CalibrateSpline(l.rig, l.data, reference, Quiet())};
}

// Both runs gated out the same corners of every camera in the same rounds.
void ExpectSameOutliers(const SplineCalibrationResult& a, const SplineCalibrationResult& b) {
  ASSERT_EQ(a.outliers.size(), b.outliers.size());
  for (std::size_t i = 0; i < b.outliers.size(); ++i) {
    EXPECT_EQ(a.outliers[i].corners, b.outliers[i].corners) << b.outliers[i].camera;
    EXPECT_EQ(a.outliers[i].removed, b.outliers[i].removed) << b.outliers[i].camera;
  }
}

// The stop criterion of the plain solves (SplineCalibratorOptions::stop_cost_change) bounds every
// estimate's distance to the fully converged one by sqrt(2 * 0.005) = 0.1 of its sigma; the run
// without it (Ceres' relative tolerances of 1e-10 only) is the reference.
TEST(SplineCalibrator, StopCriterionStaysWithinATenthSigmaOfTheConvergedEstimate) {
  const auto [fast, ref] =
      CalibrateFastAndReference([](SplineCalibratorOptions* o) { o->stop_cost_change = 0.0; });
  EXPECT_LE(fast.iterations, ref.iterations);
  // error = fast - reference, sigma = fast's; cam1's undetermined k2..k4 have none (see above).
  ASSERT_EQ(CompareRigs(ref.result, fast.result).summary.count, 98);
  const Agreement a = ExpectAgreement(ref.result, fast.result, 0.1);
  EXPECT_GE(a.compared, 95);
  std::printf("stop criterion: %d vs %d iterations, worst |fast - converged| %.4f sigma\n",
              fast.iterations, ref.iterations, a.worst);
}

// docs/performance.md step 7b's speed-ups (stacked inertial blocks at the 200-300 Hz rates, the
// robust solve's predicted stop) against the pipeline without them: the same corners gated out
// and every estimate within 0.01 sigma (the stacked blocks hold the per-sample rows to the bit;
// the robust solve ends at the point Ceres' function tolerance would have kept).
TEST(SplineCalibrator, SpeedUpsKeepTheOutliersAndTheEstimates) {
  const auto [fast, ref] = CalibrateFastAndReference([](SplineCalibratorOptions* o) {
    o->stacked_inertial_segments = 0;
    o->robust_early_stop = false;
  });
  ExpectSameOutliers(fast, ref);
  EXPECT_LE(fast.iterations, ref.iterations);
  const Agreement a = ExpectAgreement(ref.result, fast.result, 0.01);
  EXPECT_GE(a.compared, 95);
  std::printf("speed-ups: %d vs %d iterations, worst |fast - before| %.2e sigma\n", fast.iterations,
              ref.iterations, a.worst);
}

// Our Levenberg-Marquardt (lm_solver.h; docs/performance.md step 7f) against ceres::Solve: the
// same steps, so the same corners gated out, the same iterations, every estimate within 0.01
// sigma (rounding: the sums run in another order), and the covariance from the last solve's
// normal equations equal to the one from a fresh pass over the Jacobian (1e-6 relative).
TEST(SplineCalibrator, OwnSolverMatchesCeres) {
  const auto [own, ceres_run] =
      CalibrateFastAndReference([](SplineCalibratorOptions* o) { o->lm_solver = false; });
  ExpectSameOutliers(own, ceres_run);
  EXPECT_EQ(own.iterations, ceres_run.iterations);
  const Agreement a = ExpectAgreement(ceres_run.result, own.result, 0.01);
  EXPECT_GE(a.compared, 95);
  ASSERT_EQ(own.covariance.rows(), ceres_run.covariance.rows());
  ASSERT_GT(own.covariance.rows(), 0);
  double worst = 0.0;
  for (Eigen::Index i = 0; i < own.covariance.rows(); ++i) {
    const double s_own = std::sqrt(own.covariance(i, i));
    const double s_ref = std::sqrt(ceres_run.covariance(i, i));
    worst = std::max(worst, std::abs(s_own - s_ref) / s_ref);
  }
  EXPECT_LT(worst, 1e-6);
  std::printf("own solver: worst |own - ceres| %.2e sigma, sigma %.2e relative\n", a.worst, worst);
}

// The own Levenberg-Marquardt on the inertial row groups (compressed runs of 3 segments forced
// here, so that the memory rule picks the own solver; inertial_row_groups.h): groups that read
// the knots before their first block from the parameter memory and share one factorisation per
// run and point. The same outliers, iterations and estimates (0.01 sigma) as Ceres' solve.
TEST(SplineCalibrator, OwnSolverMatchesCeresOnInertialRowGroups) {
  const test::Recording l = test::LoadRecording(SimulatedData(11, 12.0));
  SplineCalibratorOptions options;
  options.threads = 2;
  options.report_data = false;
  options.inertial_block_segments = 3;
  int own_solves = 0;
  const SplineCalibrationResult own =
      CalibrateSpline(l.rig, l.data, options, [&](const std::string& line) {
        own_solves += line.find("own Levenberg-Marquardt") != std::string::npos ? 1 : 0;
      });
  ASSERT_GT(own_solves, 0)
      << "the memory rule chose Ceres: this test would not test the own solver";
  options.lm_solver = false;
  const SplineCalibrationResult ceres_run = CalibrateSpline(l.rig, l.data, options, Quiet());
  ExpectSameOutliers(own, ceres_run);
  EXPECT_EQ(own.iterations, ceres_run.iterations);
  const Agreement a = ExpectAgreement(ceres_run.result, own.result, 0.01);
  EXPECT_GE(a.compared, 95);
  std::printf("own solver, inertial row groups: %d own solves, worst |own - ceres| %.2e sigma\n",
              own_solves, a.worst);
}

// The frames split into pose and intrinsic rows (docs/performance.md step 7e; forced here, the
// rule splits long recordings only) against whole frame blocks: the same corners gated out, the
// same iterations and every estimate within 0.01 sigma (the split holds the same rows; only
// Ceres' sums run in another order).
TEST(SplineCalibrator, SplitFrameRowsKeepTheOutliersAndTheEstimates) {
  const auto [whole, split] =
      CalibrateFastAndReference([](SplineCalibratorOptions* o) { o->split_frame_rows = 1; });
  ExpectSameOutliers(split, whole);
  EXPECT_EQ(split.iterations, whole.iterations);
  const Agreement a = ExpectAgreement(whole.result, split.result, 0.01);
  EXPECT_GE(a.compared, 95);
  std::printf("split frame rows: worst |split - whole| %.2e sigma\n", a.worst);
}

// CalibrateSpline taking the data over releases the loaded corners and samples once it has
// selected its own (docs/performance.md, steps 7 and 7e) and computes the very same result as on
// the caller's data, the observability's motion analysis included.
TEST(SplineCalibrator, TakingTheDataOverReleasesTheCornersAndChangesNothing) {
  const test::Recording l = test::LoadRecording(SimulatedData(11, 12.0));
  SplineCalibratorOptions options;
  options.threads = 1;  // bitwise reproducible
  // Ceres' solver: our Levenberg-Marquardt's CHOLMOD solves (ATLAS on CHOLMOD's own buffers) vary
  // in the last bits with the heap's addresses, and this test compares the data handling to the
  // bit (OwnSolverMatchesCeres compares the solvers).
  options.lm_solver = false;
  const SplineCalibrationResult kept = CalibrateSpline(l.rig, l.data, options, Quiet());
  std::map<std::string, SensorData> data = l.data;
  const SplineCalibrationResult taken = CalibrateSpline(l.rig, std::move(data), options, Quiet());
  for (const char* camera : {"cam0", "cam1"}) {
    EXPECT_FALSE(l.data.at(camera).corners.empty());
    EXPECT_TRUE(data.at(camera).corners.empty()) << camera;
  }
  for (const char* imu : {"imu0", "imu1"}) {
    EXPECT_FALSE(l.data.at(imu).imu.empty());
    EXPECT_TRUE(data.at(imu).imu.empty()) << imu;
  }
  EXPECT_TRUE(data.at("gyro0").gyro.empty());
  // The motion half of the observability, analysed before the samples went (this well excited
  // recording has no degenerate primitive; test_observability_calibration.cpp has those).
  ASSERT_TRUE(kept.result.observability && taken.result.observability);
  EXPECT_EQ(kept.result.observability->motion.size(), taken.result.observability->motion.size());
  EXPECT_EQ(kept.result.observability->predicted_unobservable,
            taken.result.observability->predicted_unobservable);
  ASSERT_TRUE(kept.result.solver && taken.result.solver);
  EXPECT_EQ(kept.result.solver->final_cost, taken.result.solver->final_cost);
  EXPECT_EQ(kept.iterations, taken.iterations);
  // The covariance to rounding: CHOLMOD's and Eigen's vectorised sums depend on where the heap
  // put their buffers, so the last bits may differ between any two runs.
  ASSERT_EQ(kept.covariance.rows(), taken.covariance.rows());
  EXPECT_LT((kept.covariance - taken.covariance).norm(), 1e-9 * kept.covariance.norm());
  const Comparison c = CompareRigs(kept.result, taken.result);
  EXPECT_GE(c.summary.count, 95);
  for (const ComparisonRow& row : c.rows)
    EXPECT_EQ(row.error, 0.0) << row.name;
}

TEST(SplineCalibrator, CameraThatNeverSeesTheBoardIsNamed) {
  test::Recording l = test::LoadRecording(SimulatedData(12, 4.0));
  l.data["cam1"].corners.clear();
  const std::string what = InputErrorOf([&] { CalibrateSpline(l.rig, l.data, {}, Quiet()); });
  EXPECT_NE(what.find("sensors.cam1"), std::string::npos) << what;
  EXPECT_NE(what.find("never sees the board"), std::string::npos) << what;
}

TEST(SplineCalibrator, TooFewViewsAreNamed) {
  test::Recording l = test::LoadRecording(SimulatedData(12, 4.0));
  auto& corners = l.data["cam0"].corners;
  // Keep the corners of the first 5 frames only.
  std::size_t end = 0;
  int frames = 0;
  while (end < corners.size() && frames < 5) {
    const std::int64_t t = corners[end].t_ns;
    while (end < corners.size() && corners[end].t_ns == t)
      ++end;
    ++frames;
  }
  corners.resize(end);
  const std::string what = InputErrorOf([&] { CalibrateSpline(l.rig, l.data, {}, Quiet()); });
  EXPECT_NE(what.find("sensors.cam0"), std::string::npos) << what;
  EXPECT_NE(what.find("too few views"), std::string::npos) << what;
}

TEST(SplineCalibrator, NonOverlappingTimeRangesAreNamed) {
  test::Recording l = test::LoadRecording(SimulatedData(12, 4.0));
  for (ImuSample& s : l.data["imu1"].imu)
    s.t_ns += 1000000000000LL;  // 1000 s later
  const std::string what = InputErrorOf([&] { CalibrateSpline(l.rig, l.data, {}, Quiet()); });
  EXPECT_NE(what.find("sensors.imu1"), std::string::npos) << what;
  EXPECT_NE(what.find("do not overlap"), std::string::npos) << what;
}

// Options no calibration can run with are one CalibrationInputError naming the option, before
// any work: a bias knot spacing of 0 divided by zero when the bias splines were laid out (SIGFPE).
TEST(SplineCalibrator, OptionsItCannotRunWithAreNamed) {
  test::Recording l = test::LoadRecording(SimulatedData(12, 4.0));
  const std::pair<std::function<void(SplineCalibratorOptions*)>, const char*> cases[] = {
      {[](SplineCalibratorOptions* o) { o->bias_knot_spacing_s = 0.0; }, "--bias-knot-spacing"},
      {[](SplineCalibratorOptions* o) { o->bias_knot_spacing_s = 1e-12; }, "--bias-knot-spacing"},
      {[](SplineCalibratorOptions* o) { o->knot_spacing_s = -0.05; }, "--knot-spacing"},
      {[](SplineCalibratorOptions* o) { o->knot_spacing_s = 1e-6; }, "--knot-spacing"},
      {[](SplineCalibratorOptions* o) { o->knot_spacing_s = std::nan(""); }, "--knot-spacing"},
      {[](SplineCalibratorOptions* o) { o->max_iterations = -1; }, "--max-iterations"},
      {[](SplineCalibratorOptions* o) { o->order = 7; }, "order must be 4, 5 or 6"}};
  for (const auto& [breaks, says] : cases) {
    SplineCalibratorOptions options;
    breaks(&options);
    std::vector<std::string> lines;
    const std::string what = InputErrorOf([&] {
      CalibrateSpline(l.rig, l.data, options, [&](const std::string& s) { lines.push_back(s); });
    });
    EXPECT_NE(what.find(says), std::string::npos) << what;
    EXPECT_TRUE(lines.empty()) << says << ": logged " << lines.front();
  }
}

// A stated noise so small that the whitened cost overflows: the solve must stop with one
// CalibrationFailure saying it diverged (the iteration callback aborts on a non-finite cost) and
// naming the sensor whose residuals overflow, never a crash, a hang or a result.
TEST(SplineCalibrator, DivergingSolveFailsWithOneMessage) {
  test::Recording l = test::LoadRecording(SimulatedData(12, 4.0));
  l.rig.Find(l.rig.base_imu)->noise.gyroscope_noise_density = 1e-200;
  SplineCalibratorOptions options;
  options.coarse_init.policy = GuessPolicy::kOff;
  std::string what;
  try {
    CalibrateSpline(l.rig, l.data, options, Quiet());
  } catch (const CalibrationFailure& e) {
    what = e.what();
  }
  EXPECT_NE(what.find("diverged"), std::string::npos) << what;
  EXPECT_NE(what.find("sensors." + l.rig.base_imu), std::string::npos) << what;
}

TEST(SplineCalibrator, CliWritesResultAndKalibrFiles) {
  const std::string data = SimulatedData(12, 4.0);
  const std::string out = ::testing::TempDir() + "/ctcal_spline_cli_out";
  std::filesystem::remove_all(out);
  const std::string cmd = std::string(CTCAL_BINARY) + " calibrate --rig " + data +
                          "/rig.yaml --data " + data + " --out " + out +
                          " --threads 2 --knot-spacing 0.05 > /dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  for (const char* f : {"result.yaml", "camchain-imucam.yaml", "imu.yaml", "log.txt"})
    EXPECT_TRUE(std::filesystem::exists(out + "/" + f)) << f;
  std::vector<std::string> warnings;
  const RigConfig result = LoadRig(out + "/result.yaml", &warnings);
  ASSERT_TRUE(result.solver.has_value());
  EXPECT_TRUE(result.gravity_W.has_value());
  EXPECT_TRUE(result.sigma_gravity_W.has_value());
  EXPECT_FALSE(result.Find("cam0")->sigma.empty());

  // Bad usage: one line, exit code 2.
  const std::string bad = std::string(CTCAL_BINARY) + " calibrate --rig /nonexistent.yaml --data " +
                          data + " --out " + out + " 2> /dev/null";
  EXPECT_EQ(WEXITSTATUS(std::system(bad.c_str())), 2);
}

}  // namespace
}  // namespace ctcal
