// The rig's rules (rig_yaml_rules.h) and its validation (ValidateRig): what a rig must satisfy
// before it is calibrated or written, whoever built it.
#include <Eigen/Dense>
#include <cctype>
#include <cmath>
#include <set>
#include <stdexcept>

#include "ctcal/sensors/mrcal_lens.h"
#include "ctcal/sensors/parameter_names.h"
#include "ctcal/sensors/rig_yaml.h"
#include "rig_yaml_rules.h"

namespace ctcal {

int IntrinsicsCount(const std::string& camera_model) {
  if (camera_model == "pinhole")
    return 4;
  if (camera_model == "omni")
    return 5;
  if (camera_model == "ds" || camera_model == "eucm")
    return 6;
  return -1;
}

int DistortionCount(const std::string& distortion_model) {
  if (distortion_model == "radtan" || distortion_model == "equidistant")
    return 4;
  if (distortion_model == "none")
    return 0;
  return -1;
}

namespace internal {

double SecondsFromNs(std::int64_t ns) {
  return static_cast<double>(ns) / 1e9;
}

std::int64_t NsFromSeconds(double s) {
  return static_cast<std::int64_t>(std::llround(s * 1e9));
}

std::string Where(const std::string& sensor) {
  return "sensors." + sensor;
}

bool ValidSensorName(const std::string& name) {
  if (name.empty())
    return false;
  for (const char c : name) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-')
      return false;
  }
  return true;
}

int DwCount(const SensorConfig& s) {
  if (s.type == SensorType::kGyro)
    return s.gyro_model == GyroModel::kFull ? 9 : (s.gyro_model == GyroModel::kUpper ? 6 : 0);
  if (s.imu_model == ImuModel::kNone)
    return 0;
  return s.imu_model == ImuModel::kImu3 ? 9 : 6;
}

int DaCount(const SensorConfig& s) {
  if (s.type != SensorType::kImu || s.imu_model == ImuModel::kNone)
    return 0;
  return s.imu_model == ImuModel::kImu4 ? 9 : 6;
}

int TgCount(const SensorConfig& s) {
  if (s.type != SensorType::kImu)
    return 0;
  return s.g_sensitivity == GSensitivity::kFull ? 9
                                                : (s.g_sensitivity == GSensitivity::kUpper ? 6 : 0);
}

const char* StoredForm(int count) {
  return count == 9 ? "9 numbers, full row-major" : "6 numbers, upper-triangular column-wise";
}

void ValidateRigAt(const RigConfig& rig, const std::string& context, const LineOf& line_of) {
  // `key` narrows the line to the key's own when the rig came from a file.
  auto fail = [&context, &line_of](const std::string& where, const std::string& what,
                                   const std::string& key = "") {
    const int line = line_of ? line_of(where, key) : 0;
    throw std::runtime_error(context + (line > 0 ? ":" + std::to_string(line) : "") + ": " +
                             (where.empty() ? "" : where + ": ") + what);
  };
  const SensorConfig* base = rig.Find(rig.base_imu);
  if (!base)
    fail("base_imu", "names no sensor: '" + rig.base_imu + "' is not under sensors");
  const bool camera_only = rig.IsCameraOnly();
  if (!camera_only && base->type != SensorType::kImu) {
    fail("base_imu", "'" + rig.base_imu + "' is a " + ToString(base->type) +
                         "; the base must be an imu (or the reference camera of a rig without "
                         "IMUs)");
  }
  if (camera_only && base->type != SensorType::kCamera) {
    fail("base_imu", "'" + rig.base_imu +
                         "' is a gyro; a rig without an imu is a camera calibration whose base "
                         "is the reference camera");
  }
  if (camera_only && (rig.gravity_W || rig.sigma_gravity_W))
    fail("gravity_W", "a rig without IMUs has no gravity (SPEC section 7)");
  std::set<std::string> names;
  for (const SensorConfig& s : rig.sensors) {
    const std::string where = Where(s.name);
    if (!names.insert(s.name).second)
      fail(where, "sensor name given twice");
    if (!ValidSensorName(s.name) || s.name == "groundtruth")
      fail(where, "not a valid sensor name: " + std::string(kNameRule));
    if (camera_only && s.type == SensorType::kGyro)
      fail(where, "a gyroscope needs an imu as the base (this rig has none)");
    const bool is_base = s.name == rig.base_imu;
    auto check_count = [&](const char* key, const std::vector<double>& v, int count) {
      if (static_cast<int>(v.size()) != count) {
        fail(where, std::string(key) + " has " + std::to_string(v.size()) +
                        " numbers, the model needs " + std::to_string(count));
      }
    };
    check_count("Dw", s.D_w, s.type == SensorType::kCamera ? 0 : DwCount(s));
    check_count("Da", s.D_a, DaCount(s));
    check_count("Tg", s.T_g, TgCount(s));
    if (s.type == SensorType::kCamera && s.camera_model == "mrcal") {
      // distortion_model holds mrcal's lens model name (rig_yaml_read.cpp, ReadMrcalLens).
      try {
        check_count("intrinsics", s.intrinsics,
                    MrcalLens::FromName(s.distortion_model)->NumParams());
      } catch (const std::invalid_argument& e) {
        fail(where, e.what());
      }
      check_count("distortion_coeffs", s.distortion_coeffs, 0);
      if (s.width <= 0 || s.height <= 0)
        fail(where, "resolution must be positive");
    } else if (s.type == SensorType::kCamera) {
      if (IntrinsicsCount(s.camera_model) < 0)
        fail(where, "unknown camera_model '" + s.camera_model + "'");
      if (DistortionCount(s.distortion_model) < 0)
        fail(where, "unknown distortion_model '" + s.distortion_model + "'");
      check_count("intrinsics", s.intrinsics, IntrinsicsCount(s.camera_model));
      check_count("distortion_coeffs", s.distortion_coeffs, DistortionCount(s.distortion_model));
      if (s.width <= 0 || s.height <= 0)
        fail(where, "resolution must be positive");
    }
    const Eigen::Matrix3d R = s.T_B_S.topLeftCorner<3, 3>();
    if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-6 || R.determinant() < 0 ||
        s.T_B_S.row(3) != Eigen::RowVector4d(0, 0, 0, 1)) {
      fail(where, "T_B_S is not a rigid transform", "T_B_S");
    }
    if (is_base && (s.T_B_S != Eigen::Matrix4d::Identity() || s.time_offset != 0.0))
      fail(where, "the base sensor has T_B_S = identity and time_offset = 0 by definition");
    // The estimate vocabulary against what the sensor has.
    if (is_base &&
        (s.Estimates(EstimateItem::kExtrinsics) || s.Estimates(EstimateItem::kTimeOffset))) {
      fail(where, "estimate: the base sensor has no extrinsics or time_offset to estimate",
           "estimate");
    }
    if (s.Estimates(EstimateItem::kLineDelay) && s.type != SensorType::kCamera)
      fail(where, "estimate: line_delay applies to cameras only", "estimate");
    if (camera_only && s.Estimates(EstimateItem::kTimeOffset)) {
      fail(where, "estimate: a rig without IMUs pairs frames by stamp and estimates no time_offset",
           "estimate");
    }
    if (s.Estimates(EstimateItem::kIntrinsics) && s.IsInertial() && DwCount(s) == 0) {
      fail(where, "estimate: model none has no intrinsics to estimate", "estimate");
    }
    if (s.type == SensorType::kGyro && s.gyro_model == GyroModel::kFull &&
        s.Estimates(EstimateItem::kIntrinsics) && s.Estimates(EstimateItem::kExtrinsics)) {
      fail(where,
           "estimate: a gyro with model full cannot estimate its rotation (extrinsics) together "
           "with its intrinsics: the full Dw absorbs the rotation",
           "estimate");
    }
  }
  for (const auto& [name, r] : rig.residuals) {
    if (!rig.Find(name))
      fail("residuals", "'" + name + "' names no sensor of the rig");
  }
}

}  // namespace internal

void ValidateRig(const RigConfig& rig, const std::string& context) {
  internal::ValidateRigAt(rig, context, nullptr);
}

}  // namespace ctcal
