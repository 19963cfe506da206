// Degenerate-motion primitives of the seed reports, detected in an inertial sensor's raw readings
// over the whole recording and per sliding window:
//
//   constant_angular_velocity  one raw gyroscope axis reads a constant (the intrinsic paper's
//                              Table I: that column of D_w is absorbed by the gyroscope bias)
//   constant_specific_force    the raw specific force is constant along a sensor axis (Table I:
//                              that column of D_a and of T_g is absorbed by the biases), or along
//                              some other direction (axis = that direction)
//   no_rotation                the angular velocity is constant and no larger than a bias
//                              (the MVIS report's Table 2)
//   one_axis_rotation          the angular velocity stays on one line through the bias
//                              (axis = its direction, from the eigenvectors of its covariance)
//   planar                     one-axis rotation about u and constant specific force along u:
//                              the sensor moves in a plane normal to u
//
// Every decision is a chi-square test of "this component is constant" against what the sensor's
// white noise and bias random walk alone produce over the window (docs/observability.md derives
// the statistics and states the thresholds). Raw readings are the right input: the intrinsic
// model multiplies the raw reading by D (SPEC section 3), so "column j of D is unobservable" is a
// statement about raw component j; the calibrated components differ from the raw ones by the
// near-identity mixing of scale, non-orthogonality, misalignment and g-sensitivity, which the
// tests absorb by the coupling bounds of MotionOptions.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "ctcal/sensors/inertial_noise.h"
#include "ctcal/sensors/rig.h"

namespace ctcal {

// Primitive names as written to `observability: motion:`.
inline constexpr const char* kConstantAngularVelocity = "constant_angular_velocity";
inline constexpr const char* kConstantSpecificForce = "constant_specific_force";
inline constexpr const char* kNoRotation = "no_rotation";
inline constexpr const char* kOneAxisRotation = "one_axis_rotation";
inline constexpr const char* kPlanar = "planar";

struct MotionOptions {
  double window_s = 3.0;  // sliding-window length; windows advance by half of it
  // Probability that a recording of one sensor holding no primitive reports one anyway (and that
  // pure noise is reported as excitation): split by Bonferroni over every test made.
  double false_alarm_probability = 1e-3;
  // Bounds on how much of the other components' variation the unknown intrinsics leak into a raw
  // component: scale / non-orthogonality / misalignment entries (dimensionless) and g-sensitivity
  // entries ((rad/s)/(m/s^2)). A component is "constant" when its variation is explained by noise
  // plus this leakage.
  double axis_coupling = 0.02;
  double g_sensitivity = 2e-3;
  // A constant angular velocity no larger than this (rad/s) is a bias, not a rotation.
  double max_gyro_bias = 0.05;
};

// One inertial sensor's raw readings, stamped on the base clock (t_S + time_offset).
struct InertialSeries {
  std::string sensor;
  std::vector<double> t;             // s, increasing
  std::vector<Eigen::Vector3d> w_m;  // rad/s
  std::vector<Eigen::Vector3d> a_m;  // m/s^2; empty for a gyroscope-only sensor
  InertialNoise noise;
};

struct MotionDetection {
  // Primitives that hold over the whole recording (t0, t1: its first and last stamps).
  std::vector<MotionPrimitive> whole;
  // Primitives that hold over merged runs of windows and not over the whole recording.
  std::vector<MotionPrimitive> segments;
};

// Throws std::invalid_argument for a series without samples, with mismatched lengths, or for
// invalid options / noise.
MotionDetection DetectMotionPrimitives(const InertialSeries& series,
                                       const MotionOptions& options = {});

}  // namespace ctcal
