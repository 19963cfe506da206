// The camera-only calibrator (SPEC section 7): a simulated stereo rig without IMUs, EuRoC's real
// cam_april stereo detections, and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "ctcal/calibrator/camera_only/camera_only_calibrator.h"
#include "ctcal/calibrator/init/init_log.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/kalibr_files.h"
#include "ctcal/sensors/rig_yaml.h"
#include "ctcal/sim/default_rig.h"
#include "ctcal/sim/scenario.h"
#include "ctcal/sim/simulator.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;
constexpr double kRadToDeg = 180.0 / M_PI;

Eigen::Vector3d Log(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

// The default rig's two cameras, cam1 expressed in cam0 (B = cam0).
RigConfig StereoTruth() {
  RigConfig rig = sim::DefaultRig();
  rig.sensors.erase(rig.sensors.begin(), rig.sensors.begin() + 3);  // imu0, imu1, gyro0
  rig.base_imu = "cam0";
  const Eigen::Matrix4d T_B_C0 = sim::DefaultRig().Find("cam0")->T_B_S;
  rig.Find("cam1")->T_B_S = T_B_C0.inverse() * rig.Find("cam1")->T_B_S;
  rig.Find("cam0")->T_B_S.setIdentity();
  rig.Find("cam0")->time_offset = 0.0;
  rig.Find("cam1")->time_offset = 0.0;
  rig.Find("cam0")->estimate = {EstimateItem::kIntrinsics};
  rig.Find("cam1")->estimate = {EstimateItem::kIntrinsics, EstimateItem::kExtrinsics};
  return rig;
}

std::map<std::string, SensorData> ToSensorData(const sim::SimulatedDataset& sim) {
  std::map<std::string, SensorData> data;
  for (const sim::CameraData& cam : sim.cameras) {
    SensorData& d = data[cam.sensor];
    d.has_corners = true;
    for (const sim::SimulatedCorner& c : cam.corners)
      d.corners.push_back({c.t_ns, c.corner_id, c.uv.x(), c.uv.y(), c.sigma});
  }
  return data;
}

const sim::CameraData& Camera(const sim::SimulatedDataset& sim, const std::string& name) {
  for (const sim::CameraData& cam : sim.cameras)
    if (cam.sensor == name)
      return cam;
  throw std::logic_error("no camera " + name);
}

// The simulator starts every non-base camera at a random phase. A camera-only rig is
// synchronised, so cam1's time offset is chosen to put its exposures at cam0's: a short first run
// reveals the phase (it depends on the seed only).
sim::SimulatedDataset SimulateSynchronisedStereo(RigConfig* truth, double duration) {
  const auto motion = sim::MakeTrajectory(sim::Scenario::kFull, sim::SceneFor(truth->target));
  const sim::RotatedTrajectory traj(*motion, sim::ScenarioMount(*truth));
  sim::SimOptions options;
  options.seed = 7;
  options.duration = 0.3;
  const sim::SimulatedDataset probe = sim::Simulate(*truth, traj, options);
  const double dt_ns = 1e9 / options.camera_rate_hz;
  const double diff_ns = static_cast<double>(Camera(probe, "cam0").frames_ns.front() -
                                             Camera(probe, "cam1").frames_ns.front());
  truth->Find("cam1")->time_offset = std::remainder(diff_ns, dt_ns) * 1e-9;
  options.duration = duration;
  return sim::Simulate(*truth, traj, options);
}

TEST(CameraOnly, SimulatedStereoRigRecoversIntrinsicsAndExtrinsicsWithinSigma) {
  RigConfig truth = StereoTruth();
  const sim::SimulatedDataset sim = SimulateSynchronisedStereo(&truth, 4.0);
  const std::map<std::string, SensorData> data = ToSensorData(sim);

  // The guess: focal 1 % off, centre 3 px off, half the distortion, cam1 0.6 deg and 8 mm off.
  RigConfig guess = truth;
  for (const char* name : {"cam0", "cam1"}) {
    SensorConfig& s = *guess.Find(name);
    s.intrinsics[0] *= 1.01;
    s.intrinsics[1] *= 1.01;
    s.intrinsics[2] += 3.0;
    s.intrinsics[3] -= 3.0;
    for (double& k : s.distortion_coeffs)
      k *= 0.5;
  }
  Eigen::Matrix4d& T = guess.Find("cam1")->T_B_S;
  T.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(0.0095, Eigen::Vector3d(0.6, -0.6, 0.4).normalized()).toRotationMatrix() *
      T.topLeftCorner<3, 3>().eval();
  T.topRightCorner<3, 1>() += Eigen::Vector3d(0.005, -0.004, 0.005);

  std::ostringstream log;
  const CameraOnlyResult result = CalibrateCameraOnly(guess, data, {}, log);
  std::printf("%s", log.str().c_str());
  ASSERT_TRUE(result.rig.observability.has_value());
  // Varied views: no weak focal length. The wide-angle equidistant cam1's higher coefficients
  // (all ~1e-3) may be numerically inseparable over 4 s; only distortion may be undetermined.
  EXPECT_TRUE(result.rig.observability->weak.empty());
  for (const std::string& n : result.rig.observability->unobservable)
    EXPECT_NE(n.find("distortion_coeffs"), std::string::npos) << n;

  for (const char* name : {"cam0", "cam1"}) {
    const SensorConfig& est = *result.rig.Find(name);
    const SensorConfig& tru = *truth.Find(name);
    const std::vector<double>* s_k = est.sigma.Find("intrinsics");
    const std::vector<double>* s_d = est.sigma.Find("distortion_coeffs");
    ASSERT_TRUE(s_k && s_d) << name;
    for (std::size_t i = 0; i < tru.intrinsics.size(); ++i) {
      std::printf("%s intrinsics[%zu]: %.4f truth %.4f sigma %.4f\n", name, i, est.intrinsics[i],
                  tru.intrinsics[i], (*s_k)[i]);
      EXPECT_NEAR(est.intrinsics[i], tru.intrinsics[i], 4.0 * (*s_k)[i]) << name << " " << i;
      // Plausible: thousands of corners at 1 px determine focal and centre to a fraction of a px.
      EXPECT_GT((*s_k)[i], 0.005) << name << " " << i;
      EXPECT_LT((*s_k)[i], 1.0) << name << " " << i;
    }
    for (std::size_t i = 0; i < tru.distortion_coeffs.size(); ++i)
      EXPECT_NEAR(est.distortion_coeffs[i], tru.distortion_coeffs[i], 4.0 * (*s_d)[i])
          << name << " " << i;
    const SensorResiduals& res = result.rig.residuals.at(name);
    ASSERT_TRUE(res.rms_whitened.has_value());
    // Simulated 1 px noise: the whitened RMS is ~1 (the fit absorbs a few degrees of freedom).
    EXPECT_NEAR(*res.rms_whitened, 1.0, 0.05) << name;
    EXPECT_EQ(result.cameras.at(name).outliers, 0) << name;
  }

  // Synchronised: no pairing warning.
  for (const std::string& w : result.warnings)
    EXPECT_EQ(w.find("apart"), std::string::npos) << w;

  const SensorConfig& cam1 = *result.rig.Find("cam1");
  const Eigen::Matrix3d R_est = cam1.T_B_S.topLeftCorner<3, 3>();
  const Eigen::Matrix3d R_true = truth.Find("cam1")->T_B_S.topLeftCorner<3, 3>();
  // Left perturbation, as the sigma is defined: R_est = Exp(d) R_true.
  const Eigen::Vector3d d_R = Log(Eigen::Matrix3d(R_est * R_true.transpose()));
  const Eigen::Vector3d d_t =
      cam1.T_B_S.topRightCorner<3, 1>() - truth.Find("cam1")->T_B_S.topRightCorner<3, 1>();
  const std::vector<double>& s_R = *cam1.sigma.Find("R_B_S");
  const std::vector<double>& s_t = *cam1.sigma.Find("t_B_S");
  for (int i = 0; i < 3; ++i) {
    std::printf("cam1 R_B_S[%d] error %.5f deg sigma %.5f; t_B_S[%d] error %.3f mm sigma %.3f\n", i,
                d_R(i) * kRadToDeg, s_R[i] * kRadToDeg, i, d_t(i) * 1e3, s_t[i] * 1e3);
    EXPECT_LT(std::abs(d_R(i)), 4.0 * s_R[i]) << i;
    EXPECT_LT(std::abs(d_t(i)), 4.0 * s_t[i]) << i;
    EXPECT_LT(s_R[i] * kRadToDeg, 0.2) << i;
    EXPECT_LT(s_t[i], 0.002) << i;
  }

  // The result saves as a SPEC rig file and Kalibr's camchain.yaml, and reads back.
  const fs::path out = fs::temp_directory_path() / "ctcal_camera_only_sim";
  fs::create_directories(out);
  SaveRig(result.rig, (out / "result.yaml").string());
  const std::vector<std::string> written = SaveKalibrFiles(result.rig, out.string());
  EXPECT_TRUE(fs::exists(out / "camchain.yaml"));
  EXPECT_FALSE(fs::exists(out / "camchain-imucam.yaml"));
  EXPECT_FALSE(written.empty());
  const RigConfig reread = LoadRig((out / "result.yaml").string());
  EXPECT_EQ(*reread.Find("cam1")->sigma.Find("t_B_S"), s_t);
  fs::remove_all(out);
}

// One compressed block per frame (the default) against one autodiff block per corner: the same
// cost, gradient and Gauss-Newton Hessian (board_frame_corners.h), so Levenberg-Marquardt takes the
// same steps. With corners pulled 15 px off (the Huber stage and the outlier gate both act), the
// two give the same outliers, iterations and estimates to rounding: within 1e-6 sigma, the sigmas
// within 1e-6 relative.
TEST(CameraOnly, FrameBlocksGiveThePerCornerEstimates) {
  RigConfig truth = StereoTruth();
  const sim::SimulatedDataset sim = SimulateSynchronisedStereo(&truth, 2.0);
  std::map<std::string, SensorData> data = ToSensorData(sim);
  for (auto& [name, d] : data)
    for (std::size_t i = 0; i < d.corners.size(); i += 97)
      d.corners[i].u += 15.0;
  RigConfig guess = truth;
  for (const char* name : {"cam0", "cam1"}) {
    guess.Find(name)->intrinsics[0] *= 1.005;
    guess.Find(name)->intrinsics[2] += 2.0;
  }
  guess.Find("cam1")->T_B_S(0, 3) += 0.004;

  std::ostringstream log_frames, log_corners;
  CameraOnlyOptions options;
  const CameraOnlyResult frames = CalibrateCameraOnly(guess, data, options, log_frames);
  options.per_corner_blocks = true;
  const CameraOnlyResult corners = CalibrateCameraOnly(guess, data, options, log_corners);
  ASSERT_EQ(frames.rig.solver->iterations, corners.rig.solver->iterations)
      << log_frames.str() << log_corners.str();
  double worst = 0.0;
  for (const char* name : {"cam0", "cam1"}) {
    EXPECT_GT(frames.cameras.at(name).outliers, 0) << name;
    EXPECT_EQ(frames.cameras.at(name).outliers, corners.cameras.at(name).outliers) << name;
    const SensorConfig& f = *frames.rig.Find(name);
    const SensorConfig& c = *corners.rig.Find(name);
    auto compare = [&](const std::string& key, const std::vector<double>& fv,
                       const std::vector<double>& cv) {
      const std::vector<double>& fs = *f.sigma.Find(key);
      const std::vector<double>& cs = *c.sigma.Find(key);
      ASSERT_EQ(fs.size(), cv.size());
      for (std::size_t i = 0; i < fv.size(); ++i) {
        worst = std::max(worst, std::abs(fv[i] - cv[i]) / cs[i]);
        EXPECT_NEAR(fv[i], cv[i], 1e-6 * cs[i]) << name << "." << key << "[" << i << "]";
        EXPECT_NEAR(fs[i], cs[i], 1e-6 * cs[i]) << name << ".sigma." << key << "[" << i << "]";
      }
    };
    compare("intrinsics", f.intrinsics, c.intrinsics);
    compare("distortion_coeffs", f.distortion_coeffs, c.distortion_coeffs);
  }
  const Eigen::Matrix4d& T_f = frames.rig.Find("cam1")->T_B_S;
  const Eigen::Matrix4d& T_c = corners.rig.Find("cam1")->T_B_S;
  const Eigen::Vector3d d_R =
      Log(Eigen::Matrix3d(T_f.topLeftCorner<3, 3>() * T_c.topLeftCorner<3, 3>().transpose()));
  const Eigen::Vector3d d_t = T_f.topRightCorner<3, 1>() - T_c.topRightCorner<3, 1>();
  const std::vector<double>& s_R = *corners.rig.Find("cam1")->sigma.Find("R_B_S");
  const std::vector<double>& s_t = *corners.rig.Find("cam1")->sigma.Find("t_B_S");
  for (int i = 0; i < 3; ++i) {
    const auto k = static_cast<std::size_t>(i);
    worst = std::max({worst, std::abs(d_R(i)) / s_R[k], std::abs(d_t(i)) / s_t[k]});
    EXPECT_LT(std::abs(d_R(i)), 1e-6 * s_R[k]) << i;
    EXPECT_LT(std::abs(d_t(i)), 1e-6 * s_t[k]) << i;
  }
  std::printf("frame blocks vs per-corner blocks: worst difference %.3g sigma\n", worst);
}

// The same rig with its cameras at the simulator's random phases (not synchronised): SPEC's
// pairing by the nearest stamp puts two exposures of a moving rig on one board pose, which no
// intrinsics can fit. The calibrator says how far apart the paired frames are.
TEST(CameraOnly, UnsynchronisedStereoIsWarnedAbout) {
  const RigConfig truth = StereoTruth();
  const auto motion = sim::MakeTrajectory(sim::Scenario::kFull, sim::SceneFor(truth.target));
  const sim::RotatedTrajectory traj(*motion, sim::ScenarioMount(truth));
  sim::SimOptions options;
  options.seed = 7;
  options.duration = 1.5;
  const sim::SimulatedDataset sim = sim::Simulate(truth, traj, options);
  const double gap_ms =
      std::abs(std::remainder(static_cast<double>(Camera(sim, "cam0").frames_ns.front() -
                                                  Camera(sim, "cam1").frames_ns.front()),
                              1e9 / options.camera_rate_hz)) *
      1e-6;
  ASSERT_GT(gap_ms, 1.0) << "seed 7 happens to synchronise the cameras: pick another";
  std::ostringstream log;
  const CameraOnlyResult result = CalibrateCameraOnly(truth, ToSensorData(sim), {}, log);
  std::string warning;
  for (const std::string& w : result.warnings)
    if (w.find("apart") != std::string::npos)
      warning = w;
  std::printf("stamps %.2f ms apart: %s\n", gap_ms, warning.c_str());
  EXPECT_EQ(warning.rfind("cam1: frames paired with cam0's up to ", 0), 0) << log.str();
  char expected[32];
  std::snprintf(expected, sizeof expected, "%.2f", gap_ms);
  EXPECT_NE(warning.find(std::string(expected).substr(0, 3)), std::string::npos) << warning;
}

TEST(CameraOnly, EurocStereoAgreesWithReferenceOrSaysIntrinsicsAreWeak) {
  const fs::path dir = fs::path(CTCAL_SHARED_DATA_DIR) / "euroc_cam_april";
  if (!fs::exists(dir / "reference.yaml"))
    GTEST_SKIP() << "real data absent: " << dir.string();
  const RigConfig reference = LoadRig((dir / "reference.yaml").string());
  const std::map<std::string, SensorData> data = LoadDataset(dir.string(), reference);

  // A coarse guess: focal 5 % short, no distortion, cam1 at identity rotation and 10 cm baseline.
  RigConfig guess = reference;
  for (SensorConfig& s : guess.sensors) {
    s.intrinsics[0] *= 0.95;
    s.intrinsics[1] *= 0.95;
    s.distortion_coeffs.assign(s.distortion_coeffs.size(), 0.0);
  }
  guess.Find("cam1")->T_B_S.setIdentity();
  guess.Find("cam1")->T_B_S(0, 3) = 0.10;

  std::ostringstream log;
  const CameraOnlyResult result = CalibrateCameraOnly(guess, data, {}, log);
  std::printf("%s", log.str().c_str());
  ASSERT_TRUE(result.rig.observability.has_value());
  const std::vector<std::string>& weak = result.rig.observability->weak;
  auto is_weak = [&](const std::string& n) {
    return std::find(weak.begin(), weak.end(), n) != weak.end();
  };
  for (const char* name : {"cam0", "cam1"}) {
    const SensorConfig& est = *result.rig.Find(name);
    const SensorConfig& ref = *reference.Find(name);
    const std::vector<double>& s_k = *est.sigma.Find("intrinsics");
    const double whitened = *result.rig.residuals.at(name).rms_whitened;
    for (int i = 0; i < 4; ++i) {
      const std::string n = std::string(name) + ".intrinsics[" + std::to_string(i) + "]";
      const double err =
          est.intrinsics[static_cast<std::size_t>(i)] - ref.intrinsics[static_cast<std::size_t>(i)];
      std::printf("%s: %.2f reference %.2f (%+.2f) sigma %.2f px (x whitened RMS %.3f: %.2f)%s\n",
                  n.c_str(), est.intrinsics[static_cast<std::size_t>(i)],
                  ref.intrinsics[static_cast<std::size_t>(i)], err, s_k[static_cast<size_t>(i)],
                  whitened, s_k[static_cast<size_t>(i)] * whitened, is_weak(n) ? " WEAK" : "");
      EXPECT_TRUE(std::abs(err) <= 3.0 * s_k[static_cast<size_t>(i)] || is_weak(n))
          << n << ": " << err << " px from the reference, sigma " << s_k[static_cast<size_t>(i)];
    }
    // Real corners reproject at a fraction of a pixel.
    EXPECT_LT(*result.rig.residuals.at(name).rms_px, 0.5) << name;
  }
  // The EuRoC views are nearly alike: the focal lengths must be flagged.
  EXPECT_FALSE(weak.empty());
  EXPECT_FALSE(result.warnings.empty());

  const SensorConfig& cam1 = *result.rig.Find("cam1");
  const Eigen::Matrix4d T_ref = reference.Find("cam1")->T_B_S;
  const Eigen::Vector3d d_R = Log(
      Eigen::Matrix3d(cam1.T_B_S.topLeftCorner<3, 3>() * T_ref.topLeftCorner<3, 3>().transpose()));
  const Eigen::Vector3d d_t = cam1.T_B_S.topRightCorner<3, 1>() - T_ref.topRightCorner<3, 1>();
  const std::vector<double>& s_R = *cam1.sigma.Find("R_B_S");
  const std::vector<double>& s_t = *cam1.sigma.Find("t_B_S");
  std::printf("baseline %.2f mm (reference %.2f mm); rotation %.4f deg from the reference\n",
              cam1.T_B_S.topRightCorner<3, 1>().norm() * 1e3,
              T_ref.topRightCorner<3, 1>().norm() * 1e3, d_R.norm() * kRadToDeg);
  for (int i = 0; i < 3; ++i)
    std::printf("cam1 R_B_S[%d] %+.4f deg sigma %.4f; t_B_S[%d] %+.2f mm sigma %.2f\n", i,
                d_R(i) * kRadToDeg, s_R[static_cast<size_t>(i)] * kRadToDeg, i, d_t(i) * 1e3,
                s_t[static_cast<size_t>(i)] * 1e3);
  // The stereo geometry agrees with EuRoC's within its sigma (inflated by the weak focal length,
  // with which the relative pose trades), and within 0.5 deg / 1 cm outright.
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT(std::abs(d_R(i)), 3.0 * s_R[static_cast<size_t>(i)]) << i;
    EXPECT_LT(std::abs(d_t(i)), 3.0 * s_t[static_cast<size_t>(i)]) << i;
  }
  EXPECT_LT(d_R.norm() * kRadToDeg, 0.5);
  EXPECT_LT(d_t.norm(), 0.01);
}

// A stereo dataset small enough for the error tests.
struct SmallStereo {
  RigConfig rig = StereoTruth();
  std::map<std::string, SensorData> data;
  SmallStereo() {
    const sim::SimulatedDataset sim = SimulateSynchronisedStereo(&rig, 0.6);
    data = ToSensorData(sim);
  }
};

std::string ErrorOf(const RigConfig& rig, const std::map<std::string, SensorData>& data) {
  std::ostringstream log;
  try {
    CalibrateCameraOnly(rig, data, {}, log);
  } catch (const std::exception& e) {
    std::printf("error: %s\n", e.what());
    return e.what();
  }
  return "";
}

TEST(CameraOnly, BadInputGetsOneClearMessage) {
  const SmallStereo s;
  ASSERT_EQ(ErrorOf(s.rig, s.data), "");

  // A camera that never sees the board.
  auto blind = s.data;
  blind["cam1"].corners.clear();
  std::string e = ErrorOf(s.rig, blind);
  EXPECT_NE(e.find("cam1"), std::string::npos) << e;

  // Too few views: two frames of the reference camera.
  auto few = s.data;
  std::vector<CornerObservation> kept;
  std::set<std::int64_t> frames;
  for (const CornerObservation& c : few["cam0"].corners) {
    frames.insert(c.t_ns);
    if (frames.size() <= 2)
      kept.push_back(c);
  }
  few["cam0"].corners = kept;
  e = ErrorOf(s.rig, few);
  EXPECT_NE(e.find("cam0"), std::string::npos) << e;
  EXPECT_NE(e.find("3"), std::string::npos) << e;

  // No corners.csv: detection has not run.
  auto undetected = s.data;
  undetected["cam1"].has_corners = false;
  undetected["cam1"].corners.clear();
  e = ErrorOf(s.rig, undetected);
  EXPECT_NE(e.find("cam1"), std::string::npos) << e;
  EXPECT_NE(e.find("corners.csv"), std::string::npos) << e;

  // A rig with an IMU is not a camera calibration.
  RigConfig with_imu = sim::DefaultRig();
  e = ErrorOf(with_imu, s.data);
  EXPECT_NE(e.find("inertial"), std::string::npos) << e;
}

}  // namespace
}  // namespace ctcal
