// The rig file's writer (SPEC section 7): numbers written so that they read back to the bit.
#include <yaml-cpp/yaml.h>

#include <Eigen/Dense>
#include <cstdint>
#include <fstream>
#include <stdexcept>

#include "ctcal/sensors/number_format.h"
#include "ctcal/sensors/parameter_names.h"
#include "ctcal/sensors/rig_yaml.h"
#include "rig_yaml_rules.h"

namespace ctcal {

using namespace internal;  // NOLINT(build/namespaces): rig_yaml_rules.h

namespace {

void EmitNumbers(YAML::Emitter& out, const std::vector<double>& v) {
  out << YAML::Flow << YAML::BeginSeq;
  for (double x : v)
    out << FormatDouble(x);
  out << YAML::EndSeq;
}

template <typename Derived>
void EmitMatrix(YAML::Emitter& out, const Eigen::MatrixBase<Derived>& m) {
  out << YAML::Flow << YAML::BeginSeq;
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    out << YAML::Flow << YAML::BeginSeq;
    for (Eigen::Index c = 0; c < m.cols(); ++c)
      out << FormatDouble(m(r, c));
    out << YAML::EndSeq;
  }
  out << YAML::EndSeq;
}

void EmitVector3(YAML::Emitter& out, const Eigen::Vector3d& v) {
  EmitNumbers(out, {v.x(), v.y(), v.z()});
}

void EmitSigma(YAML::Emitter& out, const RigConfig& rig, const SensorConfig& s,
               const SigmaBlock& block) {
  out << YAML::BeginMap;
  for (const ParameterKey& k : SensorParameterKeys(rig, s)) {
    const std::vector<double>* v = block.Find(k.key);
    if (!v)
      continue;
    out << YAML::Key << k.key << YAML::Value;
    if (k.scalar)
      out << FormatDouble(v->front());
    else
      EmitNumbers(out, *v);
  }
  out << YAML::EndMap;
}

// `key: {...}` with the noise keys of the sensor's type (SPEC section 7).
void EmitNoise(YAML::Emitter& out, const char* key, SensorType type, double pixel_sigma,
               const InertialNoise& noise) {
  out << YAML::Key << key << YAML::Value << YAML::Flow << YAML::BeginMap;
  if (type == SensorType::kCamera) {
    out << YAML::Key << "pixel_sigma" << YAML::Value << FormatDouble(pixel_sigma);
  } else {
    out << YAML::Key << "gyroscope_noise_density" << YAML::Value
        << FormatDouble(noise.gyroscope_noise_density);
    out << YAML::Key << "gyroscope_random_walk" << YAML::Value
        << FormatDouble(noise.gyroscope_random_walk);
    if (type == SensorType::kImu) {
      out << YAML::Key << "accelerometer_noise_density" << YAML::Value
          << FormatDouble(noise.accelerometer_noise_density);
      out << YAML::Key << "accelerometer_random_walk" << YAML::Value
          << FormatDouble(noise.accelerometer_random_walk);
    }
    out << YAML::Key << "update_rate" << YAML::Value << FormatDouble(noise.update_rate);
  }
  out << YAML::EndMap;
}

void EmitSensor(YAML::Emitter& out, const RigConfig& rig, const SensorConfig& s) {
  const bool is_base = s.name == rig.base_imu;
  out << YAML::Key << s.name << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "type" << YAML::Value << ToString(s.type);
  if (s.type == SensorType::kImu) {
    out << YAML::Key << "model" << YAML::Value << ToString(s.imu_model);
    out << YAML::Key << "g_sensitivity" << YAML::Value << ToString(s.g_sensitivity);
  } else if (s.type == SensorType::kGyro) {
    out << YAML::Key << "model" << YAML::Value << ToString(s.gyro_model);
  }
  if (!s.D_w.empty()) {
    out << YAML::Key << "Dw" << YAML::Value;
    EmitNumbers(out, s.D_w);
  }
  if (!s.D_a.empty()) {
    out << YAML::Key << "Da" << YAML::Value;
    EmitNumbers(out, s.D_a);
  }
  if (!s.T_g.empty()) {
    out << YAML::Key << "Tg" << YAML::Value;
    EmitNumbers(out, s.T_g);
  }
  if (s.type == SensorType::kImu) {
    const std::string rot = RotationKey(s.imu_model);
    if (!rot.empty()) {
      out << YAML::Key << rot << YAML::Value;
      EmitMatrix(out, rot == "R_I_a" ? s.R_I_a : s.R_I_w);
    }
  }
  if (s.type == SensorType::kCamera) {
    out << YAML::Key << "camera_model" << YAML::Value << s.camera_model;
    // camera_model mrcal: distortion_model holds mrcal's lens model name (`lensmodel:`) and the
    // intrinsics are all of mrcal's parameters.
    const bool mrcal = s.camera_model == "mrcal";
    if (mrcal)
      out << YAML::Key << "lensmodel" << YAML::Value << s.distortion_model;
    out << YAML::Key << "intrinsics" << YAML::Value;
    EmitNumbers(out, s.intrinsics);
    if (!mrcal) {
      out << YAML::Key << "distortion_model" << YAML::Value << s.distortion_model;
      out << YAML::Key << "distortion_coeffs" << YAML::Value;
      EmitNumbers(out, s.distortion_coeffs);
    }
    out << YAML::Key << "resolution" << YAML::Value << YAML::Flow << YAML::BeginSeq << s.width
        << s.height << YAML::EndSeq;
    out << YAML::Key << "line_delay" << YAML::Value << FormatDouble(s.line_delay);
  }
  EmitNoise(out, "noise", s.type, s.pixel_sigma, s.noise);
  // The noise the data show (results only): beside the stated one, same keys.
  if (s.type == SensorType::kCamera && s.pixel_sigma_estimated)
    EmitNoise(out, "noise_estimated", s.type, *s.pixel_sigma_estimated, s.noise);
  else if (s.type != SensorType::kCamera && s.noise_estimated)
    EmitNoise(out, "noise_estimated", s.type, s.pixel_sigma, *s.noise_estimated);
  if (!is_base) {
    out << YAML::Key << "T_B_S" << YAML::Value;
    EmitMatrix(out, s.T_B_S);
    out << YAML::Key << "time_offset" << YAML::Value << FormatDouble(s.time_offset);
  }
  out << YAML::Key << "estimate" << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (EstimateItem e : s.estimate)
    out << ToString(e);
  out << YAML::EndSeq;
  if (!s.prior_sigma.empty()) {
    out << YAML::Key << "prior_sigma" << YAML::Value << YAML::Flow;
    EmitSigma(out, rig, s, s.prior_sigma);
  }
  if (!s.sigma.empty()) {
    out << YAML::Key << "sigma" << YAML::Value << YAML::Flow;
    EmitSigma(out, rig, s, s.sigma);
  }
  if (!s.sigma_formal.empty()) {
    out << YAML::Key << "sigma_formal" << YAML::Value << YAML::Flow;
    EmitSigma(out, rig, s, s.sigma_formal);
  }
  if (s.rostopic) {
    out << YAML::Key << "rostopic" << YAML::Value << YAML::DoubleQuoted << *s.rostopic;
  }
  out << YAML::EndMap;
}

void EmitObservability(YAML::Emitter& out, const Observability& o) {
  out << YAML::BeginMap;
  auto list = [&out](const char* key, const std::vector<std::string>& v) {
    out << YAML::Key << key << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (const std::string& s : v)
      out << s;
    out << YAML::EndSeq;
  };
  list("unobservable", o.unobservable);
  list("weak", o.weak);
  out << YAML::Key << "directions" << YAML::Value << YAML::BeginSeq;
  for (const ObservabilityDirection& d : o.directions) {
    out << YAML::BeginMap << YAML::Key << "eigenvalue" << YAML::Value << FormatDouble(d.eigenvalue);
    out << YAML::Key << "parameters" << YAML::Value << YAML::BeginSeq;
    for (const ParameterLoading& p : d.parameters) {
      out << YAML::Flow << YAML::BeginMap << YAML::Key << "name" << YAML::Value << p.name
          << YAML::Key << "loading" << YAML::Value << FormatDouble(p.loading) << YAML::EndMap;
    }
    out << YAML::EndSeq << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::Key << "motion" << YAML::Value << YAML::BeginSeq;
  for (const MotionPrimitive& m : o.motion) {
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "primitive" << YAML::Value << m.primitive
        << YAML::Key << "sensor" << YAML::Value << YAML::DoubleQuoted << m.sensor << YAML::Key
        << "axis" << YAML::Value;
    EmitVector3(out, m.axis);
    out << YAML::Key << "t0" << YAML::Value << NsFromSeconds(m.t0) << YAML::Key << "t1"
        << YAML::Value << NsFromSeconds(m.t1) << YAML::EndMap;
  }
  out << YAML::EndSeq;
  list("predicted_unobservable", o.predicted_unobservable);
  out << YAML::EndMap;
}

}  // namespace

std::string EmitRig(const RigConfig& rig) {
  ValidateRig(rig, "rig to write");
  YAML::Emitter out;
  out.SetDoublePrecision(17);  // the target's numbers (its emitter writes doubles itself)
  out << YAML::BeginMap;
  out << YAML::Key << "base_imu" << YAML::Value << rig.base_imu;
  out << YAML::Key << "gravity_magnitude" << YAML::Value << FormatDouble(rig.gravity_magnitude);
  out << YAML::Key << "target" << YAML::Value << YAML::Flow;
  EmitTargetConfig(rig.target, out);
  if (rig.gravity_W) {
    out << YAML::Key << "gravity_W" << YAML::Value;
    EmitVector3(out, *rig.gravity_W);
  }
  if (rig.sigma_gravity_W) {
    out << YAML::Key << "sigma" << YAML::Value << YAML::BeginMap << YAML::Key << "gravity_W"
        << YAML::Value;
    EmitVector3(out, *rig.sigma_gravity_W);
    out << YAML::EndMap;
  }
  out << YAML::Key << "sensors" << YAML::Value << YAML::BeginMap;
  for (const SensorConfig& s : rig.sensors)
    EmitSensor(out, rig, s);
  out << YAML::EndMap;
  if (rig.solver) {
    const SolverSummary& s = *rig.solver;
    out << YAML::Key << "solver" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "method" << YAML::Value << YAML::DoubleQuoted << s.method;
    out << YAML::Key << "iterations" << YAML::Value << s.iterations;
    out << YAML::Key << "final_cost" << YAML::Value << FormatDouble(s.final_cost);
    out << YAML::Key << "seconds" << YAML::Value << FormatDouble(s.seconds);
    out << YAML::EndMap;
  }
  if (!rig.residuals.empty()) {
    out << YAML::Key << "residuals" << YAML::Value << YAML::BeginMap;
    for (const auto& [name, r] : rig.residuals) {
      out << YAML::Key << name << YAML::Value << YAML::Flow << YAML::BeginMap;
      out << YAML::Key << "count" << YAML::Value << r.count;
      auto opt = [&out](const char* key, const std::optional<double>& v) {
        if (v)
          out << YAML::Key << key << YAML::Value << FormatDouble(*v);
      };
      opt("rms_px", r.rms_px);
      opt("rms_gyro", r.rms_gyro);
      opt("rms_accel", r.rms_accel);
      opt("rms_whitened", r.rms_whitened);
      opt("rms_whitened_gyro", r.rms_whitened_gyro);
      opt("rms_whitened_accel", r.rms_whitened_accel);
      out << YAML::EndMap;
    }
    out << YAML::EndMap;
  }
  if (rig.observability) {
    out << YAML::Key << "observability" << YAML::Value;
    EmitObservability(out, *rig.observability);
  }
  out << YAML::EndMap;
  if (!out.good())
    throw std::runtime_error("cannot emit the rig file: " + out.GetLastError());
  return std::string(out.c_str()) + "\n";
}

void SaveRig(const RigConfig& rig, const std::string& path) {
  const std::string text = EmitRig(rig);
  std::ofstream f(path);
  if (!f)
    throw std::runtime_error(path + ": cannot write the rig file");
  f << text;
  if (!f)
    throw std::runtime_error(path + ": write failed");
}

}  // namespace ctcal
