// Unobservable, weak and null directions from the data-only marginal information; the terminal's
// observability block (numeric_observability.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <set>

#include "ctcal/calibrator/observability/motion_prediction.h"
#include "ctcal/calibrator/observability/numeric_observability.h"
#include "ctcal/calibrator/observability/warnings.h"
#include "ctcal/sensors/parameter_names.h"

namespace ctcal {
namespace {

// Reference sigmas of the fully excited default rig (sim::DefaultRig, `--scenario full`, table4
// guesses), per kind, scaled to a 1 s recording: sigma(T) = value / sqrt(T). Each is the largest
// data-only sigma * sqrt(T) of its kind over the default rig's sensors on an 8 s recording
// (seed 24), rounded up to two digits, as
// `ObservabilityCalibration.FullIsObservableAndMatchesTheReference`
// (tests/calibrator/observability/test_observability_calibration.cpp) prints it;
// docs/observability.md.
struct Reference {
  const char* kind;
  double sigma_1s;
};
constexpr Reference kReferences[] = {
    // inertial sensors (rotations in rad, translations in m, offsets in s)
    {"imu.Dw", 1.2e-3},
    {"imu.Da", 1.8e-3},
    {"imu.Tg", 8.4e-5},  // (rad/s)/(m/s^2)
    {"imu.R_I", 1.4e-3},
    {"imu.R_B_S", 8.7e-4},
    {"imu.t_B_S", 6.1e-4},
    {"imu.time_offset", 2.9e-5},
    {"gyro.Dw", 1.2e-3},
    {"gyro.R_B_S", 1.2e-3},
    {"gyro.time_offset", 3.4e-5},
    // cameras (px for focal length and principal point)
    {"camera.focal", 0.72},
    {"camera.principal", 0.76},
    {"camera.radtan.distortion[0]", 1.1e-3},
    {"camera.radtan.distortion[1]", 7.5e-4},
    {"camera.radtan.distortion[2]", 1.5e-4},
    {"camera.radtan.distortion[3]", 1.2e-4},
    {"camera.equidistant.distortion[0]", 9.6e-3},
    {"camera.equidistant.distortion[1]", 2.5e-2},
    {"camera.equidistant.distortion[2]", 2.5e-2},
    {"camera.equidistant.distortion[3]", 8.0e-3},
    {"camera.R_B_S", 1.8e-3},
    {"camera.t_B_S", 1.7e-3},
    {"camera.time_offset", 1.7e-4},
    {"gravity_W.direction", 2.4e-3},
};

const std::map<std::string, double>& ReferenceTable() {
  static const std::map<std::string, double> table = [] {
    std::map<std::string, double> t;
    for (const Reference& r : kReferences)
      if (r.sigma_1s > 0.0)
        t[r.kind] = r.sigma_1s;
    return t;
  }();
  return table;
}

std::string ListName(const std::string& name) {
  return name.rfind("gravity_W.direction", 0) == 0 ? "gravity_W" : name;
}

void AddOnce(std::vector<std::string>* list, const std::string& name) {
  if (std::find(list->begin(), list->end(), name) == list->end())
    list->push_back(name);
}

std::string Joined(const std::vector<std::string>& names) {
  std::string s;
  for (const std::string& n : names)
    s += (s.empty() ? "" : " ") + n;
  return s.empty() ? "-" : s;
}

}  // namespace

std::string ParameterKind(const RigConfig& rig, const std::string& name) {
  if (name.rfind("gravity_W", 0) == 0)
    return "gravity_W.direction";
  const std::optional<ScalarParameter> p = FindParameter(rig, name);
  if (!p || p->sensor.empty())
    return "";
  const SensorConfig& s = *rig.Find(p->sensor);
  const std::string type = ToString(s.type);
  const std::string& k = p->key;
  if (k == "R_I_a" || k == "R_I_w")
    return type + ".R_I";
  if (k == "intrinsics") {
    // Every model ends with [fu, fv, pu, pv]; what comes before (xi, alpha, beta) is per model.
    const int n = static_cast<int>(s.intrinsics.size());
    const int j = p->index - (n - 4);
    if (j >= 0)
      return j < 2 ? "camera.focal" : "camera.principal";
    return "camera." + s.camera_model + ".projection[" + std::to_string(p->index) + "]";
  }
  if (k == "distortion_coeffs")
    return "camera." + s.distortion_model + ".distortion[" + std::to_string(p->index) + "]";
  return type + "." + k;
}

std::optional<double> ReferenceSigma(const RigConfig& rig, const std::string& name,
                                     double duration_s) {
  const auto& table = ReferenceTable();
  const auto it = table.find(ParameterKind(rig, name));
  if (it == table.end() || !(duration_s > 0.0))
    return std::nullopt;
  return it->second / std::sqrt(duration_s);
}

Observability NumericObservability(const MarginalInformation& information,
                                   const CalibrationCovariance& covariance, const RigConfig& rig,
                                   double duration_s, double weak_factor) {
  Observability obs;
  const std::size_t n = information.names.size();
  for (std::size_t i = 0; i < n; ++i)
    if (covariance.undetermined[i])
      AddOnce(&obs.unobservable, ListName(information.names[i]));

  const Eigen::VectorXd& lambda = covariance.scaled_eigenvalues;
  const double largest = lambda.size() > 0 ? std::max(lambda.maxCoeff(), 0.0) : 0.0;
  for (const int col : covariance.null_directions) {
    ObservabilityDirection dir;
    dir.eigenvalue = largest > 0.0 ? std::max(lambda(col), 0.0) / largest : 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const double l = covariance.scaled_eigenvectors(static_cast<Eigen::Index>(i), col);
      if (std::abs(l) > kUnobservableLoading)
        dir.parameters.push_back(ParameterLoading{information.names[i], l});
    }
    std::sort(dir.parameters.begin(), dir.parameters.end(),
              [](const ParameterLoading& a, const ParameterLoading& b) {
                return std::abs(a.loading) > std::abs(b.loading);
              });
    obs.directions.push_back(dir);
  }

  for (std::size_t i = 0; i < n; ++i) {
    if (covariance.undetermined[i])
      continue;
    const std::optional<double> ref = ReferenceSigma(rig, information.names[i], duration_s);
    if (ref && covariance.sigma(static_cast<Eigen::Index>(i)) > weak_factor * *ref)
      AddOnce(&obs.weak, ListName(information.names[i]));
  }
  return obs;
}

std::vector<std::string> MergePredictedWeakIntoUnobservable(Observability* obs, RigConfig* result) {
  std::vector<std::string> moved;
  for (const std::string& name : obs->predicted_unobservable) {
    const auto w = std::find(obs->weak.begin(), obs->weak.end(), name);
    if (w == obs->weak.end())
      continue;
    obs->weak.erase(w);
    AddOnce(&obs->unobservable, name);
    moved.push_back(name);
    const std::optional<ScalarParameter> p = FindParameter(*result, name);
    if (!p || p->sensor.empty())
      continue;
    SensorConfig* sensor = result->Find(p->sensor);
    const auto it = sensor->sigma.values.find(p->key);
    const std::size_t i = p->index < 0 ? 0 : static_cast<std::size_t>(p->index);
    if (it != sensor->sigma.values.end() && i < it->second.size())
      it->second[i] = std::numeric_limits<double>::infinity();
  }
  return moved;
}

void ReportObservability(const RigConfig& result, const Observability& observability,
                         const std::function<void(const std::string&)>& log,
                         std::vector<std::string>* warnings) {
  log("  observability (numeric: information without priors; predicted: the motion's tables)");
  log("    numeric unobservable:   " + Joined(observability.unobservable));
  log("    predicted unobservable: " + Joined(observability.predicted_unobservable));
  log("    weak (sigma > " + std::to_string(static_cast<int>(kWeakFactor)) +
      "x the fully excited default rig): " + Joined(observability.weak));
  // The motion primitives, the first kMaxMotionLines of them (result.yaml has them all).
  constexpr std::size_t kMaxMotionLines = 30;
  std::size_t shown = 0;
  for (const MotionPrimitive& m : observability.motion) {
    char line[200];
    std::snprintf(line, sizeof line, "    motion: %-8s %-26s axis [%+.3f %+.3f %+.3f]  %.2f-%.2f s",
                  m.sensor.c_str(), m.primitive.c_str(), m.axis.x(), m.axis.y(), m.axis.z(), m.t0,
                  m.t1);
    if (shown++ < kMaxMotionLines)
      log(line);
  }
  if (shown > kMaxMotionLines)
    log("    motion: ... " + std::to_string(shown - kMaxMotionLines) + " more in result.yaml");
  for (const std::string& w : ObservabilityWarnings(result, observability)) {
    log("  warning: " + w);
    if (warnings != nullptr)
      warnings->push_back("warning: " + w);
  }
}

}  // namespace ctcal
