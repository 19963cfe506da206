#include "ctcal/sim/default_rig.h"

#include <Eigen/Geometry>
#include <cmath>

namespace ctcal::sim {
namespace {

Eigen::Matrix3d Exp(double x, double y, double z) {
  const Eigen::Vector3d phi(x, y, z);
  const double angle = phi.norm();
  if (angle == 0.0)
    return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, phi / angle).toRotationMatrix();
}

Eigen::Matrix4d Pose(const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = R;
  T.topRightCorner<3, 1>() = t;
  return T;
}

// Looking down along -z_B with image x along x_B: R_B_C = Rx(pi).
const Eigen::Matrix3d kLookingDown = Exp(M_PI, 0.0, 0.0);

}  // namespace

RigConfig DefaultRig() {
  RigConfig rig;
  rig.base_imu = "imu0";
  rig.gravity_magnitude = 9.81;
  rig.target = TargetConfig{};  // 6x6, 0.088 m, 0.3 (target_config.h defaults)
  rig.target.type = TargetType::kAprilGrid;
  rig.target.tag_cols = 6;
  rig.target.tag_rows = 6;
  rig.target.tag_size = 0.088;
  rig.target.tag_spacing = 0.3;

  // Stored forms (SPEC section 3): upper [d11, d12, d22, d13, d23, d33], full row-major.
  // Scale errors ~1e-2, non-orthogonality ~1e-3, g-sensitivity ~1e-3 (rad/s)/(m/s^2),
  // accelerometer-to-gyroscope rotation ~0.5 deg.
  SensorConfig imu0;
  imu0.name = "imu0";
  imu0.type = SensorType::kImu;
  imu0.imu_model = ImuModel::kImu2;
  imu0.g_sensitivity = GSensitivity::kFull;
  imu0.D_w = {1.012, 0.0011, 0.991, -0.0008, 0.0013, 1.007};
  imu0.D_a = {0.989, -0.0012, 1.011, 0.0009, 0.0007, 0.994};
  imu0.T_g = {0.0011, -0.0006, 0.0009, 0.0004, -0.0012, 0.0007, -0.0008, 0.0005, 0.0010};
  imu0.R_I_a = Exp(0.005, -0.004, 0.006);
  imu0.noise = EurocAdis16448Noise(250.0);
  imu0.estimate = {EstimateItem::kIntrinsics};
  rig.sensors.push_back(imu0);

  const std::set<EstimateItem> aux_estimate = {EstimateItem::kIntrinsics, EstimateItem::kExtrinsics,
                                               EstimateItem::kTimeOffset};

  SensorConfig imu1;
  imu1.name = "imu1";
  imu1.type = SensorType::kImu;
  imu1.imu_model = ImuModel::kImu2;
  imu1.g_sensitivity = GSensitivity::kFull;
  imu1.D_w = {0.993, -0.0014, 1.009, 0.0010, -0.0006, 1.013};
  imu1.D_a = {1.008, 0.0008, 0.992, -0.0011, 0.0012, 1.006};
  imu1.T_g = {-0.0009, 0.0007, 0.0004, -0.0010, 0.0008, -0.0005, 0.0006, -0.0011, 0.0009};
  imu1.R_I_a = Exp(-0.006, 0.004, 0.005);
  imu1.noise = EurocAdis16448Noise(300.0);
  imu1.T_B_S = Pose(Exp(0.02, -0.03, M_PI / 2), Eigen::Vector3d(0.06, -0.04, 0.02));
  imu1.time_offset = 0.004;
  imu1.estimate = aux_estimate;
  rig.sensors.push_back(imu1);

  SensorConfig gyro0;
  gyro0.name = "gyro0";
  gyro0.type = SensorType::kGyro;
  gyro0.gyro_model = GyroModel::kUpper;
  gyro0.D_w = {1.011, 0.0012, 0.988, 0.0009, -0.0013, 1.004};
  gyro0.noise = EurocAdis16448Noise(200.0);
  gyro0.noise.accelerometer_noise_density = 0.0;
  gyro0.noise.accelerometer_random_walk = 0.0;
  gyro0.T_B_S = Pose(Exp(M_PI / 2, 0.02, -0.01), Eigen::Vector3d(-0.05, 0.03, 0.01));
  gyro0.time_offset = -0.003;
  gyro0.estimate = aux_estimate;
  rig.sensors.push_back(gyro0);

  SensorConfig cam0;
  cam0.name = "cam0";
  cam0.type = SensorType::kCamera;
  cam0.camera_model = "pinhole";
  cam0.intrinsics = {458.654, 457.296, 367.215, 248.375};
  cam0.distortion_model = "radtan";
  cam0.distortion_coeffs = {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05};
  cam0.width = 752;
  cam0.height = 480;
  cam0.pixel_sigma = 1.0;
  cam0.T_B_S = Pose(kLookingDown * Exp(0.01, -0.02, 0.015), Eigen::Vector3d(0.03, 0.015, -0.02));
  cam0.time_offset = 0.006;
  cam0.estimate = aux_estimate;
  rig.sensors.push_back(cam0);

  SensorConfig cam1;
  cam1.name = "cam1";
  cam1.type = SensorType::kCamera;
  cam1.camera_model = "pinhole";
  cam1.intrinsics = {190.97847715128717, 190.9733070521226, 254.93170605935475, 256.8974428996504};
  cam1.distortion_model = "equidistant";
  cam1.distortion_coeffs = {0.0034823894022493434, 0.0007150348452162257, -0.0020532361418706202,
                            0.00020293673591811182};
  cam1.width = 512;
  cam1.height = 512;
  cam1.pixel_sigma = 1.0;
  cam1.T_B_S =
      Pose(kLookingDown * Exp(-0.015, 0.01, M_PI / 2 + 0.02), Eigen::Vector3d(-0.04, 0.02, -0.015));
  cam1.time_offset = -0.005;
  cam1.estimate = aux_estimate;
  rig.sensors.push_back(cam1);
  return rig;
}

}  // namespace ctcal::sim
