// `ctcal import-kalibr`'s reader (kalibr_files.h, RigFromKalibr with several imu.yaml files):
// Kalibr's files as a Kalibr user has them before and after Kalibr's own calibrations become a rig
// whose transforms are the files' in our frames, with what the files leave open started where
// ctcal's initialisation takes over.
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <string>

#include "ctcal/sensors/kalibr_files.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;

std::string TempDir(const std::string& name) {
  const fs::path dir =
      fs::path(::testing::TempDir()) / ("ctcal_import_" + name + "_" + std::to_string(getpid()));
  fs::create_directories(dir);
  return dir.string();
}

// Kalibr's imu.yaml input file (its documentation's example values).
constexpr char kImuYaml[] = R"(#Accelerometers
accelerometer_noise_density: 1.86e-03   #Noise density (continuous-time)
accelerometer_random_walk:   4.33e-04   #Bias random walk
#Gyroscopes
gyroscope_noise_density:     1.87e-04   #Noise density (continuous-time)
gyroscope_random_walk:       2.66e-05   #Bias random walk
rostopic:                    /imu0      #the IMU ROS topic
update_rate:                 200.0      #Hz (for discretization of the values above)
)";

// A second IMU after Kalibr's IMU-IMU calibration: its T_i_b and time offset.
constexpr char kImu1Yaml[] = R"(accelerometer_noise_density: 2.0e-03
accelerometer_random_walk: 3.0e-03
gyroscope_noise_density: 1.7e-04
gyroscope_random_walk: 2.0e-05
rostopic: /imu1
update_rate: 400.0
time_offset: -0.0025
T_i_b:
- [0.0, -1.0, 0.0, 0.05]
- [1.0, 0.0, 0.0, -0.02]
- [0.0, 0.0, 1.0, 0.01]
- [0.0, 0.0, 0.0, 1.0]
)";

// kalibr_calibrate_cameras' camchain.yaml of a stereo pair: no T_cam_imu, no timeshift.
constexpr char kCamchainYaml[] = R"(cam0:
  cam_overlaps: [1]
  camera_model: pinhole
  distortion_coeffs: [0.0, 0.0, 0.0, 0.0]
  distortion_model: radtan
  intrinsics: [470.0, 468.0, 367.0, 248.0]
  resolution: [752, 480]
  rostopic: /cam0/image_raw
cam1:
  T_cn_cnm1:
  - [0.9999972564779, 0.0023156141, 0.0003760688, -0.1100738081]
  - [-0.0023171350, 0.9999878, 0.0044306, 0.0003991]
  - [-0.0003658, -0.0044315, 0.9999901, -0.0008531]
  - [0.0, 0.0, 0.0, 1.0]
  cam_overlaps: [0]
  camera_model: pinhole
  distortion_coeffs: [0.0, 0.0, 0.0, 0.0]
  distortion_model: radtan
  intrinsics: [470.0, 468.0, 379.0, 255.0]
  resolution: [752, 480]
  rostopic: /cam1/image_raw
)";

struct Files {
  std::string dir, imu0, imu1, camchain;
};

Files WriteFiles(const std::string& name) {
  Files f;
  f.dir = TempDir(name);
  f.imu0 = f.dir + "/imu.yaml";
  f.imu1 = f.dir + "/imu1.yaml";
  f.camchain = f.dir + "/camchain.yaml";
  std::ofstream(f.imu0) << kImuYaml;
  std::ofstream(f.imu1) << kImu1Yaml;
  std::ofstream(f.camchain) << kCamchainYaml;
  return f;
}

TEST(KalibrImport, SeveralImuFilesAndACamchainWithoutTCamImu) {
  const Files f = WriteFiles("several");
  std::vector<std::string> warnings;
  const RigConfig rig =
      RigFromKalibr(f.camchain, {f.imu0, f.imu1}, TargetConfig{}, KalibrImportOptions{}, &warnings);
  ASSERT_EQ(rig.sensors.size(), 4u);
  EXPECT_EQ(rig.base_imu, "imu0");
  const SensorConfig& imu0 = *rig.Find("imu0");
  const SensorConfig& imu1 = *rig.Find("imu1");
  EXPECT_EQ(imu0.imu_model, ImuModel::kNone);  // Kalibr's default: a calibrated IMU
  EXPECT_TRUE(imu0.estimate.empty());
  EXPECT_EQ(imu1.noise.update_rate, 400.0);
  EXPECT_EQ(*imu1.rostopic, "/imu1");
  // T_i_b is imu1's pose seen from imu0 (b): T_B_S = inverse(T_i_b), t_b = t_i + time_offset.
  Eigen::Matrix4d T_i_b;
  T_i_b << 0, -1, 0, 0.05, 1, 0, 0, -0.02, 0, 0, 1, 0.01, 0, 0, 0, 1;
  EXPECT_TRUE(imu1.T_B_S.isApprox(T_i_b.inverse(), 1e-12)) << imu1.T_B_S;
  EXPECT_EQ(imu1.time_offset, -0.0025);
  EXPECT_EQ(imu1.estimate,
            (std::set<EstimateItem>{EstimateItem::kExtrinsics, EstimateItem::kTimeOffset}));
  // No T_cam_imu: cam0 starts at the identity (one warning naming it), cam1 chained to it.
  const SensorConfig& cam0 = *rig.Find("cam0");
  const SensorConfig& cam1 = *rig.Find("cam1");
  EXPECT_TRUE(cam0.T_B_S.isIdentity());
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("cam0: no T_cam_imu"), std::string::npos) << warnings[0];
  Eigen::Matrix4d T_c1_c0 = Eigen::Matrix4d::Identity();
  T_c1_c0.topRightCorner<3, 1>() << -0.1100738081, 0.0003991, -0.0008531;
  EXPECT_LT((cam1.T_B_S.topRightCorner<3, 1>() - T_c1_c0.inverse().topRightCorner<3, 1>()).norm(),
            1e-3);
  EXPECT_NEAR(cam1.T_B_S(0, 3), 0.11, 1e-3);
  // The camchain is a guess to refine: intrinsics, extrinsics and the offset are estimated.
  for (const SensorConfig* c : {&cam0, &cam1}) {
    EXPECT_EQ(c->estimate,
              (std::set<EstimateItem>{EstimateItem::kIntrinsics, EstimateItem::kExtrinsics,
                                      EstimateItem::kTimeOffset}))
        << c->name;
    EXPECT_EQ(c->time_offset, 0.0);
  }
  EXPECT_EQ(*cam1.rostopic, "/cam1/image_raw");
  // What import-kalibr writes reads back as the same rig.
  SaveRig(rig, f.dir + "/rig.yaml");
  std::vector<std::string> load_warnings;
  const RigConfig back = LoadRig(f.dir + "/rig.yaml", &load_warnings);
  ASSERT_EQ(back.sensors.size(), 4u);
  EXPECT_TRUE(back.Find("cam1")->T_B_S.isApprox(cam1.T_B_S, 1e-12));
  EXPECT_EQ(back.Find("imu1")->time_offset, -0.0025);
  EXPECT_EQ(*back.Find("imu0")->rostopic, "/imu0");
}

TEST(KalibrImport, ACalibratedImuCanBeGivenAModelToEstimate) {
  const Files f = WriteFiles("model");
  KalibrImportOptions options;
  options.calibrated_imu_model = ImuModel::kImu2;
  options.g_sensitivity = GSensitivity::kUpper;
  options.estimate_camera_intrinsics = false;
  const RigConfig rig = RigFromKalibr(f.camchain, {f.imu0}, TargetConfig{}, options, nullptr);
  const SensorConfig& imu0 = rig.Base();
  EXPECT_EQ(imu0.imu_model, ImuModel::kImu2);
  EXPECT_EQ(imu0.g_sensitivity, GSensitivity::kUpper);
  EXPECT_EQ(imu0.estimate, std::set<EstimateItem>{EstimateItem::kIntrinsics});
  EXPECT_FALSE(rig.Find("cam0")->Estimates(EstimateItem::kIntrinsics));
}

TEST(KalibrImport, ImuFileAloneAndBadFilesNameTheFile) {
  const Files f = WriteFiles("bad");
  const RigConfig imus = RigFromKalibr("", {f.imu0, f.imu1}, TargetConfig{}, {}, nullptr);
  EXPECT_EQ(imus.sensors.size(), 2u);
  std::ofstream(f.dir + "/broken.yaml") << "accelerometer_noise_density: 1.0e-3\nrostopic: /x\n";
  try {
    RigFromKalibr(f.camchain, {f.imu0, f.dir + "/broken.yaml"}, TargetConfig{}, {}, nullptr);
    ADD_FAILURE() << "a Kalibr IMU without its noise keys was accepted";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("broken.yaml:1"), std::string::npos) << what;
    EXPECT_NE(what.find("missing required key"), std::string::npos) << what;
  }
  EXPECT_THROW(RigFromKalibr("", {}, TargetConfig{}, {}, nullptr), std::runtime_error);
}

}  // namespace
}  // namespace ctcal
