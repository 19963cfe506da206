// The calibration quantities of a rig as Ceres parameter blocks, and their conversion from / to
// the stored forms of the rig file (SPEC section 7).
//
// Every sensor owns its blocks; their addresses never change for the lifetime of the state (the
// sensors are heap-allocated and never resized), so Ceres can optimise them in place:
//   inertial:  the intrinsics (ImuIntrinsics / GyroIntrinsics blocks), bias-spline knots b_g, b_a
//              (3 doubles each, a linear spline on the sensor's own clock);
//   camera:    `params` (intrinsics then distortion coefficients, CameraModel's storage),
//              `line_delay`;
//   non-base:  q_B_S (x, y, z, w on So3LeftManifold), t_B_S, time_offset.
// Gravity g_W (3 doubles, norm gravity_magnitude, ceres::SphereManifold<3>) belongs to the rig.
// The trajectory spline is not here: its order and representation are template parameters of the
// problem that owns it (spline_problem.h).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ctcal/sensors/camera_model.h"
#include "ctcal/sensors/gyro_intrinsics.h"
#include "ctcal/sensors/imu_intrinsics.h"
#include "ctcal/sensors/parameter_names.h"
#include "ctcal/sensors/rig.h"
#include "ctcal/spline/bspline_basis.h"

namespace ctcal {

// Knot values of one bias spline (3 doubles per knot, contiguous).
struct BiasSpline {
  KnotTiming timing;
  std::vector<double> knots;

  int NumKnots() const { return static_cast<int>(knots.size() / 3); }
  double* Knot(int k) { return knots.data() + 3 * k; }
  const double* Knot(int k) const { return knots.data() + 3 * k; }
  // Linear interpolation (the bias spline has order 2); clamps outside the knot range.
  Eigen::Vector3d Evaluate(std::int64_t t_ns) const;
};

struct SensorState {
  SensorConfig config;  // the input's configuration (estimate sets, priors, noise)
  bool is_base = false;

  // Extrinsics and clock (unused for the base).
  std::array<double, 4> q_B_S{0.0, 0.0, 0.0, 1.0};
  std::array<double, 3> t_B_S{0.0, 0.0, 0.0};
  double time_offset = 0.0;
  double line_delay = 0.0;

  std::optional<ImuIntrinsics> imu;
  std::optional<GyroIntrinsics> gyro;
  std::optional<CameraModel> camera;

  BiasSpline bias_gyro;   // inertial sensors
  BiasSpline bias_accel;  // IMUs

  const std::string& name() const { return config.name; }
  Eigen::Matrix3d R_B_S() const;
  Eigen::Vector3d p_B_S() const { return Eigen::Vector3d(t_B_S[0], t_B_S[1], t_B_S[2]); }
  Eigen::Isometry3d T_B_S() const;
};

// One Ceres parameter block of a calibration quantity with its SPEC names (one per tangent
// dimension) and the rig-file key it stores.
struct ParameterBlockInfo {
  std::string sensor;
  std::string key;  // the ParameterKey of parameter_names.h; "params" = intrinsics + distortion
  double* values = nullptr;
  int ambient_size = 0;
  int tangent_size = 0;
  bool left_rotation = false;  // So3LeftManifold
  bool estimated = false;
  std::vector<std::string> names;   // per tangent dimension
  std::vector<double> unit;         // comparison unit per tangent dimension (marginal_covariance.h)
  std::vector<double> prior_sigma;  // per tangent dimension; empty: no prior
};

class CalibrationState {
 public:
  // Throws std::runtime_error "sensors.<name>: <what>" for a configuration the models reject.
  explicit CalibrationState(const RigConfig& rig);
  CalibrationState(const CalibrationState&) = delete;
  CalibrationState& operator=(const CalibrationState&) = delete;

  const RigConfig& rig() const { return rig_; }
  std::vector<std::unique_ptr<SensorState>>& sensors() { return sensors_; }
  const std::vector<std::unique_ptr<SensorState>>& sensors() const { return sensors_; }
  SensorState& base() { return *sensors_[base_index_]; }
  SensorState* Find(const std::string& name);

  double* g_W() { return g_W_.data(); }
  Eigen::Vector3d gravity() const { return Eigen::Vector3d(g_W_[0], g_W_[1], g_W_[2]); }
  void SetGravity(const Eigen::Vector3d& g_W);  // rescaled to gravity_magnitude

  // Every calibration block (estimated or not) in SPEC order: sensors in file order, keys in
  // SensorParameterKeys order, then gravity. Camera intrinsics and distortion share one block.
  std::vector<ParameterBlockInfo> Blocks();

  // The rig file of the current values (input rig with values replaced; sigma, solver, residuals
  // and observability left to the caller).
  RigConfig ToRig() const;

 private:
  RigConfig rig_;
  std::vector<std::unique_ptr<SensorState>> sensors_;
  std::size_t base_index_ = 0;
  std::array<double, 3> g_W_{0.0, 0.0, -9.81};
};

}  // namespace ctcal
