// The camera-only calibrator with mrcal lens models (camera_model mrcal): a simulated camera with
// a rational OPENCV8 lens recovered within its sigma, a splined model fitted to the same lens,
// and the lens-fit diagnosis on EuRoC's real imu_april corners (radtan vs a splined lens).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>
#include <sstream>

#include "ctcal/calibrator/camera_only/camera_only_calibrator.h"
#include "ctcal/report/lens_fit.h"
#include "ctcal/sensors/camera_model.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/mrcal_lens.h"
#include "ctcal/sensors/projection_diff.h"
#include "ctcal/sensors/rig_yaml.h"
#include "ctcal/sim/dataset_writer.h"
#include "ctcal/sim/default_rig.h"
#include "ctcal/sim/scenario.h"
#include "ctcal/sim/simulator.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;

// EuRoC cam0's radtan lens plus rational and k3 terms: OPENCV8 = k1 k2 p1 p2 k3 k4 k5 k6.
const std::vector<double> kOpencv8 = {458.654, 457.296, 367.215, 248.375, -0.2834, 0.07396,
                                      1.9e-4,  1.8e-5,  0.01,    0.02,    -0.03,   0.015};

// The default rig's cam0 alone, as the base of a camera-only rig, with an mrcal lens.
RigConfig MonoRig(const std::string& lensmodel, const std::vector<double>& intrinsics,
                  double pixel_sigma) {
  const RigConfig rig_in = sim::DefaultRig();
  RigConfig rig = rig_in;
  rig.sensors.clear();
  SensorConfig cam = *rig_in.Find("cam0");
  cam.camera_model = "mrcal";
  cam.distortion_model = lensmodel;
  cam.intrinsics = intrinsics;
  cam.distortion_coeffs.clear();
  cam.T_B_S.setIdentity();
  cam.time_offset = 0.0;
  cam.pixel_sigma = pixel_sigma;
  cam.estimate = {EstimateItem::kIntrinsics};
  rig.sensors.push_back(cam);
  rig.base_imu = "cam0";
  return rig;
}

std::map<std::string, SensorData> Simulate(const RigConfig& truth, double duration) {
  const auto motion = sim::MakeTrajectory(sim::Scenario::kFull, sim::SceneFor(truth.target));
  const sim::RotatedTrajectory traj(*motion, sim::ScenarioMount(truth));
  sim::SimOptions options;
  options.seed = 3;
  options.duration = duration;
  return sim::ToSensorData(sim::Simulate(truth, traj, options));
}

CameraModel CameraOf(const SensorConfig& s) {
  return CameraModel::Create(s.camera_model, s.intrinsics, s.distortion_model, s.distortion_coeffs,
                             Eigen::Vector2i(s.width, s.height));
}

std::vector<Eigen::Vector2d> Pixels(const std::vector<CornerObservation>& corners) {
  std::vector<Eigen::Vector2d> uv;
  for (const CornerObservation& c : corners)
    uv.emplace_back(c.u, c.v);
  return uv;
}

// A rational OPENCV8 lens, projected through mrcal both in the simulator and in the calibrator,
// is recovered within 4 sigma from a guess 1 % off in focal length, 3 px off in the centre and
// with half its distortion. mrcal's regularisation (0.25 % of the cost) biases by at most
// w x / sigma ~ 1 sigma at these values (MrcalLens::MakeRegularization).
TEST(CameraOnlyMrcal, SimulatedOpencv8LensRecoveredWithinSigma) {
  const RigConfig truth = MonoRig("LENSMODEL_OPENCV8", kOpencv8, 1.0);
  const std::map<std::string, SensorData> data = Simulate(truth, 4.0);
  RigConfig guess = truth;
  std::vector<double>& k = guess.Find("cam0")->intrinsics;
  k[0] *= 1.01;
  k[1] *= 1.01;
  k[2] += 3.0;
  k[3] -= 3.0;
  for (std::size_t i = 4; i < k.size(); ++i)
    k[i] *= 0.5;
  std::ostringstream log;
  const CameraOnlyResult result = CalibrateCameraOnly(guess, data, {}, log);
  std::printf("%s", log.str().c_str());
  const SensorConfig& est = *result.rig.Find("cam0");
  EXPECT_EQ(est.distortion_model, "LENSMODEL_OPENCV8");
  const std::vector<double>* sigma = est.sigma.Find("intrinsics");
  ASSERT_TRUE(sigma);
  ASSERT_EQ(sigma->size(), kOpencv8.size());
  for (std::size_t i = 0; i < kOpencv8.size(); ++i) {
    std::printf("intrinsics[%zu]: %.6f truth %.6f sigma %.6f (%+.2f sigma)\n", i, est.intrinsics[i],
                kOpencv8[i], (*sigma)[i], (est.intrinsics[i] - kOpencv8[i]) / (*sigma)[i]);
    EXPECT_NEAR(est.intrinsics[i], kOpencv8[i], 4.0 * (*sigma)[i]) << i;
    EXPECT_TRUE(std::isfinite((*sigma)[i]) && (*sigma)[i] > 0.0) << i;
  }
  EXPECT_NEAR(*result.rig.residuals.at("cam0").rms_whitened, 1.0, 0.05);
}

// A splined stereographic model fitted to the same lens (0.2 px noise) reproduces its projection
// over the observed part of the image: the projection difference to the truth is a small
// fraction of a pixel, and the fit reaches the noise (whitened RMS ~1).
TEST(CameraOnlyMrcal, SplinedModelFitsTheLens) {
  const RigConfig truth = MonoRig("LENSMODEL_OPENCV8", kOpencv8, 0.2);
  const std::map<std::string, SensorData> data = Simulate(truth, 4.0);
  const std::string spline = "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=12_Ny=9_fov_x_deg=120";
  const int n = MrcalLens::FromName(spline)->NumParams();
  std::vector<double> start(static_cast<std::size_t>(n), 0.0);
  std::copy(kOpencv8.begin(), kOpencv8.begin() + 4, start.begin());
  const RigConfig guess = MonoRig(spline, start, 0.2);
  std::ostringstream log;
  const CameraOnlyResult result = CalibrateCameraOnly(guess, data, {}, log);
  std::printf("%s", log.str().c_str());
  const double whitened = *result.rig.residuals.at("cam0").rms_whitened;
  EXPECT_NEAR(whitened, 1.0, 0.05);

  ProjectionDiffOptions options;
  options.observed = Pixels(data.at("cam0").corners);
  const ProjectionDiff d =
      DiffProjections(CameraOf(*truth.Find("cam0")), CameraOf(*result.rig.Find("cam0")), options);
  std::printf("splined fit vs truth: mean %.4f px, max %.4f px over %d observed grid points\n",
              d.mean_px, d.max_px, d.points);
  EXPECT_LT(d.mean_px, 0.1);
  EXPECT_LT(d.max_px, 0.5);
}

// Issue 21's diagnosis on EuRoC's real imu_april corners (cam0, every 6th image: 120 views): a
// pinhole-radtan fit leaves a systematic pattern that grows to the image border; a splined mrcal
// fit removes most of it. The projection difference between the two fits is reported.
TEST(CameraOnlyMrcal, EurocSplinedLensRemovesTheBorderPattern) {
  const fs::path dir = fs::path(CTCAL_SHARED_DATA_DIR) / "euroc_imu_april_first_half";
  if (!fs::exists(dir / "reference_kalibr.yaml"))
    GTEST_SKIP() << "real data absent: " << dir.string();
  const RigConfig reference = LoadRig((dir / "reference_kalibr.yaml").string());
  RigConfig radtan = reference;
  radtan.sensors.clear();
  SensorConfig cam0 = *reference.Find("cam0");
  cam0.T_B_S.setIdentity();
  cam0.time_offset = 0.0;
  cam0.estimate = {EstimateItem::kIntrinsics};
  radtan.sensors.push_back(cam0);
  radtan.base_imu = "cam0";
  std::map<std::string, SensorData> data = LoadDataset(dir.string(), radtan);
  {
    std::set<std::int64_t> frames;
    for (const CornerObservation& c : data.at("cam0").corners)
      frames.insert(c.t_ns);
    std::set<std::int64_t> kept;
    int i = 0;
    for (std::int64_t t : frames)
      if (i++ % 6 == 0)
        kept.insert(t);
    std::vector<CornerObservation> sub;
    for (const CornerObservation& c : data.at("cam0").corners)
      if (kept.count(c.t_ns))
        sub.push_back(c);
    data.at("cam0").corners = sub;
    data.at("cam0").images.clear();
  }

  std::ostringstream log;
  const CameraOnlyResult fit_radtan = CalibrateCameraOnly(radtan, data, {}, log);
  const SensorConfig& r = *fit_radtan.rig.Find("cam0");
  const report::LensFitDiagnosis before =
      report::DiagnoseLensFit(r, fit_radtan.report_data.corners.at("cam0"));

  const std::string spline = report::SuggestedSplinedModel(r);
  const int n = MrcalLens::FromName(spline)->NumParams();
  RigConfig splined = radtan;
  SensorConfig& s = splined.sensors[0];
  s.camera_model = "mrcal";
  s.distortion_model = spline;
  s.intrinsics.assign(static_cast<std::size_t>(n), 0.0);
  std::copy(r.intrinsics.begin(), r.intrinsics.begin() + 4, s.intrinsics.begin());
  s.distortion_coeffs.clear();
  const CameraOnlyResult fit_spline = CalibrateCameraOnly(splined, data, {}, log);
  const SensorConfig& sp = *fit_spline.rig.Find("cam0");
  const report::LensFitDiagnosis after =
      report::DiagnoseLensFit(sp, fit_spline.report_data.corners.at("cam0"));

  ProjectionDiffOptions options;
  options.observed = Pixels(data.at("cam0").corners);
  const ProjectionDiff d = DiffProjections(CameraOf(r), CameraOf(sp), options);
  std::printf(
      "%s\nradtan: RMS %.3f px, lens fit chi2 %.0f / %d (p %.2g), cell means %.3f px border / "
      "%.3f inside, max %.3f\n%s: RMS %.3f px, chi2 %.0f / %d (p %.2g), cell means %.3f px "
      "border / %.3f inside, max %.3f\nprojection difference radtan vs splined over the "
      "observed part: mean %.3f px, max %.3f px (%d grid points), rotation %.4f deg\n",
      log.str().c_str(), *fit_radtan.rig.residuals.at("cam0").rms_px, before.chi2, before.dof,
      before.p_value, before.border_mean_px, before.inner_mean_px, before.max_mean_px,
      spline.c_str(), *fit_spline.rig.residuals.at("cam0").rms_px, after.chi2, after.dof,
      after.p_value, after.border_mean_px, after.inner_mean_px, after.max_mean_px, d.mean_px,
      d.max_px, d.points, d.rotation_deg);
  // radtan leaves a significant pattern, larger at the border than inside, and names a richer
  // model; the splined lens leaves none (chi-square consistent with the noise), its border cells'
  // systematic error and its largest cell mean a fraction of radtan's.
  EXPECT_TRUE(before.significant);
  EXPECT_GT(before.border_mean_px, before.inner_mean_px);
  EXPECT_NE(before.suggestion.find("LENSMODEL_SPLINED_STEREOGRAPHIC"), std::string::npos);
  EXPECT_FALSE(after.significant);
  EXPECT_LT(after.border_mean_px, 0.33 * before.border_mean_px);
  EXPECT_LT(after.max_mean_px, 0.33 * before.max_mean_px);
  EXPECT_LT(after.chi2, 0.1 * before.chi2);
  EXPECT_LT(*fit_spline.rig.residuals.at("cam0").rms_px,
            *fit_radtan.rig.residuals.at("cam0").rms_px);
  // The two fits differ by more than the noise somewhere in the observed part.
  EXPECT_GT(d.max_px, before.noise_px);
}

}  // namespace
}  // namespace ctcal
