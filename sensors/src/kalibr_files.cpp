#include "ctcal/sensors/kalibr_files.h"

#include <yaml-cpp/yaml.h>

#include <Eigen/Dense>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "ctcal/sensors/imu_intrinsics.h"
#include "ctcal/sensors/kalibr_imu_model.h"
#include "ctcal/sensors/number_format.h"
#include "ctcal/sensors/rig_yaml.h"
#include "export_helpers.h"
#include "rigid_inverse.h"

namespace ctcal {
namespace {

using internal::EmitMatrix;
using internal::EmitNumbers;
using internal::ImuIntrinsicsOf;
using internal::Inverse;
using internal::KalibrCameraModels;

// Kalibr's model of an IMU, written in our frame I. SPEC fixes the files' IMU frame to ours
// (`T_cam_imu = inverse(T_B_C)`), while Kalibr's canonical form (lower-triangular M's) lives in
// its frame i = R_i_I I. Kalibr's equations hold in any frame: with a_i = R_i_I a_I,
//   a_m = (M_a R_i_I) a_I,   w_m = M_g (C_gyro_i R_i_I) w_I + A (C_gyro_i R_i_I) a_I,
// so M_a and C_gyro_i absorb R_i_I and the files stay exact (M_a is then full, not triangular).
KalibrScaleMisalignment KalibrModelOf(const SensorConfig& s) {
  if (s.imu_model == ImuModel::kNone)
    return {};
  Eigen::Matrix3d R_i_I;
  KalibrScaleMisalignment k = ToKalibrScaleMisalignment(ImuIntrinsicsOf(s), &R_i_I);
  k.M_accel = k.M_accel * R_i_I;
  k.C_gyro_i = k.C_gyro_i * R_i_I;
  return k;
}

std::vector<const SensorConfig*> KalibrImus(const RigConfig& rig) {
  std::vector<const SensorConfig*> imus;
  if (!rig.IsCameraOnly())
    imus.push_back(&rig.Base());
  for (const SensorConfig& s : rig.sensors) {
    if (s.type == SensorType::kImu && s.name != rig.base_imu)
      imus.push_back(&s);
  }
  return imus;
}

void Save(const std::string& text, const std::string& path) {
  std::ofstream f(path);
  if (!f)
    throw std::runtime_error(path + ": cannot write file");
  f << text;
  if (!f)
    throw std::runtime_error(path + ": write failed");
}

}  // namespace

std::string EmitKalibrCamchain(const RigConfig& rig,
                               const std::vector<std::vector<int>>& cam_overlaps,
                               std::vector<std::string>* notes) {
  const std::vector<SensorConfig> cams =
      KalibrCameraModels(rig, rig.IsCameraOnly() ? "camchain.yaml" : "camchain-imucam.yaml", notes);
  const bool camera_only = rig.IsCameraOnly();
  YAML::Emitter out;
  out << YAML::BeginMap;
  for (std::size_t n = 0; n < cams.size(); ++n) {
    const SensorConfig& c = cams[n];
    out << YAML::Key << "cam" + std::to_string(n) << YAML::Value << YAML::BeginMap;
    if (!camera_only) {
      out << YAML::Key << "T_cam_imu" << YAML::Value;
      EmitMatrix(out, Inverse(c.T_B_S));
    }
    if (n > 0) {
      out << YAML::Key << "T_cn_cnm1" << YAML::Value;
      EmitMatrix(out, Inverse(c.T_B_S) * cams[n - 1].T_B_S);
    }
    out << YAML::Key << "cam_overlaps" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    if (n < cam_overlaps.size()) {
      for (int k : cam_overlaps[n])
        out << k;
    } else if (cam_overlaps.empty()) {
      for (std::size_t k = 0; k < cams.size(); ++k) {
        if (k != n)
          out << static_cast<int>(k);
      }
    }
    out << YAML::EndSeq;
    out << YAML::Key << "camera_model" << YAML::Value << c.camera_model;
    out << YAML::Key << "distortion_coeffs" << YAML::Value;
    EmitNumbers(out, c.distortion_coeffs);
    out << YAML::Key << "distortion_model" << YAML::Value << c.distortion_model;
    out << YAML::Key << "intrinsics" << YAML::Value;
    EmitNumbers(out, c.intrinsics);
    out << YAML::Key << "resolution" << YAML::Value << YAML::Flow << YAML::BeginSeq << c.width
        << c.height << YAML::EndSeq;
    out << YAML::Key << "rostopic" << YAML::Value
        << (c.rostopic ? *c.rostopic : "/" + c.name + "/image_raw");
    if (!camera_only)
      out << YAML::Key << "timeshift_cam_imu" << YAML::Value << FormatDouble(c.time_offset);
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

std::string EmitKalibrImu(const RigConfig& rig) {
  const std::vector<const SensorConfig*> imus = KalibrImus(rig);
  if (imus.empty())
    throw std::runtime_error("a camera-only rig has no imu.yaml");
  YAML::Emitter out;
  out << YAML::BeginMap;
  for (std::size_t k = 0; k < imus.size(); ++k) {
    const SensorConfig& s = *imus[k];
    const KalibrScaleMisalignment m = KalibrModelOf(s);
    const Eigen::Matrix4d T_B_S = s.name == rig.base_imu ? Eigen::Matrix4d::Identity() : s.T_B_S;
    const Eigen::Matrix4d T_i_b = Inverse(T_B_S);
    out << YAML::Key << "imu" + std::to_string(k) << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "T_i_b" << YAML::Value;
    EmitMatrix(out, T_i_b);
    out << YAML::Key << "accelerometer_noise_density" << YAML::Value
        << FormatDouble(s.noise.accelerometer_noise_density);
    out << YAML::Key << "accelerometer_random_walk" << YAML::Value
        << FormatDouble(s.noise.accelerometer_random_walk);
    out << YAML::Key << "gyroscope_noise_density" << YAML::Value
        << FormatDouble(s.noise.gyroscope_noise_density);
    out << YAML::Key << "gyroscope_random_walk" << YAML::Value
        << FormatDouble(s.noise.gyroscope_random_walk);
    if (s.imu_model == ImuModel::kNone) {
      out << YAML::Key << "model" << YAML::Value << "calibrated";
    } else {
      out << YAML::Key << "model" << YAML::Value << "scale-misalignment";
      out << YAML::Key << "gyroscopes" << YAML::Value << YAML::BeginMap;
      out << YAML::Key << "A" << YAML::Value;
      EmitMatrix(out, m.A_gyro);
      out << YAML::Key << "C_gyro_i" << YAML::Value;
      EmitMatrix(out, m.C_gyro_i);
      out << YAML::Key << "M" << YAML::Value;
      EmitMatrix(out, m.M_gyro);
      out << YAML::EndMap;
      out << YAML::Key << "accelerometers" << YAML::Value << YAML::BeginMap;
      out << YAML::Key << "M" << YAML::Value;
      EmitMatrix(out, m.M_accel);
      out << YAML::EndMap;
    }
    out << YAML::Key << "rostopic" << YAML::Value << (s.rostopic ? *s.rostopic : "/" + s.name);
    out << YAML::Key << "time_offset" << YAML::Value
        << FormatDouble(s.name == rig.base_imu ? 0.0 : s.time_offset);
    out << YAML::Key << "update_rate" << YAML::Value << FormatDouble(s.noise.update_rate);
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

std::vector<std::string> SaveKalibrFiles(const RigConfig& rig, const std::string& dir,
                                         const std::vector<std::vector<int>>& cam_overlaps,
                                         std::vector<std::string>* notes) {
  namespace fs = std::filesystem;
  std::vector<std::string> written;
  const bool camera_only = rig.IsCameraOnly();
  const std::string camchain =
      (fs::path(dir) / (camera_only ? "camchain.yaml" : "camchain-imucam.yaml")).string();
  Save(EmitKalibrCamchain(rig, cam_overlaps, notes), camchain);
  written.push_back(camchain);
  if (!camera_only) {
    const std::string imu = (fs::path(dir) / "imu.yaml").string();
    Save(EmitKalibrImu(rig), imu);
    written.push_back(imu);
  }
  return written;
}

}  // namespace ctcal
