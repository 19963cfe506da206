// The report data (report/report_data.h) of a finished calibration: every measurement of the
// final solve next to the model's prediction of it, evaluated directly from the final values
// (the sensors' CalibrationState and a trajectory evaluator), not read back from the solver's
// residual blocks, so any formulation (spline, discrete) that can say where the base IMU was can
// produce it.
//
// What each file holds and why:
//   corners   per camera, every corner the final solve was given, the removed outliers included
//             (flagged): the corner was read at base-clock time t = t_S + time_offset + v_meas *
//             line_delay (SPEC section 2), so with T_W_B(t) and T_B_C
//               p_C = R_B_C^T (R_W_B^T (p_W - p_W_B) - t_B_C),  uv_pred = project(p_C),
//             du, dv = uv_meas - uv_pred, whitened = |(du, dv)| / sigma (the corner residual's
//             model, corner_residual.h).
//   inertial  per inertial sensor, every sample of the solve: the base IMU predicts
//             ImuRawFromTrue(w_B, f_B, b_g, b_a) at its own stamp; an auxiliary IMU at t_S +
//             time_offset with the lever arm (w_S = R_B_S^T w_B, a_S = R_B_S^T (f_B + alpha_B x r
//             + w_B x (w_B x r)), r = t_B_S); a gyroscope GyroRawFromTrue(R_B_S^T w_B, b_g). Biases
//             are read at the stamp on the sensor's own clock (inertial_support.h).
//   bias      per inertial sensor, the estimated bias b(t) at every 10th sample with the +-3 sigma
//             random-walk envelope of Kalibr's bias plots: sigma(t) = sigma_rw sqrt(t - t_first),
//             the spread the stated random walk (noise: gyroscope_random_walk /
//             accelerometer_random_walk) allows the true bias to wander from its value at the first
//             sample. The report draws it around b(t_first): a track leaving it says the stated
//             random walk is too small (or the bias absorbs an unmodelled effect). Why not the
//             estimate's marginal sigma: that needs a second Schur complement over the bias knots,
//             as expensive as the calibration covariance itself, and it answers a question the
//             plot does not ask (how well the bias is known, rather than whether it behaves as the
//             noise model says).
//   trajectory T_W_B sampled at `trajectory_rate_hz` over the solve's time range.
//   correlation the calibration parameters' correlation, from the marginal covariance
//             (undetermined parameters: NaN rows and columns).
//   run_info  given by the caller (configuration), with the library versions appended.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "ctcal/calibrator/calibration_state.h"
#include "ctcal/report/report_data.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/spline/se3_spline.h"

namespace ctcal {

// Base IMU kinematics at base-clock time t_ns with derivatives up to `derivatives` (0: pose, 1:
// + w_B, v_W, 2: + alpha_B, a_W). Must answer on the whole [t0_ns, t1_ns] of ReportInputs and a
// little beyond (time offsets move samples off the ends; extrapolate as the solve did).
using TrajectoryEvaluator =
    std::function<Se3Kinematics<double>(std::int64_t t_ns, int derivatives)>;

// One corner the final solve was given.
struct ReportCorner {
  std::int64_t t_ns = 0;  // image stamp, camera clock
  int corner_id = 0;
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();  // the board corner (world = board frame)
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();   // measured, px
  double sigma_px = 1.0;
  bool outlier = false;  // removed before the final solve
};

// An inertial sensor's biases at time t_ns on its own clock (b_a: left alone for a gyroscope).
using BiasEvaluator =
    std::function<void(std::int64_t t_ns, Eigen::Vector3d* b_g, Eigen::Vector3d* b_a)>;

struct ReportInputs {
  std::map<std::string, std::vector<ReportCorner>> corners;  // per camera
  std::map<std::string, std::vector<ImuSample>> imu;         // per IMU: the samples of the solve
  std::map<std::string, std::vector<GyroSample>> gyro;       // per gyroscope
  std::int64_t t0_ns = 0, t1_ns = 0;                         // trajectory range, base clock
  double trajectory_rate_hz = 20.0;
  int bias_every = 10;  // one bias row per this many samples
  // Per inertial sensor, replaces the state's bias splines (the discrete method's biases live in
  // its keyframe states).
  std::map<std::string, BiasEvaluator> bias;
};

namespace discrete {
struct Keyframe;
}

// Which keyframe the discrete formulation's residuals read at a base-clock time: A.1 from
// keyframe k (kinematic), A.2 between k and k + 1, k = -1 outside (discrete_calibrator.cpp).
struct KeyframeSlot {
  int k = -1;
  bool kinematic = true;
};

// The base motion of the discrete formulation (discrete_calibrator.h) for BuildReportData, from
// its final keyframe states (t in s from t0_ns):
//  - poses (derivatives 0: the corners, the trajectory) exactly as the corner residuals read
//    them, BaseMotionAt (discrete_residuals.h) on the keyframe(s) `slot(t)` names; outside the
//    keyframes A.1 from the nearest end keyframe;
//  - rates and accelerations (derivatives >= 1: the inertial predictions), which the discrete
//    problem never evaluates per sample (its inertial residuals are preintegrated between
//    keyframes): the C2 interpolation of the keyframe states, position quintic Hermite through
//    (p, v, a_W) and rotation R_k Exp(phi(t)) with phi cubic Hermite matching w_B at both ends,
//    w_B = Jr(phi) phi', alpha_B by central differences; a_W and w_B at a keyframe are its A.1
//    values (the base IMU's corrected reading there). The per-sample errors therefore include
//    this interpolation's error besides the noise: the discrete report's inertial whitened RMS
//    is larger than result.yaml's (docs/report.md).
// `base` (the base IMU's intrinsics) must outlive the evaluator; keyframes and g_W are copied.
TrajectoryEvaluator KeyframeTrajectory(const std::vector<discrete::Keyframe>& keyframes,
                                       ImuIntrinsics* base, const Eigen::Vector3d& g_W,
                                       std::int64_t t0_ns,
                                       std::function<KeyframeSlot(double t)> slot);

// The discrete formulation's biases, held over each keyframe interval as its preintegration
// factors use them: keyframe k's values from t_k on (t_k in s from t0_ns on the base clock; the
// sensor's own clock maps onto it by + time_offset). b_a empty for a gyroscope.
BiasEvaluator KeyframeBiases(std::vector<double> t_k, std::vector<Eigen::Vector3d> b_g,
                             std::vector<Eigen::Vector3d> b_a, std::int64_t t0_ns,
                             double time_offset);

// The correlation of a tangent-space covariance; a parameter with a non-finite or non-positive
// variance (or flagged undetermined) gets NaN in its row and column, 1 on the diagonal otherwise.
report::Correlation CorrelationFromCovariance(const Eigen::MatrixXd& covariance,
                                              const std::vector<std::string>& names,
                                              const std::vector<bool>& undetermined = {});

// "ceres", "eigen", "suitesparse" versions compiled in, as run_info rows.
report::RunInfo LibraryVersions();

// Evaluates every measurement model at the final values. Throws std::runtime_error naming the
// sensor when the state lacks one of the inputs' sensors.
report::ReportData BuildReportData(const CalibrationState& state, const ReportInputs& inputs,
                                   const TrajectoryEvaluator& trajectory);

}  // namespace ctcal
