// Scalar parameter names of SPEC section 7, `<sensor>.<key>[i]`, used wherever one scalar is
// named (observability, compare, reports): `imu0.Dw[0]`, `cam0.intrinsics[2]`, `imu1.t_B_S[2]`,
// `gyro0.R_B_S[2]`, `cam1.time_offset`, `gravity_W[1]`, `imu0.R_I_a[0]`,
// `cam0.distortion_coeffs[1]`, `cam0.line_delay`.
//
// A rotation R_X_Y is named by the 3 components of its left perturbation
// R_X_Y = Exp(dtheta) * R_hat_X_Y (dtheta in frame X, radians), the convention of `sigma:`.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ctcal/sensors/rig.h"

namespace ctcal {

// One key of a sensor's `sigma:` / `prior_sigma:` block, with its shape.
struct ParameterKey {
  std::string key;  // Dw, Da, Tg, R_I_a, R_I_w, intrinsics, distortion_coeffs, line_delay,
                    // R_B_S, t_B_S, time_offset
  int size = 1;
  bool scalar = false;    // written as a plain number (time_offset, line_delay), not a list
  bool rotation = false;  // a rotation's perturbation 3-vector
  EstimateItem item = EstimateItem::kIntrinsics;  // the `estimate:` word that frees it
};

// Every parameter key of a sensor's model, estimated or not, in canonical order. The base sensor
// has no extrinsics and no time offset; a camera-only rig has no time offsets; a gyroscope's
// extrinsics are its rotation only (its position enters no measurement).
std::vector<ParameterKey> SensorParameterKeys(const RigConfig& rig, const SensorConfig& sensor);

struct ScalarParameter {
  std::string name;    // "cam0.intrinsics[2]", "cam1.time_offset", "gravity_W[1]"
  std::string sensor;  // "" for gravity_W
  std::string key;
  int index = -1;  // -1 for a scalar key
  bool rotation = false;
};

std::string ParameterName(const std::string& sensor, const std::string& key, int index);

// Every scalar parameter of the rig, sensors in file order then gravity_W (rigs with an IMU).
// With `estimated_only`, only the keys freed by each sensor's `estimate:` (gravity_W is always
// estimated in a rig with an IMU).
std::vector<ScalarParameter> ScalarParameters(const RigConfig& rig, bool estimated_only);

// Looks a name up; std::nullopt when the rig has no such parameter.
std::optional<ScalarParameter> FindParameter(const RigConfig& rig, const std::string& name);

// The stored value. A rotation component is the component of Log(R) (its rotation vector); to
// compare two rotations use RotationError (spline/so3.h) on the whole rotation instead.
// Throws std::invalid_argument when the rig lacks the parameter (e.g. gravity_W of a rig file).
double ParameterValue(const RigConfig& rig, const ScalarParameter& p);
// The whole 3x3 rotation a rotation parameter is a component of.
Eigen::Matrix3d ParameterRotation(const RigConfig& rig, const ScalarParameter& p);
// From `sigma:` / `prior_sigma:` (top-level `sigma: {gravity_W}` for gravity); std::nullopt when
// the file gives none for it.
std::optional<double> ParameterSigma(const RigConfig& rig, const ScalarParameter& p);
std::optional<double> ParameterPriorSigma(const RigConfig& rig, const ScalarParameter& p);

}  // namespace ctcal
