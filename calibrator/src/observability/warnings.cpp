// Warning lines for unobservable and weak parameters, with the motion that would determine each.
#include <set>

#include "ctcal/calibrator/observability/warnings.h"
#include "ctcal/sensors/parameter_names.h"

namespace ctcal {
namespace {

const char* AxisName(int k) {
  static const char* kNames[] = {"x", "y", "z"};
  return (k >= 0 && k < 3) ? kNames[k] : "?";
}

// Column of a stored D / T_g entry (6: upper-triangular column-wise, 9: full row-major).
int StoredColumn(int stored_size, int index) {
  if (stored_size == 9)
    return index % 3;
  static const int kUpper[] = {0, 1, 1, 2, 2, 2};
  return (index >= 0 && index < 6) ? kUpper[index] : -1;
}

int KeySize(const RigConfig& rig, const SensorConfig& s, const std::string& key) {
  for (const ParameterKey& k : SensorParameterKeys(rig, s))
    if (k.key == key)
      return k.size;
  return 0;
}

}  // namespace

std::string MotionSuggestion(const RigConfig& rig, const std::string& parameter) {
  // Gravity is listed as `gravity_W` (its direction's two tangent dimensions), a name
  // FindParameter does not know (it has gravity_W[0..2]).
  const auto p = FindParameter(rig, parameter);
  if (parameter.rfind("gravity_W", 0) == 0 || (p && p->sensor.empty()))
    return "tilt the rig through several orientations so gravity is seen from different "
           "directions";
  if (!p)
    return "excite the motion on every axis";
  const SensorConfig& s = *rig.Find(p->sensor);
  const std::string& k = p->key;
  const std::string base = rig.base_imu;
  if (k == "Dw")
    return std::string("rotate about ") + s.name + "'s " +
           AxisName(StoredColumn(KeySize(rig, s, k), p->index)) +
           " axis with a varying rate (not only about one axis)";
  if (k == "Da")
    return std::string("vary the specific force along ") + s.name + "'s " +
           AxisName(StoredColumn(KeySize(rig, s, k), p->index)) +
           " axis (accelerate along it and tilt it through gravity)";
  if (k == "Tg")
    return std::string("vary the specific force along ") + s.name + "'s " +
           AxisName(StoredColumn(KeySize(rig, s, k), p->index)) +
           " axis while rotating (tilt it through gravity)";
  if (k == "R_I_a" || k == "R_I_w")
    return "rotate about all three axes and tilt the rig through gravity";
  if (k == "t_B_S")
    return std::string("rotate about axes other than ") + base + "'s " + AxisName(p->index) +
           " axis (a lever arm along the rotation axis never moves)";
  if (k == "R_B_S")
    return s.type == SensorType::kGyro
               ? std::string("rotate about ") + base + "'s axes other than " + AxisName(p->index) +
                     " (a gyroscope sees its rotation about the rotation "
                     "axis not at all)"
               : std::string("rotate about more than one axis of ") + base;
  if (k == "time_offset")
    return s.type == SensorType::kCamera ? "move with varying speed and rotation rate"
                                         : "rotate with a varying rate";
  if (k == "line_delay")
    return "move the board fast across the image rows";
  if (k == "intrinsics" || k == "distortion_coeffs")
    return "show the board in every part of the image, near and far, tilted";
  return "excite the motion on every axis";
}

std::vector<std::string> ObservabilityWarnings(const RigConfig& rig,
                                               const Observability& observability) {
  const std::set<std::string> numeric(observability.unobservable.begin(),
                                      observability.unobservable.end());
  const std::set<std::string> predicted(observability.predicted_unobservable.begin(),
                                        observability.predicted_unobservable.end());
  const std::set<std::string> weak(observability.weak.begin(), observability.weak.end());

  std::vector<std::string> order;
  std::set<std::string> seen;
  for (const auto* list :
       {&observability.unobservable, &observability.predicted_unobservable, &observability.weak})
    for (const std::string& name : *list)
      if (seen.insert(name).second)
        order.push_back(name);

  std::vector<std::string> lines;
  for (const std::string& name : order) {
    std::string status;
    if (numeric.count(name) || predicted.count(name)) {
      status = "unobservable (";
      if (numeric.count(name))
        status += "numeric";
      if (numeric.count(name) && predicted.count(name))
        status += ", ";
      if (predicted.count(name))
        status += "predicted by the motion";
      status += ")";
      if (weak.count(name))
        status += ", weak";
    } else {
      status = "weak";
    }
    std::string line = name + ": " + status + " - " + MotionSuggestion(rig, name);
    const auto p = FindParameter(rig, name);
    if (p && !p->sensor.empty()) {
      const std::string item = p->key == "t_B_S" || p->key == "R_B_S" ? "extrinsics"
                               : p->key == "time_offset"              ? "time_offset"
                               : p->key == "line_delay"               ? "line_delay"
                                                                      : "intrinsics";
      line += ", or remove `" + item + "` from " + p->sensor + "'s estimate";
    }
    lines.push_back(line);
  }
  return lines;
}

}  // namespace ctcal
