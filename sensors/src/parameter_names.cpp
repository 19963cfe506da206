#include "ctcal/sensors/parameter_names.h"

#include <stdexcept>

#include "ctcal/spline/so3.h"

namespace ctcal {
namespace {

int StoredSize(GSensitivity g) {
  return g == GSensitivity::kFull ? 9 : (g == GSensitivity::kUpper ? 6 : 0);
}

ParameterKey Key(const std::string& key, int size, EstimateItem item, bool scalar = false,
                 bool rotation = false) {
  ParameterKey k;
  k.key = key;
  k.size = size;
  k.item = item;
  k.scalar = scalar;
  k.rotation = rotation;
  return k;
}

const SensorConfig& SensorOf(const RigConfig& rig, const ScalarParameter& p) {
  const SensorConfig* s = rig.Find(p.sensor);
  if (!s)
    throw std::invalid_argument("no sensor '" + p.sensor + "' for parameter " + p.name);
  return *s;
}

std::optional<double> FromBlock(const SigmaBlock& block, const ScalarParameter& p) {
  const std::vector<double>* v = block.Find(p.key);
  const std::size_t i = p.index < 0 ? 0 : static_cast<std::size_t>(p.index);
  if (!v || i >= v->size())
    return std::nullopt;
  return (*v)[i];
}

}  // namespace

std::vector<ParameterKey> SensorParameterKeys(const RigConfig& rig, const SensorConfig& s) {
  constexpr EstimateItem kIn = EstimateItem::kIntrinsics;
  std::vector<ParameterKey> keys;
  switch (s.type) {
    case SensorType::kImu:
      if (s.imu_model != ImuModel::kNone) {
        keys.push_back(Key("Dw", s.imu_model == ImuModel::kImu3 ? 9 : 6, kIn));
        keys.push_back(Key("Da", s.imu_model == ImuModel::kImu4 ? 9 : 6, kIn));
        if (s.g_sensitivity != GSensitivity::kNone)
          keys.push_back(Key("Tg", StoredSize(s.g_sensitivity), kIn));
        const std::string rot = RotationKey(s.imu_model);
        if (!rot.empty())
          keys.push_back(Key(rot, 3, kIn, false, true));
      }
      break;
    case SensorType::kGyro:
      if (s.gyro_model != GyroModel::kNone)
        keys.push_back(Key("Dw", s.gyro_model == GyroModel::kFull ? 9 : 6, kIn));
      break;
    case SensorType::kCamera:
      keys.push_back(Key("intrinsics", static_cast<int>(s.intrinsics.size()), kIn));
      if (!s.distortion_coeffs.empty()) {
        keys.push_back(Key("distortion_coeffs", static_cast<int>(s.distortion_coeffs.size()), kIn));
      }
      keys.push_back(Key("line_delay", 1, EstimateItem::kLineDelay, true));
      break;
  }
  if (s.name != rig.base_imu) {
    keys.push_back(Key("R_B_S", 3, EstimateItem::kExtrinsics, false, true));
    if (s.type != SensorType::kGyro)
      keys.push_back(Key("t_B_S", 3, EstimateItem::kExtrinsics));
    if (!rig.IsCameraOnly())
      keys.push_back(Key("time_offset", 1, EstimateItem::kTimeOffset, true));
  }
  return keys;
}

std::string ParameterName(const std::string& sensor, const std::string& key, int index) {
  std::string name = sensor.empty() ? key : sensor + "." + key;
  if (index >= 0)
    name += "[" + std::to_string(index) + "]";
  return name;
}

std::vector<ScalarParameter> ScalarParameters(const RigConfig& rig, bool estimated_only) {
  std::vector<ScalarParameter> out;
  auto add = [&out](const std::string& sensor, const std::string& key, int size, bool scalar,
                    bool rotation) {
    for (int i = 0; i < size; ++i) {
      ScalarParameter p;
      p.sensor = sensor;
      p.key = key;
      p.index = scalar ? -1 : i;
      p.rotation = rotation;
      p.name = ParameterName(sensor, key, p.index);
      out.push_back(p);
    }
  };
  for (const SensorConfig& s : rig.sensors) {
    for (const ParameterKey& k : SensorParameterKeys(rig, s)) {
      if (!estimated_only || s.Estimates(k.item))
        add(s.name, k.key, k.size, k.scalar, k.rotation);
    }
  }
  if (!rig.IsCameraOnly())
    add("", "gravity_W", 3, false, false);
  return out;
}

std::optional<ScalarParameter> FindParameter(const RigConfig& rig, const std::string& name) {
  for (const ScalarParameter& p : ScalarParameters(rig, false)) {
    if (p.name == name)
      return p;
  }
  return std::nullopt;
}

Eigen::Matrix3d ParameterRotation(const RigConfig& rig, const ScalarParameter& p) {
  const SensorConfig& s = SensorOf(rig, p);
  if (p.key == "R_B_S")
    return s.T_B_S.topLeftCorner<3, 3>();
  if (p.key == "R_I_a")
    return s.R_I_a;
  if (p.key == "R_I_w")
    return s.R_I_w;
  throw std::invalid_argument(p.name + " is not a rotation parameter");
}

double ParameterValue(const RigConfig& rig, const ScalarParameter& p) {
  const std::size_t i = p.index < 0 ? 0 : static_cast<std::size_t>(p.index);
  if (p.sensor.empty()) {
    if (p.key != "gravity_W" || i > 2)
      throw std::invalid_argument("no parameter " + p.name);
    if (!rig.gravity_W)
      throw std::invalid_argument("the file has no gravity_W");
    return (*rig.gravity_W)(static_cast<Eigen::Index>(i));
  }
  if (p.rotation) {
    const Eigen::Quaterniond q(ParameterRotation(rig, p));
    return LogSO3<double>(q)(static_cast<Eigen::Index>(i));
  }
  const SensorConfig& s = SensorOf(rig, p);
  auto at = [&](const std::vector<double>& v) {
    if (i >= v.size())
      throw std::invalid_argument("no parameter " + p.name);
    return v[i];
  };
  if (p.key == "Dw")
    return at(s.D_w);
  if (p.key == "Da")
    return at(s.D_a);
  if (p.key == "Tg")
    return at(s.T_g);
  if (p.key == "intrinsics")
    return at(s.intrinsics);
  if (p.key == "distortion_coeffs")
    return at(s.distortion_coeffs);
  if (p.key == "line_delay")
    return s.line_delay;
  if (p.key == "time_offset")
    return s.time_offset;
  if (p.key == "t_B_S" && i < 3)
    return s.T_B_S(static_cast<Eigen::Index>(i), 3);
  throw std::invalid_argument("no parameter " + p.name);
}

std::optional<double> ParameterSigma(const RigConfig& rig, const ScalarParameter& p) {
  if (p.sensor.empty()) {
    if (p.key == "gravity_W" && rig.sigma_gravity_W && p.index >= 0 && p.index < 3)
      return (*rig.sigma_gravity_W)(p.index);
    return std::nullopt;
  }
  return FromBlock(SensorOf(rig, p).sigma, p);
}

std::optional<double> ParameterPriorSigma(const RigConfig& rig, const ScalarParameter& p) {
  if (p.sensor.empty())
    return std::nullopt;
  return FromBlock(SensorOf(rig, p).prior_sigma, p);
}

}  // namespace ctcal
