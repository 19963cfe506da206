// OpenVINS's kalibr_imucam_chain.yaml and kalibr_imu_chain.yaml from a result, and the writer of
// every export (ecosystem_exports.h has the mapping and its frames).
#include <yaml-cpp/yaml.h>

#include <Eigen/Dense>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "ctcal/sensors/ecosystem_exports.h"
#include "ctcal/sensors/mrcal_model.h"
#include "ctcal/sensors/number_format.h"
#include "export_helpers.h"

namespace ctcal {
namespace {

using internal::EmitMatrix;
using internal::EmitNumbers;
using internal::ImuIntrinsicsOf;
using internal::KalibrCameraModels;

// M = R U with R a rotation and U upper-triangular with a positive diagonal (M invertible, det >
// 0): Householder QR with the signs fixed.
void QrDecomposition(const Eigen::Matrix3d& M, Eigen::Matrix3d* R, Eigen::Matrix3d* U) {
  const Eigen::HouseholderQR<Eigen::Matrix3d> qr(M);
  const Eigen::Matrix3d Q = qr.householderQ();
  const Eigen::Matrix3d T = qr.matrixQR().triangularView<Eigen::Upper>();
  const Eigen::Vector3d sign = T.diagonal().array().sign().matrix();
  *R = Q * sign.asDiagonal();
  *U = sign.asDiagonal() * T;
}

// OpenCV's FileStorage (OpenVINS's parser) wants its own directive on the first line.
std::string WithOpenCvHeader(const YAML::Emitter& out) {
  return "%YAML:1.0\n\n" + std::string(out.c_str()) + "\n";
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

std::optional<std::string> EmitOpenVinsImucamChain(const RigConfig& rig, std::string* why,
                                                   std::vector<std::string>* notes) {
  if (rig.IsCameraOnly()) {
    if (why)
      *why = "OpenVINS needs an IMU (this rig is camera-only)";
    return std::nullopt;
  }
  const std::vector<SensorConfig> cams = KalibrCameraModels(rig, "kalibr_imucam_chain.yaml", notes);
  YAML::Emitter out;
  out << YAML::BeginMap;
  for (std::size_t n = 0; n < cams.size(); ++n) {
    const SensorConfig& c = cams[n];
    std::string distortion = c.distortion_model;
    std::vector<double> coeffs = c.distortion_coeffs;
    if (c.camera_model != "pinhole" || distortion == "none") {
      if (c.camera_model != "pinhole") {
        if (why)
          *why = "OpenVINS has no " + c.camera_model + " camera (" + c.name + ")";
        return std::nullopt;
      }
      distortion = "radtan";  // the identity of OpenVINS's radtan model
      coeffs = {0.0, 0.0, 0.0, 0.0};
    }
    out << YAML::Key << "cam" + std::to_string(n) << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "T_imu_cam" << YAML::Value;
    EmitMatrix(out, c.T_B_S);
    out << YAML::Key << "cam_overlaps" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (std::size_t k = 0; k < cams.size(); ++k) {
      if (k != n)
        out << static_cast<int>(k);
    }
    out << YAML::EndSeq;
    out << YAML::Key << "camera_model" << YAML::Value << "pinhole";
    out << YAML::Key << "distortion_coeffs" << YAML::Value;
    EmitNumbers(out, coeffs);
    out << YAML::Key << "distortion_model" << YAML::Value << distortion;
    out << YAML::Key << "intrinsics" << YAML::Value;
    EmitNumbers(out, c.intrinsics);
    out << YAML::Key << "resolution" << YAML::Value << YAML::Flow << YAML::BeginSeq << c.width
        << c.height << YAML::EndSeq;
    out << YAML::Key << "rostopic" << YAML::Value
        << (c.rostopic ? *c.rostopic : "/" + c.name + "/image_raw");
    out << YAML::Key << "timeshift_cam_imu" << YAML::Value << FormatDouble(c.time_offset);
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
  return WithOpenCvHeader(out);
}

std::optional<std::string> EmitOpenVinsImuChain(const RigConfig& rig, std::string* why,
                                                std::vector<std::string>* notes) {
  if (rig.IsCameraOnly()) {
    if (why)
      *why = "OpenVINS needs an IMU (this rig is camera-only)";
    return std::nullopt;
  }
  const SensorConfig& imu = rig.Base();
  const ImuIntrinsics in = ImuIntrinsicsOf(imu);
  Eigen::Matrix3d R_GYROtoIMU, Dw, R_ACCtoIMU, Da;
  QrDecomposition(in.R_I_w() * in.D_w(), &R_GYROtoIMU, &Dw);
  QrDecomposition(in.R_I_a() * in.D_a(), &R_ACCtoIMU, &Da);
  YAML::Emitter out;
  out << YAML::BeginMap << YAML::Key << "imu0" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "T_i_b" << YAML::Value;
  EmitMatrix(out, Eigen::Matrix4d::Identity());
  out << YAML::Key << "accelerometer_noise_density" << YAML::Value
      << FormatDouble(imu.noise.accelerometer_noise_density);
  out << YAML::Key << "accelerometer_random_walk" << YAML::Value
      << FormatDouble(imu.noise.accelerometer_random_walk);
  out << YAML::Key << "gyroscope_noise_density" << YAML::Value
      << FormatDouble(imu.noise.gyroscope_noise_density);
  out << YAML::Key << "gyroscope_random_walk" << YAML::Value
      << FormatDouble(imu.noise.gyroscope_random_walk);
  out << YAML::Key << "model" << YAML::Value
      << (imu.imu_model == ImuModel::kNone ? "calibrated" : "rpng");
  out << YAML::Key << "rostopic" << YAML::Value << (imu.rostopic ? *imu.rostopic : "/" + imu.name);
  out << YAML::Key << "time_offset" << YAML::Value << FormatDouble(0.0);
  out << YAML::Key << "update_rate" << YAML::Value << FormatDouble(imu.noise.update_rate);
  out << YAML::Key << "Tw" << YAML::Value;
  EmitMatrix(out, Dw.inverse());
  out << YAML::Key << "R_IMUtoGYRO" << YAML::Value;
  EmitMatrix(out, R_GYROtoIMU.transpose());
  out << YAML::Key << "Ta" << YAML::Value;
  EmitMatrix(out, Da.inverse());
  out << YAML::Key << "R_IMUtoACC" << YAML::Value;
  EmitMatrix(out, R_ACCtoIMU.transpose());
  out << YAML::Key << "Tg" << YAML::Value;
  EmitMatrix(out, in.T_g());
  out << YAML::EndMap << YAML::EndMap;
  if (notes) {
    for (const SensorConfig& s : rig.sensors) {
      if (s.IsInertial() && s.name != rig.base_imu)
        notes->push_back("kalibr_imu_chain.yaml: OpenVINS reads one IMU: " + s.name +
                         " is left out");
    }
  }
  return WithOpenCvHeader(out);
}

std::vector<std::string> SaveEcosystemExports(const RigConfig& rig, const std::string& dir,
                                              std::vector<std::string>* notes) {
  namespace fs = std::filesystem;
  std::vector<std::string> written;
  std::string why;
  auto save = [&](const std::optional<std::string>& text, const std::string& name) {
    if (!text) {
      if (notes)
        notes->push_back(name + " not written: " + why);
      return;
    }
    const std::string path = (fs::path(dir) / name).string();
    Save(*text, path);
    written.push_back(path);
  };
  save(EmitBasaltCalibration(rig, &why, notes), "calibration.json");
  if (notes && !rig.IsCameraOnly()) {
    for (const SensorConfig& s : rig.sensors) {
      if (s.IsInertial() && s.name != rig.base_imu)
        notes->push_back("calibration.json: basalt has one IMU: " + s.name + " is left out");
    }
  }
  save(EmitOpenVinsImucamChain(rig, &why, notes), "kalibr_imucam_chain.yaml");
  save(EmitOpenVinsImuChain(rig, &why, notes), "kalibr_imu_chain.yaml");
  for (const std::string& path : SaveMrcalCameraModels(rig, dir, notes))
    written.push_back(path);
  return written;
}

}  // namespace ctcal
