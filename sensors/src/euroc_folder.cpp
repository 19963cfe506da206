// EuRoC / TUM-VI `mav0/` folders' sensor.yaml files as initial guesses (euroc_folder.h).
#include "ctcal/sensors/euroc_folder.h"

#include <yaml-cpp/yaml.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <stdexcept>

#include "ctcal/sensors/number_format.h"
#include "ctcal/sensors/rig_yaml.h"
#include "rigid_inverse.h"
#include "yaml_in.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;
using internal::Inverse;
using internal::YamlIn;

struct EurocSensor {
  SensorConfig config;
  Eigen::Matrix4d T_body_S = Eigen::Matrix4d::Identity();
};

// The folders with a sensor.yaml, in name order.
std::vector<fs::path> SensorYamls(const std::string& data_dir) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (const fs::directory_entry& e : fs::directory_iterator(data_dir, ec)) {
    if (e.is_directory() && fs::is_regular_file(e.path() / "sensor.yaml"))
      out.push_back(e.path() / "sensor.yaml");
  }
  std::sort(out.begin(), out.end());
  return out;
}

// One sensor.yaml; false for a sensor type ctcal does not calibrate.
bool ReadSensorYaml(const fs::path& path, EurocSensor* out) {
  const std::string file = path.string();
  const YamlIn in(file);
  const YAML::Node root = YamlIn::LoadFile(file);
  in.RequireMap(root, "");
  if (!root["sensor_type"])
    in.Fail(root, "", "missing required key 'sensor_type'");
  const std::string type = in.String(root["sensor_type"], "sensor_type");
  if (type != "camera" && type != "imu")
    return false;
  SensorConfig& s = out->config;
  s.name = path.parent_path().filename().string();
  if (root["T_BS"]) {
    const YAML::Node T = root["T_BS"];
    in.RequireMap(T, "T_BS");
    const std::vector<double> d = in.Vector(T["data"], "T_BS.data", 16);
    Eigen::Matrix4d M;
    for (int k = 0; k < 16; ++k)
      M(k / 4, k % 4) = d[k];
    // Re-read through the strict rigid-transform check (rotation, last row).
    YAML::Node rows;
    for (int r = 0; r < 4; ++r) {
      YAML::Node row;
      for (int c = 0; c < 4; ++c)
        row.push_back(FormatDouble(M(r, c)));
      rows.push_back(row);
    }
    out->T_body_S = in.Rigid(rows, "T_BS.data");
  }
  auto req = [&](const char* key) {
    if (!root[key])
      in.Fail(root, "", std::string("missing required key '") + key + "'");
    return root[key];
  };
  if (type == "imu") {
    s.type = SensorType::kImu;
    s.imu_model = ImuModel::kNone;
    s.g_sensitivity = GSensitivity::kNone;
    s.noise.gyroscope_noise_density =
        in.FiniteDouble(req("gyroscope_noise_density"), "gyroscope_noise_density");
    s.noise.gyroscope_random_walk =
        in.FiniteDouble(req("gyroscope_random_walk"), "gyroscope_random_walk");
    s.noise.accelerometer_noise_density =
        in.FiniteDouble(req("accelerometer_noise_density"), "accelerometer_noise_density");
    s.noise.accelerometer_random_walk =
        in.FiniteDouble(req("accelerometer_random_walk"), "accelerometer_random_walk");
    s.noise.update_rate = in.FiniteDouble(req("rate_hz"), "rate_hz");
    return true;
  }
  s.type = SensorType::kCamera;
  s.camera_model = in.String(req("camera_model"), "camera_model");
  s.intrinsics = in.Vector(req("intrinsics"), "intrinsics", -1);
  const std::string distortion = in.String(req("distortion_model"), "distortion_model");
  s.distortion_model = distortion == "radial-tangential" ? "radtan" : distortion;
  if (root["distortion_coefficients"])
    s.distortion_coeffs = in.Vector(root["distortion_coefficients"], "distortion_coefficients", -1);
  const std::vector<double> res = in.Vector(req("resolution"), "resolution", 2);
  s.width = static_cast<int>(res[0]);
  s.height = static_cast<int>(res[1]);
  s.estimate = {EstimateItem::kIntrinsics, EstimateItem::kExtrinsics, EstimateItem::kTimeOffset};
  return true;
}

std::vector<EurocSensor> ReadFolder(const std::string& data_dir) {
  std::vector<EurocSensor> sensors;
  for (const fs::path& path : SensorYamls(data_dir)) {
    EurocSensor s;
    if (ReadSensorYaml(path, &s))
      sensors.push_back(s);
  }
  return sensors;
}

double AngleDeg(const Eigen::Matrix3d& R) {
  return Eigen::AngleAxisd(R).angle() * 180.0 / M_PI;
}

}  // namespace

bool HasEurocSensorYamls(const std::string& data_dir) {
  for (const fs::path& path : SensorYamls(data_dir)) {
    EurocSensor s;
    try {
      if (ReadSensorYaml(path, &s))
        return true;
    } catch (const std::runtime_error&) {
      return true;  // a malformed one: the reader will name it
    }
  }
  return false;
}

RigConfig RigFromEurocFolder(const std::string& data_dir, const TargetConfig& target,
                             std::vector<std::string>* warnings) {
  const std::vector<EurocSensor> sensors = ReadFolder(data_dir);
  const auto base = std::find_if(sensors.begin(), sensors.end(), [](const EurocSensor& s) {
    return s.config.type == SensorType::kImu;
  });
  if (base == sensors.end())
    throw std::runtime_error(data_dir + ": no <sensor>/sensor.yaml of an IMU (sensor_type: imu)");
  RigConfig rig;
  rig.target = target;
  rig.base_imu = base->config.name;
  const Eigen::Matrix4d T_B_body = Inverse(base->T_body_S);
  for (const EurocSensor& e : sensors) {
    SensorConfig s = e.config;
    if (s.name != rig.base_imu) {
      s.T_B_S = T_B_body * e.T_body_S;
      s.estimate.insert(EstimateItem::kExtrinsics);
      s.estimate.insert(EstimateItem::kTimeOffset);
    }
    rig.sensors.push_back(s);
  }
  if (warnings && rig.sensors.size() == 1)
    warnings->push_back(data_dir + ": only " + rig.base_imu + " has a sensor.yaml");
  ValidateRig(rig, data_dir + " (sensor.yaml files)");
  return rig;
}

std::vector<std::string> CrossCheckEurocFolder(const std::string& data_dir, const RigConfig& rig) {
  std::vector<std::string> warnings;
  const std::vector<EurocSensor> sensors = ReadFolder(data_dir);
  const EurocSensor* base = nullptr;
  for (const EurocSensor& e : sensors) {
    if (e.config.name == rig.base_imu)
      base = &e;
  }
  for (const SensorConfig& s : rig.sensors) {
    const auto e = std::find_if(sensors.begin(), sensors.end(),
                                [&](const EurocSensor& x) { return x.config.name == s.name; });
    const std::string file = (fs::path(data_dir) / s.name / "sensor.yaml").string();
    if (e == sensors.end()) {
      warnings.push_back(data_dir + ": " + s.name + " has no sensor.yaml to cross-check");
      continue;
    }
    if (base && s.name != rig.base_imu) {
      const Eigen::Matrix4d T = Inverse(base->T_body_S) * e->T_body_S;
      const Eigen::Matrix4d E = Inverse(T) * s.T_B_S;
      const double deg = AngleDeg(E.topLeftCorner<3, 3>());
      const double m = (T.topRightCorner<3, 1>() - s.T_B_S.topRightCorner<3, 1>()).norm();
      if (deg > 2.0 || m > 0.02)
        warnings.push_back(file + ": T_BS disagrees with the rig's T_B_S of " + s.name + " by " +
                           FormatDouble(std::round(deg * 100) / 100) + " deg, " +
                           FormatDouble(std::round(m * 1e4) / 10) + " mm (the rig's is used)");
    }
    if (s.type == SensorType::kCamera && e->config.camera_model == s.camera_model &&
        e->config.intrinsics.size() == s.intrinsics.size()) {
      const std::size_t fu = s.intrinsics.size() - 4;
      for (std::size_t k = fu; k < s.intrinsics.size(); ++k) {
        const double a = s.intrinsics[k], b = e->config.intrinsics[k];
        if (std::abs(a - b) > 0.05 * std::abs(b)) {
          warnings.push_back(file + ": intrinsics[" + std::to_string(k) + "] " + FormatDouble(b) +
                             " disagrees with the rig's " + FormatDouble(a) + " of " + s.name +
                             " (the rig's is used)");
          break;
        }
      }
    }
  }
  return warnings;
}

}  // namespace ctcal
