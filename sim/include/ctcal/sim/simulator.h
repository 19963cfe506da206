// The simulator proper: samples every sensor of a rig along a ground-truth trajectory of the base
// frame B, each on its own clock, and returns the raw data in memory (dataset_writer.h writes it
// in the SPEC section 6 / 7 layout).
//
// Clocks (SPEC section 2): a sample stamped t_S on sensor S's clock is taken at base time
// t_B = t_S + time_offset. Stamps are integer nanoseconds and the physics is evaluated at exactly
// the stamp written to the file. Every sensor starts at its own phase (not aligned with the base)
// and only samples whose base time lies inside [t_begin, t_begin + duration] are kept, so every
// measurement is covered by the base IMU's data.
//
// Inertial sensors: ideal readings (kinematics.h: lever arm and the sensor's own orientation),
// then the sensor's intrinsic model true -> raw with its current biases (sensors/imu_intrinsics.h,
// gyro_intrinsics.h), plus white noise of density * sqrt(rate) per sample. Biases start at a
// random value and walk: b_{k+1} = b_k + random_walk * sqrt(dt) * n_k.
//
// Cameras: every board corner in front of the camera, on the printed side of the board (which
// faces +z_W), seen less obliquely than max_view_angle, projected inside the image, then dropped
// with probability corner_dropout, then pixel noise. With line_delay > 0 a corner on row v was
// read at t_S + time_offset + v * line_delay (SPEC section 2, v the noise-free row): the row is
// found by the fixed-point iteration v <- project(T_W_C(t_S + time_offset + v * line_delay)).v,
// a contraction because line_delay * |dv/dt| << 1.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "ctcal/sensors/rig.h"
#include "ctcal/sim/trajectory.h"

namespace ctcal::sim {

struct SimOptions {
  double duration = 60.0;  // s of base IMU data
  double t_begin = 1.0;    // base time (s) of the first base IMU sample; stamps stay > 0
  std::uint64_t seed = 0;
  double camera_rate_hz = 20.0;  // a rig file has no camera rate
  double corner_dropout = 0.0;   // probability that a visible corner is not detected
  double max_view_angle_deg = 75.0;
  double image_border_px = 2.0;  // corners closer to the image edge than this are not detected
  double initial_gyro_bias_sigma = 0.005;  // rad/s per axis: initial biases ~ N(0, sigma^2)
  double initial_accel_bias_sigma = 0.05;  // m/s^2 per axis
  bool white_noise = true;                 // inertial white noise and pixel noise
  bool bias_random_walk = true;            // biases walk (else stay at their initial values)
  // Called now and then with a fraction done in [0, 1] and what is being simulated.
  std::function<void(double, const std::string&)> progress;
};

struct InertialSample {
  std::int64_t t_ns = 0;  // the sensor's own clock
  Eigen::Vector3d w_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_m = Eigen::Vector3d::Zero();  // zero for a gyroscope-only sensor
};

struct BiasState {
  std::int64_t t_ns = 0;  // the sensor's own clock
  Eigen::Vector3d b_g = Eigen::Vector3d::Zero();
  Eigen::Vector3d b_a = Eigen::Vector3d::Zero();
};

struct InertialData {
  std::string sensor;
  bool has_accel = true;  // false for type gyro
  std::vector<InertialSample> samples;
  std::vector<BiasState> biases;  // one per sample, the biases that sample was taken with
};

struct SimulatedCorner {
  std::int64_t t_ns = 0;  // the image's stamp on the camera's clock
  int corner_id = 0;
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();       // with pixel noise
  Eigen::Vector2d uv_true = Eigen::Vector2d::Zero();  // noise-free
  double sigma = 1.0;                                 // px per coordinate
};

struct CameraData {
  std::string sensor;
  std::vector<std::int64_t> frames_ns;  // every image stamp, with or without corners
  std::vector<SimulatedCorner> corners;
};

// The base frame's state at a base IMU sample, with the base IMU's biases.
struct GroundTruthSample {
  std::int64_t t_ns = 0;
  KinematicState state;
  Eigen::Vector3d b_g = Eigen::Vector3d::Zero();
  Eigen::Vector3d b_a = Eigen::Vector3d::Zero();
};

struct SimulatedDataset {
  RigConfig truth;  // the rig simulated, with gravity_W
  std::vector<InertialData> inertial;
  std::vector<CameraData> cameras;
  std::vector<GroundTruthSample> groundtruth;  // at the base IMU's samples (reference camera's
                                               // frames for a camera-only rig)
};

// `traj` is T_W_B(t) on the base clock. Throws std::invalid_argument for a rig the simulator
// cannot sample (an inertial sensor without update_rate, an invalid camera or intrinsics), naming
// the sensor.
SimulatedDataset Simulate(const RigConfig& rig, const Trajectory& traj, const SimOptions& options);

// The frame rigidly attached to a trajectory's frame T by the rotation R_T_B (same origin):
// q_W_B = q_W_T R_T_B, w_B = R_T_B^T w_T, alpha_B = R_T_B^T alpha_T, position and its derivatives
// unchanged.
class RotatedTrajectory : public Trajectory {
 public:
  RotatedTrajectory(const Trajectory& base, const Eigen::Matrix3d& R_T_B)
      : base_(base), R_T_B_(R_T_B) {}
  KinematicState Evaluate(double t) const override;

 private:
  const Trajectory& base_;
  Eigen::Matrix3d R_T_B_;
};

// The scenarios move a frame T whose -z axis is where cameras should look (scenario.h). A rig's
// B is mounted in T by the axis permutation (one of the 24 rotations by multiples of 90 deg) that
// points the optical axis of its reference camera (the first camera) closest to -z_T: identity
// for the default rig; for a camera-only rig, B is that camera and the mount is a half turn
// taking z_B to -z_T. Keeping to axis permutations keeps the degenerate scenarios exact about
// B's own axes.
Eigen::Matrix3d ScenarioMount(const RigConfig& rig);

}  // namespace ctcal::sim
