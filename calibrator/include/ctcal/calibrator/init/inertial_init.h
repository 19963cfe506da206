// Coarse-guess initialisation, stages 4 to 6: a sensor's rotation by hand-eye on angular rates,
// an auxiliary IMU's lever arm from the accelerometers, and gravity from the base accelerometer.
// A camera's translation t_B_C is kept from the rig guess (see docs/initialisation.md).
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "ctcal/calibrator/init/angular_rates.h"
#include "ctcal/calibrator/init/init_log.h"
#include "ctcal/calibrator/spline_init.h"
#include "ctcal/sensors/dataset.h"

namespace ctcal {

struct HandEyeOptions {
  double huber_rad_s = 0.05;    // robust weight threshold on the rate residual
  double min_excitation = 0.1;  // rad/s: second singular value of the centred rates; below, the
                                // rotation about the one excited axis is undetermined
  int min_pairs = 20;
};

struct HandEyeResult {
  Eigen::Matrix3d R_B_S = Eigen::Matrix3d::Identity();
  // w_B = R_B_S w_S + c with c = b_B - R_B_S b_S: the gyro biases enter as one constant.
  Eigen::Vector3d c_B = Eigen::Vector3d::Zero();
  Eigen::Vector3d singular_values = Eigen::Vector3d::Zero();  // excitation per axis, rad/s
  double rms_rad_s = 0.0;  // RMS of the residuals w_B - R_B_S w_S - c
  int pairs = 0;
  std::string summary;
};

// Stage 4. For every sensor rate (sample or camera interval) at base time t_S + time_offset, the
// base rate over the same interval; then R_B_S and c minimise sum rho(|w_B - R_B_S w_S - c|^2).
// For fixed R the optimal c is the (weighted) mean difference, so R is Kabsch on the centred
// rates; Huber weights are re-computed and the two steps iterated (IRLS). Throws InitError
// (stage "hand-eye rotation") with too few pairs or one rotation axis only.
HandEyeResult InitRotationHandEye(const std::string& sensor_name,
                                  const std::vector<RateSample>& base_rates,
                                  const std::vector<RateSample>& sensor_rates, double time_offset,
                                  const HandEyeOptions& options = {},
                                  const InitLog& log = LogInitToStderr);
// The same with the base gyro already integrated (for repeated calls on one base).
HandEyeResult InitRotationHandEye(const std::string& sensor_name, const BaseRateIntegral& base,
                                  const std::vector<RateSample>& sensor_rates, double time_offset,
                                  const HandEyeOptions& options = {},
                                  const InitLog& log = LogInitToStderr);

struct LeverArmOptions {
  double diff_half_window = 0.02;  // s, central difference of the base gyro for alpha_B
  double huber_m_s2 = 0.5;         // robust threshold of the accelerometer residual
  double min_excitation = 0.5;     // rad/s^2 (or rad^2/s^2): smallest singular value of the
                                   // lever-arm columns per sample, RMS over samples
};

struct LeverArmResult {
  Eigen::Vector3d t_B_S = Eigen::Vector3d::Zero();        // the sensor's position in B, m
  Eigen::Vector3d c_B = Eigen::Vector3d::Zero();          // R_B_S b_a_S - b_a_B, m/s^2
  Eigen::Vector3d sigma_t_B_S = Eigen::Vector3d::Zero();  // 1-sigma from the residual scatter
  double rms_m_s2 = 0.0;
  int samples = 0;
  std::string summary;
};

// Stage 5. A rigid body's specific force at the point t_B_S differs from the base's by the
// Euler and centripetal terms (both in B):
//   R_B_S (a_S - b_a_S) = a_B - b_a_B + alpha_B x t_B_S + w_B x (w_B x t_B_S),
// which is linear in t_B_S and in c_B = R_B_S b_a_S - b_a_B. w_B is the base gyro interpolated at
// the sensor's base time t_S + time_offset, alpha_B its central difference, a_B the base
// accelerometer interpolated; solved by iteratively reweighted (Huber) linear least squares.
// Throws InitError (stage "lever arm") when the rotation does not excite all three directions.
LeverArmResult InitLeverArm(const std::string& sensor_name, const std::vector<ImuSample>& base,
                            const std::vector<ImuSample>& sensor, const Eigen::Matrix3d& R_B_S,
                            double time_offset, const LeverArmOptions& options = {},
                            const InitLog& log = LogInitToStderr);

struct GravityOptions {
  // Whole: g_W = -mean_t(R_W_B(t) a_B(t)) over the camera-covered span (the mean of acc_W is
  // dv/T, ~0 for a wave that starts and ends at rest). Window: the same mean over the window of
  // `window` seconds with the least accelerometer variance (a pause in the motion).
  enum class Method { kWhole, kLowMotionWindow };
  Method method = Method::kWhole;
  double window = 1.0;  // s
  int min_samples = 50;
};

struct GravityResult {
  Eigen::Vector3d g_W = Eigen::Vector3d::Zero();  // gravity_magnitude times the found direction
  double t0 = 0.0;                                // base-clock span used, s
  double t1 = 0.0;
  double accel_std = 0.0;  // m/s^2, accelerometer magnitude scatter in that span
  int samples = 0;
  std::string summary;
};

// Stage 6. Each base accelerometer sample measures a_B = R_W_B^T (acc_W - g_W); R_W_B(t) comes
// from the camera: R_W_C at the camera time t - cam_time_offset (slerp between views) times
// R_C_B = R_B_C^T. Throws InitError (stage "gravity") with too few samples under the views.
GravityResult InitGravity(const std::string& base_name, const std::vector<ImuSample>& base,
                          const std::string& camera_name, const std::vector<BoardView>& views,
                          const Eigen::Matrix3d& R_B_C, double cam_time_offset,
                          double gravity_magnitude, const GravityOptions& options = {},
                          const InitLog& log = LogInitToStderr);

}  // namespace ctcal
