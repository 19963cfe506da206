// Kalibr's camchain(-imucam).yaml / imu.yaml: what we write follows Kalibr's definitions, and
// reading it back as an initial guess gives the rig we wrote.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <unistd.h>
#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <random>

#include "ctcal/sensors/imu_intrinsics.h"
#include "ctcal/sensors/kalibr_files.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;

Eigen::Matrix4d Pose(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() =
      Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized().toRotationMatrix();
  T.topRightCorner<3, 1>() = 0.1 * Eigen::Vector3d(n(rng), n(rng), n(rng));
  return T;
}

template <int N>
Eigen::Matrix<double, N, N> ReadMatrix(const YAML::Node& node) {
  Eigen::Matrix<double, N, N> T;
  for (int r = 0; r < N; ++r) {
    for (int c = 0; c < N; ++c)
      T(r, c) = node[r][c].as<double>();
  }
  return T;
}
Eigen::Matrix4d ReadMatrix4(const YAML::Node& node) {
  return ReadMatrix<4>(node);
}
Eigen::Matrix3d ReadMatrix3(const YAML::Node& node) {
  return ReadMatrix<3>(node);
}

RigConfig VisualInertialRig(ImuModel base_model, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<std::string> warnings;
  RigConfig rig = LoadRig(std::string(CTCAL_SOURCE_DIR) + "/configs/example_rig.yaml", &warnings);
  SensorConfig& imu0 = *rig.Find("imu0");
  imu0.imu_model = base_model;
  if (base_model == ImuModel::kNone) {
    imu0.g_sensitivity = GSensitivity::kNone;
    imu0.D_w.clear();
    imu0.D_a.clear();
    imu0.T_g.clear();
    imu0.estimate.clear();
    imu0.prior_sigma = {};
  } else {
    // A plausible IMU: scale ~1 +- 1 %, misalignment ~1e-3, g-sensitivity ~1e-4.
    std::normal_distribution<double> n(0.0, 1.0);
    imu0.D_w = {1 + 0.01 * n(rng), 1e-3 * n(rng), 1 + 0.01 * n(rng),
                1e-3 * n(rng),     1e-3 * n(rng), 1 + 0.01 * n(rng)};
    imu0.D_a = {1 + 0.01 * n(rng), 1e-3 * n(rng), 1 + 0.01 * n(rng),
                1e-3 * n(rng),     1e-3 * n(rng), 1 + 0.01 * n(rng)};
    for (double& x : imu0.T_g)
      x = 1e-4 * n(rng);
    imu0.R_I_a = Eigen::Quaterniond(1, 1e-3 * n(rng), 1e-3 * n(rng), 1e-3 * n(rng))
                     .normalized()
                     .toRotationMatrix();
  }
  // imu1 (imu1 model -> calibrated is not exact; make it a calibrated IMU) and no gyro: Kalibr
  // has no gyroscope-only sensor.
  SensorConfig& imu1 = *rig.Find("imu1");
  imu1.imu_model = ImuModel::kNone;
  imu1.D_w.clear();
  imu1.D_a.clear();
  imu1.estimate = {EstimateItem::kExtrinsics, EstimateItem::kTimeOffset};
  imu1.T_B_S = Pose(rng);
  imu1.time_offset = 0.003;
  rig.sensors.erase(rig.sensors.begin() + 2);  // gyro0
  SensorConfig cam1 = *rig.Find("cam0");
  cam1.name = "cam1";
  cam1.T_B_S = Pose(rng);
  cam1.time_offset = -0.0021;
  cam1.rostopic = "/cam1/image_raw";
  rig.sensors.push_back(cam1);
  rig.Find("cam0")->T_B_S = Pose(rng);
  rig.Find("cam0")->time_offset = 0.0042;
  return rig;
}

TEST(KalibrFiles, CamchainFollowsKalibrsDefinitions) {
  const RigConfig rig = VisualInertialRig(ImuModel::kNone, 1);
  const YAML::Node chain = YAML::Load(EmitKalibrCamchain(rig));
  const SensorConfig& cam0 = *rig.Find("cam0");
  const SensorConfig& cam1 = *rig.Find("cam1");
  // With a calibrated base IMU, Kalibr's imu frame is B.
  EXPECT_TRUE(ReadMatrix4(chain["cam0"]["T_cam_imu"]).isApprox(cam0.T_B_S.inverse(), 1e-14));
  EXPECT_TRUE(ReadMatrix4(chain["cam1"]["T_cam_imu"]).isApprox(cam1.T_B_S.inverse(), 1e-14));
  EXPECT_TRUE(
      ReadMatrix4(chain["cam1"]["T_cn_cnm1"]).isApprox(cam1.T_B_S.inverse() * cam0.T_B_S, 1e-14));
  EXPECT_FALSE(chain["cam0"]["T_cn_cnm1"]);
  EXPECT_EQ(chain["cam0"]["timeshift_cam_imu"].as<double>(), 0.0042);
  EXPECT_EQ(chain["cam1"]["timeshift_cam_imu"].as<double>(), -0.0021);
  EXPECT_EQ(chain["cam0"]["camera_model"].as<std::string>(), "pinhole");
  EXPECT_EQ(chain["cam0"]["distortion_model"].as<std::string>(), "radtan");
  EXPECT_EQ(chain["cam0"]["intrinsics"].as<std::vector<double>>(), cam0.intrinsics);
  EXPECT_EQ(chain["cam0"]["distortion_coeffs"].as<std::vector<double>>(), cam0.distortion_coeffs);
  EXPECT_EQ(chain["cam0"]["resolution"].as<std::vector<int>>(), (std::vector<int>{752, 480}));
  EXPECT_EQ(chain["cam0"]["cam_overlaps"].as<std::vector<int>>(), std::vector<int>{1});
  EXPECT_EQ(chain["cam1"]["rostopic"].as<std::string>(), "/cam1/image_raw");

  const YAML::Node imu = YAML::Load(EmitKalibrImu(rig));
  EXPECT_TRUE(ReadMatrix4(imu["imu0"]["T_i_b"]).isApprox(Eigen::Matrix4d::Identity(), 1e-15));
  EXPECT_TRUE(ReadMatrix4(imu["imu1"]["T_i_b"]).isApprox(rig.Find("imu1")->T_B_S.inverse(), 1e-14));
  EXPECT_EQ(imu["imu1"]["time_offset"].as<double>(), 0.003);
  EXPECT_EQ(imu["imu0"]["model"].as<std::string>(), "calibrated");
  EXPECT_EQ(imu["imu0"]["update_rate"].as<double>(), 200.0);
  EXPECT_EQ(imu["imu0"]["gyroscope_noise_density"].as<double>(), 1.6968e-04);
  EXPECT_EQ(imu["imu0"]["accelerometer_random_walk"].as<double>(), 3.0e-03);
}

// Write -> read as an initial guess gives back the rig (up to Kalibr's model choice).
void ExpectKalibrRoundTrip(const RigConfig& rig, const std::string& name) {
  const std::string dir =
      (fs::path(::testing::TempDir()) / ("ctcal_kalibr_" + std::to_string(getpid()) + "_" + name))
          .string();
  fs::create_directories(dir);
  const std::vector<std::string> files = SaveKalibrFiles(rig, dir);
  const bool camera_only = rig.IsCameraOnly();
  ASSERT_EQ(files.size(), camera_only ? 1u : 2u);
  KalibrImportOptions options;
  if (!camera_only) {
    options.imu_model =
        rig.Base().imu_model == ImuModel::kNone ? ImuModel::kImu2 : rig.Base().imu_model;
    options.g_sensitivity = rig.Base().g_sensitivity;
  }
  const RigConfig back = RigFromKalibr(files[0], camera_only ? "" : files[1], rig.target, options);
  for (const SensorConfig& s : rig.sensors) {
    const std::string kalibr_name = s.name;  // cam0, cam1, imu0, imu1 as in the example
    const SensorConfig* b = back.Find(kalibr_name);
    ASSERT_TRUE(b) << kalibr_name;
    EXPECT_TRUE(b->T_B_S.isApprox(s.T_B_S, 1e-9)) << kalibr_name << "\n"
                                                  << b->T_B_S << "\n"
                                                  << s.T_B_S;
    if (s.name != rig.base_imu) {
      EXPECT_NEAR(b->time_offset, s.time_offset, 1e-15) << kalibr_name;
    }
    if (s.type == SensorType::kCamera) {
      EXPECT_EQ(b->intrinsics, s.intrinsics);
      EXPECT_EQ(b->distortion_coeffs, s.distortion_coeffs);
      EXPECT_EQ(b->width, s.width);
    } else {
      EXPECT_EQ(b->noise.gyroscope_noise_density, s.noise.gyroscope_noise_density);
      EXPECT_EQ(b->noise.update_rate, s.noise.update_rate);
      if (s.imu_model != ImuModel::kNone) {
        for (std::size_t k = 0; k < s.D_w.size(); ++k) {
          EXPECT_NEAR(b->D_w[k], s.D_w[k], 1e-12) << k;
          EXPECT_NEAR(b->D_a[k], s.D_a[k], 1e-12) << k;
        }
        for (std::size_t k = 0; k < s.T_g.size(); ++k)
          EXPECT_NEAR(b->T_g[k], s.T_g[k], 1e-12) << k;
        EXPECT_TRUE(b->R_I_a.isApprox(s.R_I_a, 1e-12));
      }
    }
  }
}

TEST(KalibrFiles, CalibratedImuRigRoundTrips) {
  ExpectKalibrRoundTrip(VisualInertialRig(ImuModel::kNone, 2), "calibrated");
}

TEST(KalibrFiles, ScaleMisalignedBaseImuRoundTripsWithItsFrames) {
  ExpectKalibrRoundTrip(VisualInertialRig(ImuModel::kImu2, 3), "scale_misalignment");
}

// SPEC 1: T_cam_imu = inverse(T_B_C) with B the base IMU's frame I (here imu2: its gyroscope
// frame), even when Kalibr's canonical frame (accelerometer x axis) differs from it; imu.yaml's
// scale-misalignment equations then hold in I:
//   a_m = M_a a_I + b_a,   w_m = M_g C_gyro_i w_I + A C_gyro_i a_I + b_g,
// and must give our model's raw readings to rounding.
TEST(KalibrFiles, ScaleMisalignedBaseKeepsSpecFramesAndKalibrEquations) {
  const RigConfig rig = VisualInertialRig(ImuModel::kImu2, 5);
  const SensorConfig& imu0 = *rig.Find("imu0");
  const YAML::Node chain = YAML::Load(EmitKalibrCamchain(rig));
  for (const char* cam : {"cam0", "cam1"})
    EXPECT_TRUE(
        ReadMatrix4(chain[cam]["T_cam_imu"]).isApprox(rig.Find(cam)->T_B_S.inverse(), 1e-12))
        << cam;
  const YAML::Node imu = YAML::Load(EmitKalibrImu(rig))["imu0"];
  const Eigen::Matrix3d M_a = ReadMatrix3(imu["accelerometers"]["M"]);
  const Eigen::Matrix3d M_g = ReadMatrix3(imu["gyroscopes"]["M"]);
  const Eigen::Matrix3d A = ReadMatrix3(imu["gyroscopes"]["A"]);
  const Eigen::Matrix3d C = ReadMatrix3(imu["gyroscopes"]["C_gyro_i"]);
  StoredImuIntrinsics stored;
  stored.Dw = imu0.D_w;
  stored.Da = imu0.D_a;
  stored.Tg = imu0.T_g;
  stored.rotation = imu0.R_I_a;
  const ImuIntrinsics ours = ImuIntrinsics::FromStored(imu0.imu_model, imu0.g_sensitivity, stored);
  std::mt19937 rng(11);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int k = 0; k < 5; ++k) {
    const Eigen::Vector3d w_I(n(rng), n(rng), n(rng)), a_I(3 * n(rng), 3 * n(rng), 9.81 + n(rng));
    Eigen::Vector3d w_m, a_m;
    ours.RawFromTrue(w_I, a_I, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), &w_m, &a_m);
    // The file's numbers are printed to ~1e-10 relative.
    EXPECT_LT((M_a * a_I - a_m).norm(), 1e-8 * a_m.norm());
    EXPECT_LT((M_g * C * w_I + A * C * a_I - w_m).norm(), 1e-8 * (w_m.norm() + 1.0));
  }
}

TEST(KalibrFiles, CameraOnlyRigWritesCamchainWithChainedPoses) {
  std::vector<std::string> warnings;
  const std::string ref = std::string(CTCAL_SHARED_DATA_DIR) + "/euroc_cam_april/reference.yaml";
  if (!fs::is_regular_file(ref))
    GTEST_SKIP() << ref << " is absent (shared real data)";
  const RigConfig rig = LoadRig(ref, &warnings);
  const YAML::Node chain = YAML::Load(EmitKalibrCamchain(rig));
  EXPECT_FALSE(chain["cam0"]["T_cam_imu"]);
  EXPECT_FALSE(chain["cam0"]["timeshift_cam_imu"]);
  EXPECT_TRUE(
      ReadMatrix4(chain["cam1"]["T_cn_cnm1"]).isApprox(rig.Find("cam1")->T_B_S.inverse(), 1e-10));
  ExpectKalibrRoundTrip(rig, "camera_only");
}

TEST(KalibrFiles, ReadsAKalibrWrittenImuInputFile) {
  // Kalibr's single-IMU input format: keys at the top level.
  const std::string dir =
      (fs::path(::testing::TempDir()) / ("ctcal_kalibr_input_" + std::to_string(getpid())))
          .string();
  fs::create_directories(dir);
  std::ofstream(dir + "/imu.yaml") << R"(#Accelerometers
accelerometer_noise_density: 1.86e-03   #Noise density (continuous-time)
accelerometer_random_walk:   4.33e-04   #Bias random walk
#Gyroscopes
gyroscope_noise_density:     1.87e-04   #Noise density (continuous-time)
gyroscope_random_walk:       2.66e-05   #Bias random walk
rostopic:                    /imu0      #the IMU ROS topic
update_rate:                 200.0      #Hz (for discretization of the values above)
)";
  std::ofstream(dir + "/camchain.yaml") << R"(cam0:
  cam_overlaps: []
  camera_model: pinhole
  distortion_coeffs: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]
  distortion_model: radtan
  intrinsics: [458.654, 457.296, 367.215, 248.375]
  resolution: [752, 480]
  rostopic: /cam0/image_raw
  T_cam_imu:
  - [0.0148655429818, 0.999557249008, -0.0257744366974, 0.0652229609887]
  - [-0.999880929698, 0.0149672133247, 0.00375618835797, -0.0207063854221]
  - [0.00414029679422, 0.025715529948, 0.999660727178, -0.0080546329543]
  - [0.0, 0.0, 0.0, 1.0]
  timeshift_cam_imu: 0.0001
)";
  TargetConfig target;
  const RigConfig rig = RigFromKalibr(dir + "/camchain.yaml", dir + "/imu.yaml", target);
  ASSERT_EQ(rig.sensors.size(), 2u);
  EXPECT_EQ(rig.base_imu, "imu0");
  EXPECT_EQ(rig.Base().imu_model, ImuModel::kNone);
  EXPECT_EQ(rig.Base().noise.accelerometer_noise_density, 1.86e-03);
  EXPECT_EQ(*rig.Base().rostopic, "/imu0");
  const SensorConfig& cam = *rig.Find("cam0");
  // EuRoC's T_BS of cam0 (the inverse of Kalibr's T_cam_imu above, which is rounded: 1e-7 m).
  EXPECT_NEAR(cam.T_B_S(0, 3), -0.0216401454975, 1e-7);
  EXPECT_NEAR(cam.T_B_S(1, 3), -0.064676986768, 1e-7);
  EXPECT_NEAR(cam.T_B_S(1, 0), 0.999557249008, 1e-9);
  EXPECT_EQ(cam.time_offset, 0.0001);
  // The guess is a valid rig: it writes and reads back.
  std::vector<std::string> warnings;
  EXPECT_TRUE(ParseRigString(EmitRig(rig), "guess", &warnings) == rig);
}

}  // namespace
}  // namespace ctcal
