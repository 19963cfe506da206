// EuRoC / TUM-VI `mav0/` folders (euroc_folder.h): the sensor.yaml files as EuRoC writes them
// (its cam0 and imu0 values, written here as a test fixture) give the initial guesses, relative
// to the base IMU, and disagree with a rig file only with a warning.
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>

#include "ctcal/sensors/euroc_folder.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;

// EuRoC's cam0/sensor.yaml (MAV dataset, VI-Sensor cam0).
constexpr char kCam0[] = R"(# General sensor definitions.
sensor_type: camera
comment: VI-Sensor cam0 (MT9M034)

# Sensor extrinsics wrt. the body-frame.
T_BS:
  cols: 4
  rows: 4
  data: [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,
         0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,
        -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,
         0.0, 0.0, 0.0, 1.0]

# Camera specific definitions.
rate_hz: 20
resolution: [752, 480]
camera_model: pinhole
intrinsics: [458.654, 457.296, 367.215, 248.375] #fu, fv, cu, cv
distortion_model: radial-tangential
distortion_coefficients: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]
)";

// An IMU whose T_BS is not the identity (the body frame is not the IMU's), to check that the
// guesses are relative to the base IMU.
constexpr char kImu0[] = R"(#Default imu sensor yaml file
sensor_type: imu
comment: VI-Sensor IMU (ADIS16448)

# Sensor extrinsics wrt. the body-frame.
T_BS:
  cols: 4
  rows: 4
  data: [0.0, -1.0, 0.0, 0.1,
         1.0, 0.0, 0.0, 0.0,
         0.0, 0.0, 1.0, 0.0,
         0.0, 0.0, 0.0, 1.0]
rate_hz: 200

# inertial sensor noise model parameters (static)
gyroscope_noise_density: 1.6968e-04     # [ rad / s / sqrt(Hz) ]   ( gyro "white noise" )
gyroscope_random_walk: 1.9393e-05       # [ rad / s^2 / sqrt(Hz) ] ( gyro bias diffusion )
accelerometer_noise_density: 2.0000e-3  # [ m / s^2 / sqrt(Hz) ]  ( accel "white noise" )
accelerometer_random_walk: 3.0000e-3    # [ m / s^3 / sqrt(Hz) ].  ( accel bias diffusion )
)";

constexpr char kLeica[] = R"(sensor_type: position
comment: position measurement from a leica laser tracker
T_BS:
  cols: 4
  rows: 4
  data: [1.0, 0.0, 0.0, 7.48903e-02, 0.0, 1.0, 0.0, -1.84772e-02, 0.0, 0.0, 1.0, -1.20209e-01,
         0.0, 0.0, 0.0, 1.0]
)";

std::string Mav0(const std::string& name) {
  const fs::path dir =
      fs::path(::testing::TempDir()) / ("ctcal_mav0_" + name + "_" + std::to_string(getpid()));
  for (const char* s : {"cam0", "imu0", "leica0"})
    fs::create_directories(dir / s);
  std::ofstream(dir / "cam0" / "sensor.yaml") << kCam0;
  std::ofstream(dir / "imu0" / "sensor.yaml") << kImu0;
  std::ofstream(dir / "leica0" / "sensor.yaml") << kLeica;
  return dir.string();
}

Eigen::Matrix4d EurocCam0() {
  Eigen::Matrix4d T;
  T << 0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975, 0.999557249008,
      0.0149672133247, 0.025715529948, -0.064676986768, -0.0257744366974, 0.00375618835797,
      0.999660727178, 0.00981073058949, 0, 0, 0, 1;
  return T;
}

TEST(EurocFolder, SensorYamlsGiveTheGuessesRelativeToTheBaseImu) {
  const std::string dir = Mav0("guess");
  ASSERT_TRUE(HasEurocSensorYamls(dir));
  std::vector<std::string> warnings;
  const RigConfig rig = RigFromEurocFolder(dir, TargetConfig{}, &warnings);
  ASSERT_EQ(rig.sensors.size(), 2u);  // leica0 is not a sensor ctcal calibrates
  EXPECT_EQ(rig.base_imu, "imu0");
  const SensorConfig& imu = rig.Base();
  EXPECT_EQ(imu.imu_model, ImuModel::kNone);
  EXPECT_EQ(imu.noise.gyroscope_noise_density, 1.6968e-04);
  EXPECT_EQ(imu.noise.update_rate, 200.0);
  const SensorConfig& cam = *rig.Find("cam0");
  EXPECT_EQ(cam.distortion_model, "radtan");  // EuRoC's radial-tangential
  EXPECT_EQ(cam.intrinsics, (std::vector<double>{458.654, 457.296, 367.215, 248.375}));
  EXPECT_EQ(cam.distortion_coeffs.size(), 4u);
  EXPECT_EQ(cam.width, 752);
  Eigen::Matrix4d T_body_imu = Eigen::Matrix4d::Identity();
  T_body_imu.topLeftCorner<3, 3>() << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  T_body_imu(0, 3) = 0.1;
  EXPECT_TRUE(cam.T_B_S.isApprox(T_body_imu.inverse() * EurocCam0(), 1e-9)) << cam.T_B_S;
  EXPECT_TRUE(cam.Estimates(EstimateItem::kIntrinsics));
  EXPECT_TRUE(cam.Estimates(EstimateItem::kTimeOffset));
}

TEST(EurocFolder, ARigThatDisagreesIsUsedWithAWarning) {
  const std::string dir = Mav0("check");
  std::vector<std::string> warnings;
  RigConfig rig = RigFromEurocFolder(dir, TargetConfig{}, &warnings);
  EXPECT_TRUE(CrossCheckEurocFolder(dir, rig).empty());
  SensorConfig& cam = *rig.Find("cam0");
  cam.T_B_S(1, 3) += 0.05;  // 5 cm off
  cam.intrinsics[0] *= 1.1;
  const std::vector<std::string> w = CrossCheckEurocFolder(dir, rig);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_NE(w[0].find("cam0/sensor.yaml: T_BS disagrees"), std::string::npos) << w[0];
  EXPECT_NE(w[0].find("50.0 mm"), std::string::npos) << w[0];
  EXPECT_NE(w[1].find("intrinsics[0] 458.654 disagrees"), std::string::npos) << w[1];
}

TEST(EurocFolder, BadSensorYamlNamesTheFileAndLine) {
  const std::string dir = Mav0("bad");
  std::ofstream(fs::path(dir) / "cam0" / "sensor.yaml") << "sensor_type: camera\nrate_hz: 20\n";
  try {
    RigFromEurocFolder(dir, TargetConfig{}, nullptr);
    ADD_FAILURE() << "a camera without its model was accepted";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("cam0/sensor.yaml:1"), std::string::npos) << what;
    EXPECT_NE(what.find("missing required key 'camera_model'"), std::string::npos) << what;
  }
  fs::remove(fs::path(dir) / "imu0" / "sensor.yaml");
  fs::remove(fs::path(dir) / "cam0" / "sensor.yaml");
  EXPECT_FALSE(HasEurocSensorYamls(dir));
}

}  // namespace
}  // namespace ctcal
