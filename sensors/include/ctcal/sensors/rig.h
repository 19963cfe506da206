// The rig / result / truth file of SPEC section 7 as plain data. One schema serves the rig
// description with initial guesses (input), the calibration result (output) and the simulator's
// ground truth. Values are kept in their stored forms (upper-triangular matrices as 6 numbers
// column-wise, full ones as 9 row-major, rotations as 3x3); the sensor models convert from them.
// Reading and writing live in rig_yaml.h, scalar parameter names in parameter_names.h.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "ctcal/sensors/inertial_noise.h"
#include "ctcal/sensors/model_names.h"
#include "ctcal/targets/target_config.h"

namespace ctcal {

// The vocabulary of `estimate:` (SPEC section 7).
enum class EstimateItem { kIntrinsics, kExtrinsics, kTimeOffset, kLineDelay };
EstimateItem ParseEstimateItem(const std::string& s);  // throws std::invalid_argument
std::string ToString(EstimateItem e);

// `sigma:` / `prior_sigma:` of one sensor: the same keys and shapes as the values, except that
// every rotation R_X_Y is a 3-vector (radians, left perturbation R = Exp(dtheta) * R_hat, dtheta
// in frame X) and T_B_S is split into `R_B_S` and `t_B_S`. Scalars (`time_offset`, `line_delay`)
// are stored as one-element vectors. `.inf` marks a quantity the data does not determine.
struct SigmaBlock {
  std::map<std::string, std::vector<double>> values;

  bool empty() const { return values.empty(); }
  const std::vector<double>* Find(const std::string& key) const {
    const auto it = values.find(key);
    return it == values.end() ? nullptr : &it->second;
  }
};

// One sensor of the rig, in file order. Fields that do not apply to the sensor's type keep their
// defaults and are neither read nor written.
struct SensorConfig {
  std::string name;  // the folder name of its data (SPEC section 6)
  SensorType type = SensorType::kImu;

  // --- imu and gyro ---
  ImuModel imu_model = ImuModel::kImu2;              // type imu
  GSensitivity g_sensitivity = GSensitivity::kNone;  // type imu
  GyroModel gyro_model = GyroModel::kUpper;          // type gyro
  // Stored forms: 6 numbers [d11, d12, d22, d13, d23, d33] (upper) or 9 row-major (full); empty
  // when the model has no such part. Absent in a file: identity (D_w, D_a) or zero (T_g).
  std::vector<double> D_w;
  std::vector<double> D_a;
  std::vector<double> T_g;
  // The model's rotation (RotationKey(imu_model)): R_I_w for imu1, R_I_a for imu2. The other one
  // stays identity. Absent in a file: identity.
  Eigen::Matrix3d R_I_w = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d R_I_a = Eigen::Matrix3d::Identity();
  InertialNoise noise;  // required for imu and gyro

  // --- camera ---
  std::string camera_model;               // pinhole, omni, ds, eucm
  std::vector<double> intrinsics;         // SPEC section 4 table
  std::string distortion_model = "none";  // radtan, equidistant, none
  std::vector<double> distortion_coeffs;
  int width = 0;  // resolution: [width, height]
  int height = 0;
  double line_delay = 0.0;   // seconds per image row, 0 for a global shutter
  double pixel_sigma = 1.0;  // px per coordinate, for corners without their own sigma

  // --- all but the base ---
  Eigen::Matrix4d T_B_S = Eigen::Matrix4d::Identity();
  double time_offset = 0.0;  // t_B = t_S + time_offset

  // --- all ---
  std::set<EstimateItem> estimate;
  SigmaBlock prior_sigma;  // empty: no prior
  SigmaBlock sigma;        // results only; ignored as input
  // Results only, read back and ignored as input (SPEC section 7): the noise the data show
  // (variance component estimation, docs/noise_estimation.md), same keys as `noise:` (inertial:
  // every key of InertialNoise; camera: `pixel_sigma`, the median of its corners' estimated
  // sigmas).
  std::optional<InertialNoise> noise_estimated;
  std::optional<double> pixel_sigma_estimated;
  // Results only, ignored as input: the covariance from the stated noise alone, written when
  // `sigma` adds a model error that cross-validation found (docs/cross_validation.md).
  SigmaBlock sigma_formal;
  std::optional<std::string> rostopic;

  bool Estimates(EstimateItem e) const { return estimate.count(e) > 0; }
  bool IsInertial() const { return type != SensorType::kCamera; }
};

struct SolverSummary {
  std::string method;  // spline, discrete
  int iterations = 0;
  double final_cost = 0.0;
  double seconds = 0.0;
};

// `residuals:` of one sensor: RMS of the raw residuals in their units and of the whitened ones
// (which should be ~1 at a consistent fit). Only the entries that apply to the sensor are set.
struct SensorResiduals {
  std::int64_t count = 0;                   // number of scalar residuals
  std::optional<double> rms_px;             // cameras
  std::optional<double> rms_gyro;           // rad/s
  std::optional<double> rms_accel;          // m/s^2
  std::optional<double> rms_whitened;       // all of the sensor's residuals
  std::optional<double> rms_whitened_gyro;  // inertial sensors, per part
  std::optional<double> rms_whitened_accel;
};

struct ParameterLoading {
  std::string name;  // SPEC section 7 parameter name
  double loading = 0.0;
};

struct ObservabilityDirection {
  double eigenvalue = 0.0;
  std::vector<ParameterLoading> parameters;
};

// A degenerate-motion primitive found in the data (e.g. "constant_velocity", "pure_rotation").
struct MotionPrimitive {
  std::string primitive;
  std::string sensor;
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();
  double t0 = 0.0;  // seconds on the base clock
  double t1 = 0.0;
};

struct Observability {
  std::vector<std::string> unobservable;
  std::vector<std::string> weak;
  std::vector<ObservabilityDirection> directions;
  std::vector<MotionPrimitive> motion;
  std::vector<std::string> predicted_unobservable;
};

struct RigConfig {
  std::string base_imu;  // an imu, or the reference camera of a camera-only rig
  double gravity_magnitude = 9.81;
  TargetConfig target;
  std::vector<SensorConfig> sensors;  // file order

  // Truth and result files.
  std::optional<Eigen::Vector3d> gravity_W;        // m/s^2
  std::optional<Eigen::Vector3d> sigma_gravity_W;  // top-level `sigma: {gravity_W: [...]}`
  std::optional<SolverSummary> solver;
  std::map<std::string, SensorResiduals> residuals;  // by sensor name
  std::optional<Observability> observability;

  const SensorConfig* Find(const std::string& name) const;
  SensorConfig* Find(const std::string& name);
  const SensorConfig& Base() const;  // throws std::logic_error when base_imu names no sensor
  // No IMU: a camera calibration whose B frame is the reference camera's (SPEC section 7).
  bool IsCameraOnly() const;
};

// Stored forms of the identity: 6 upper-triangular or 9 row-major numbers.
std::vector<double> IdentityStored(std::size_t count);

// Exact equality, field by field, with NaN equal to NaN (what a write -> read round trip keeps).
bool operator==(const SigmaBlock& a, const SigmaBlock& b);
bool operator==(const SensorConfig& a, const SensorConfig& b);
bool operator==(const SolverSummary& a, const SolverSummary& b);
bool operator==(const SensorResiduals& a, const SensorResiduals& b);
bool operator==(const Observability& a, const Observability& b);
// Targets compare by every field of TargetConfig.
bool operator==(const RigConfig& a, const RigConfig& b);
inline bool operator!=(const RigConfig& a, const RigConfig& b) {
  return !(a == b);
}

}  // namespace ctcal
