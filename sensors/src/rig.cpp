#include "ctcal/sensors/rig.h"

#include <cmath>
#include <stdexcept>

namespace ctcal {

EstimateItem ParseEstimateItem(const std::string& s) {
  if (s == "intrinsics")
    return EstimateItem::kIntrinsics;
  if (s == "extrinsics")
    return EstimateItem::kExtrinsics;
  if (s == "time_offset")
    return EstimateItem::kTimeOffset;
  if (s == "line_delay")
    return EstimateItem::kLineDelay;
  throw std::invalid_argument("unknown estimate item '" + s +
                              "' (expected intrinsics, extrinsics, time_offset or line_delay)");
}

std::string ToString(EstimateItem e) {
  switch (e) {
    case EstimateItem::kIntrinsics:
      return "intrinsics";
    case EstimateItem::kExtrinsics:
      return "extrinsics";
    case EstimateItem::kTimeOffset:
      return "time_offset";
    case EstimateItem::kLineDelay:
      return "line_delay";
  }
  return "?";
}

const SensorConfig* RigConfig::Find(const std::string& name) const {
  for (const SensorConfig& s : sensors) {
    if (s.name == name)
      return &s;
  }
  return nullptr;
}

SensorConfig* RigConfig::Find(const std::string& name) {
  for (SensorConfig& s : sensors) {
    if (s.name == name)
      return &s;
  }
  return nullptr;
}

const SensorConfig& RigConfig::Base() const {
  const SensorConfig* base = Find(base_imu);
  if (!base)
    throw std::logic_error("base_imu '" + base_imu + "' names no sensor of the rig");
  return *base;
}

bool RigConfig::IsCameraOnly() const {
  for (const SensorConfig& s : sensors) {
    if (s.type == SensorType::kImu)
      return false;
  }
  return true;
}

std::vector<double> IdentityStored(std::size_t count) {
  if (count == 6)
    return {1, 0, 1, 0, 0, 1};
  if (count == 9)
    return {1, 0, 0, 0, 1, 0, 0, 0, 1};
  throw std::invalid_argument("a stored matrix has 6 (upper) or 9 (full) numbers");
}

namespace {

bool Same(double a, double b) {
  return a == b || (std::isnan(a) && std::isnan(b));
}

bool Same(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size())
    return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (!Same(a[i], b[i]))
      return false;
  }
  return true;
}

template <typename Derived>
bool Same(const Eigen::MatrixBase<Derived>& a, const Eigen::MatrixBase<Derived>& b) {
  for (Eigen::Index i = 0; i < a.size(); ++i) {
    if (!Same(a(i), b(i)))
      return false;
  }
  return true;
}

bool Same(const std::optional<double>& a, const std::optional<double>& b) {
  if (a.has_value() != b.has_value())
    return false;
  return !a || Same(*a, *b);
}

bool Same(const std::optional<Eigen::Vector3d>& a, const std::optional<Eigen::Vector3d>& b) {
  if (a.has_value() != b.has_value())
    return false;
  return !a || Same(*a, *b);
}

bool SameTarget(const TargetConfig& a, const TargetConfig& b) {
  if (a.type != b.type)
    return false;
  if (a.type == TargetType::kAprilGrid) {
    return a.tag_cols == b.tag_cols && a.tag_rows == b.tag_rows && a.tag_size == b.tag_size &&
           a.tag_spacing == b.tag_spacing && a.black_tag_border == b.black_tag_border;
  }
  if (a.type == TargetType::kCharuco) {
    return a.squares_x == b.squares_x && a.squares_y == b.squares_y &&
           a.square_length_m == b.square_length_m && a.marker_length_m == b.marker_length_m &&
           a.dictionary == b.dictionary;
  }
  return a.target_cols == b.target_cols && a.target_rows == b.target_rows &&
         a.row_spacing_m == b.row_spacing_m && a.col_spacing_m == b.col_spacing_m;
}

bool SameNoise(const InertialNoise& a, const InertialNoise& b) {
  return Same(a.gyroscope_noise_density, b.gyroscope_noise_density) &&
         Same(a.gyroscope_random_walk, b.gyroscope_random_walk) &&
         Same(a.accelerometer_noise_density, b.accelerometer_noise_density) &&
         Same(a.accelerometer_random_walk, b.accelerometer_random_walk) &&
         Same(a.update_rate, b.update_rate);
}

}  // namespace

bool operator==(const SigmaBlock& a, const SigmaBlock& b) {
  if (a.values.size() != b.values.size())
    return false;
  for (const auto& [key, v] : a.values) {
    const std::vector<double>* w = b.Find(key);
    if (!w || !Same(v, *w))
      return false;
  }
  return true;
}

bool operator==(const SensorConfig& a, const SensorConfig& b) {
  return a.name == b.name && a.type == b.type && a.imu_model == b.imu_model &&
         a.g_sensitivity == b.g_sensitivity && a.gyro_model == b.gyro_model && Same(a.D_w, b.D_w) &&
         Same(a.D_a, b.D_a) && Same(a.T_g, b.T_g) && Same(a.R_I_w, b.R_I_w) &&
         Same(a.R_I_a, b.R_I_a) && SameNoise(a.noise, b.noise) &&
         a.camera_model == b.camera_model && Same(a.intrinsics, b.intrinsics) &&
         a.distortion_model == b.distortion_model &&
         Same(a.distortion_coeffs, b.distortion_coeffs) && a.width == b.width &&
         a.height == b.height && Same(a.line_delay, b.line_delay) &&
         Same(a.pixel_sigma, b.pixel_sigma) && Same(a.T_B_S, b.T_B_S) &&
         Same(a.time_offset, b.time_offset) && a.estimate == b.estimate &&
         a.prior_sigma == b.prior_sigma && a.sigma == b.sigma && a.sigma_formal == b.sigma_formal &&
         a.rostopic == b.rostopic &&
         a.noise_estimated.has_value() == b.noise_estimated.has_value() &&
         (!a.noise_estimated || SameNoise(*a.noise_estimated, *b.noise_estimated)) &&
         Same(a.pixel_sigma_estimated, b.pixel_sigma_estimated);
}

bool operator==(const SolverSummary& a, const SolverSummary& b) {
  return a.method == b.method && a.iterations == b.iterations && Same(a.final_cost, b.final_cost) &&
         Same(a.seconds, b.seconds);
}

bool operator==(const SensorResiduals& a, const SensorResiduals& b) {
  return a.count == b.count && Same(a.rms_px, b.rms_px) && Same(a.rms_gyro, b.rms_gyro) &&
         Same(a.rms_accel, b.rms_accel) && Same(a.rms_whitened, b.rms_whitened) &&
         Same(a.rms_whitened_gyro, b.rms_whitened_gyro) &&
         Same(a.rms_whitened_accel, b.rms_whitened_accel);
}

bool operator==(const Observability& a, const Observability& b) {
  if (a.unobservable != b.unobservable || a.weak != b.weak ||
      a.predicted_unobservable != b.predicted_unobservable ||
      a.directions.size() != b.directions.size() || a.motion.size() != b.motion.size()) {
    return false;
  }
  for (std::size_t i = 0; i < a.directions.size(); ++i) {
    const ObservabilityDirection& da = a.directions[i];
    const ObservabilityDirection& db = b.directions[i];
    if (!Same(da.eigenvalue, db.eigenvalue) || da.parameters.size() != db.parameters.size())
      return false;
    for (std::size_t j = 0; j < da.parameters.size(); ++j) {
      if (da.parameters[j].name != db.parameters[j].name ||
          !Same(da.parameters[j].loading, db.parameters[j].loading)) {
        return false;
      }
    }
  }
  for (std::size_t i = 0; i < a.motion.size(); ++i) {
    const MotionPrimitive& ma = a.motion[i];
    const MotionPrimitive& mb = b.motion[i];
    if (ma.primitive != mb.primitive || ma.sensor != mb.sensor || !Same(ma.axis, mb.axis) ||
        !Same(ma.t0, mb.t0) || !Same(ma.t1, mb.t1)) {
      return false;
    }
  }
  return true;
}

bool operator==(const RigConfig& a, const RigConfig& b) {
  if (a.base_imu != b.base_imu || !Same(a.gravity_magnitude, b.gravity_magnitude) ||
      !SameTarget(a.target, b.target) || !(a.sensors == b.sensors) ||
      !Same(a.gravity_W, b.gravity_W) || !Same(a.sigma_gravity_W, b.sigma_gravity_W) ||
      !(a.solver == b.solver) || !(a.residuals == b.residuals) ||
      a.observability.has_value() != b.observability.has_value()) {
    return false;
  }
  return !a.observability || *a.observability == *b.observability;
}

}  // namespace ctcal
