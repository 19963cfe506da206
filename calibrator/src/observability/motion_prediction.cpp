// The seed reports' tables as rules from motion primitives to parameter names (header and
// docs/observability.md).
#include <algorithm>
#include <set>
#include <stdexcept>

#include "ctcal/calibrator/observability/motion_prediction.h"
#include "ctcal/calibrator/observability/numeric_observability.h"
#include "ctcal/sensors/parameter_names.h"

namespace ctcal {
namespace {

// Stored indices of column j of a D / T_g matrix: 6 numbers are upper-triangular column-wise
// [d11, d12, d22, d13, d23, d33], 9 numbers are full and row-major.
std::vector<int> ColumnIndices(int stored_size, int j) {
  if (stored_size == 9)
    return {j, 3 + j, 6 + j};
  if (stored_size == 6) {
    static const std::vector<std::vector<int>> kUpper = {{0}, {1, 2}, {3, 4, 5}};
    return kUpper[j];
  }
  return {};
}

int KeySize(const RigConfig& rig, const SensorConfig& s, const std::string& key) {
  for (const ParameterKey& k : SensorParameterKeys(rig, s))
    if (k.key == key)
      return k.size;
  return 0;
}

class Collector {
 public:
  explicit Collector(const RigConfig& rig) : rig_(rig) {}

  void Add(const std::string& sensor, const std::string& key, int index) {
    names_.insert(ParameterName(sensor, key, index));
  }
  void AddColumn(const SensorConfig& s, const std::string& key, int j) {
    for (const int i : ColumnIndices(KeySize(rig_, s, key), j))
      Add(s.name, key, i);
  }
  void AddAll(const SensorConfig& s, const std::string& key) {
    const int size = KeySize(rig_, s, key);
    for (int i = 0; i < size; ++i)
      Add(s.name, key, i);
  }
  // The estimated parameters among those collected, in canonical order.
  std::vector<std::string> Result() const {
    std::vector<std::string> out;
    for (const ScalarParameter& p : ScalarParameters(rig_, /*estimated_only=*/true))
      if (names_.count(p.name))
        out.push_back(p.name);
    return out;
  }

 private:
  const RigConfig& rig_;
  std::set<std::string> names_;
};

// Columns of D_w that a rotation about the single raw axis u leaves free: only D_w u is seen, so
// a perturbation dD with dD u = 0 is invisible. Solving for the column u is closest to
// (i = argmax |u_i|), column i loads |u_k| / |u_i| on the column-k perturbations; every other
// column loads fully.
std::vector<int> ColumnsFreeByOneAxisRotation(const Eigen::Vector3d& u) {
  Eigen::Index i = 0;
  u.cwiseAbs().maxCoeff(&i);
  std::vector<int> cols;
  for (int j = 0; j < 3; ++j) {
    if (j != i) {
      cols.push_back(j);
    } else {
      double worst = 0.0;
      for (int k = 0; k < 3; ++k)
        if (k != i)
          worst = std::max(worst, std::abs(u(k)) / std::abs(u(i)));
      if (worst > kUnobservableLoading)
        cols.push_back(j);
    }
  }
  return cols;
}

}  // namespace

std::vector<std::string> PredictUnobservable(const RigConfig& rig,
                                             const std::vector<MotionPrimitive>& whole_recording) {
  Collector c(rig);
  const SensorConfig* base = rig.IsCameraOnly() ? nullptr : rig.Find(rig.base_imu);
  for (const MotionPrimitive& p : whole_recording) {
    const SensorConfig* s = rig.Find(p.sensor);
    if (s == nullptr || !s->IsInertial())
      continue;
    const bool is_base = (s == base);
    const Eigen::Vector3d u =
        p.axis.norm() > 0.0 ? Eigen::Vector3d(p.axis.normalized()) : Eigen::Vector3d::Zero();

    if (p.primitive == kConstantAngularVelocity) {
      for (int j = 0; j < 3; ++j)
        if (std::abs(u(j)) > kUnobservableLoading)
          c.AddColumn(*s, "Dw", j);
    } else if (p.primitive == kConstantSpecificForce) {
      for (int j = 0; j < 3; ++j) {
        if (std::abs(u(j)) <= kUnobservableLoading)
          continue;
        c.AddColumn(*s, "Da", j);
        c.AddColumn(*s, "Tg", j);
      }
    } else if (p.primitive == kOneAxisRotation || p.primitive == kPlanar) {
      for (const int j : ColumnsFreeByOneAxisRotation(u))
        c.AddColumn(*s, "Dw", j);
      if (!is_base)
        continue;
      // Rotating only about u never moves a lever arm along u relative to the rotation, and a
      // gyroscope sees the rotation only through its projection on u.
      for (const SensorConfig& o : rig.sensors) {
        if (&o == base)
          continue;
        for (int k = 0; k < 3; ++k) {
          if (std::abs(u(k)) <= kUnobservableLoading)
            continue;
          if (o.type == SensorType::kGyro)
            c.Add(o.name, "R_B_S", k);
          else
            c.Add(o.name, "t_B_S", k);
        }
      }
    } else if (p.primitive == kNoRotation) {
      c.AddAll(*s, "Dw");
      if (!is_base)
        continue;
      for (const SensorConfig& o : rig.sensors) {
        if (&o == base)
          continue;
        if (o.type == SensorType::kGyro) {
          c.AddAll(o, "R_B_S");
          c.Add(o.name, "time_offset", -1);
        } else {
          c.AddAll(o, "t_B_S");
        }
      }
    }
  }
  return c.Result();
}

InertialSeries MakeInertialSeries(const RigConfig& rig, const SensorConfig& sensor,
                                  const SensorData& data) {
  if (!sensor.IsInertial())
    throw std::invalid_argument("motion analysis: sensor " + sensor.name + " is not inertial");
  InertialSeries s;
  s.sensor = sensor.name;
  s.noise = sensor.noise;
  const bool is_base = rig.base_imu == sensor.name;
  const double offset = is_base ? 0.0 : sensor.time_offset;
  if (sensor.type == SensorType::kImu) {
    for (const ImuSample& m : data.imu) {
      s.t.push_back(1e-9 * static_cast<double>(m.t_ns) + offset);
      s.w_m.push_back(m.w_m);
      s.a_m.push_back(m.a_m);
    }
  } else {
    for (const GyroSample& m : data.gyro) {
      s.t.push_back(1e-9 * static_cast<double>(m.t_ns) + offset);
      s.w_m.push_back(m.w_m);
    }
  }
  if (s.t.empty())
    throw std::invalid_argument("motion analysis: sensor " + sensor.name + " has no samples");
  return s;
}

void AnalyseMotion(const RigConfig& rig, const std::map<std::string, SensorData>& data,
                   const MotionOptions& options, Observability* observability) {
  std::vector<MotionPrimitive> whole;
  std::vector<MotionPrimitive> segments;
  for (const SensorConfig& s : rig.sensors) {
    if (!s.IsInertial())
      continue;
    const auto it = data.find(s.name);
    if (it == data.end())
      throw std::invalid_argument("motion analysis: no data for inertial sensor " + s.name);
    const MotionDetection d =
        DetectMotionPrimitives(MakeInertialSeries(rig, s, it->second), options);
    whole.insert(whole.end(), d.whole.begin(), d.whole.end());
    segments.insert(segments.end(), d.segments.begin(), d.segments.end());
  }
  observability->motion = whole;
  observability->motion.insert(observability->motion.end(), segments.begin(), segments.end());
  observability->predicted_unobservable = PredictUnobservable(rig, whole);
}

void CompleteObservability(const RigConfig& rig, const std::map<std::string, SensorData>& data,
                           RigConfig* result, const std::function<void(const std::string&)>& log,
                           std::vector<std::string>* warnings) {
  if (!result->observability)
    return;
  Observability motion;
  AnalyseMotion(rig, data, MotionOptions{}, &motion);
  CompleteObservability(motion, result, log, warnings);
}

void CompleteObservability(const Observability& motion, RigConfig* result,
                           const std::function<void(const std::string&)>& log,
                           std::vector<std::string>* warnings) {
  if (!result->observability)
    return;
  result->observability->motion = motion.motion;
  result->observability->predicted_unobservable = motion.predicted_unobservable;
  MergePredictedWeakIntoUnobservable(&*result->observability, result);
  ReportObservability(*result, *result->observability, log, warnings);
}

}  // namespace ctcal
