// The continuous-time calibrator (`ctcal calibrate --method spline`): one sparse Ceres problem over
// the base IMU trajectory T_W_B(t) (an SE(3) B-spline), bias splines of every inertial sensor and
// every estimated calibration quantity, started from a close guess (docs/calibrator.md).
//
// Stages, each separable so that a coarse-guess initialisation can replace the first one:
//   1. initialise: board poses by PnP per camera frame, base poses T_W_B = T_W_C T_B_C^-1 at
//      stamp + time_offset, the trajectory spline and gravity fitted to them and to the base
//      IMU (spline_init.h, src/spline_trajectory_fit.h), biases seeded by the initialisation;
//   2. robust solve (Huber on the whitened corner residuals);
//   3. outliers removed (whitened corner residual beyond the chi-square gate), plain L2 solve,
//      residuals re-bucketed onto the spline segment their time offsets now select, re-solved;
//   4. marginal covariance of the calibration (trajectory and biases marginalised), per-sensor
//      residual statistics, the result rig.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "ctcal/calibrator/init/coarse_init.h"
#include "ctcal/calibrator/noise/variance_components.h"
#include "ctcal/report/report_data.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig.h"
#include "ctcal/spline/se3_spline.h"

namespace ctcal {

// Bad input (a camera that never sees the board, too few views, time ranges that do not overlap):
// the message names the sensor.
class CalibrationInputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A run that could not complete on valid input (a diverging solve: NaN, no convergence).
class CalibrationFailure : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct SplineCalibratorOptions {
  int order = 4;  // trajectory spline order N: 4, 5 or 6
  Se3Representation representation = Se3Representation::kSplit;
  // Knot spacing of the trajectory (s); 0 = from the data: by fit (knot_fit.h), or from the
  // motion's bandwidth (knot_spacing.h) with knot_spacing_by_fit false.
  double knot_spacing_s = 0.0;
  // Off by default until its real-recording numbers are measured (issue 19): the bandwidth rule.
  bool knot_spacing_by_fit = false;
  // Knot spacing of the (linear) bias splines, s.
  double bias_knot_spacing_s = 1.0;
  bool analytic = true;  // false: the same residuals through ceres::Jet (--autodiff)
  // Global-shutter corners as one compressed block per frame (analytic path only); false: one
  // block per corner (for benchmarks and tests of the compression).
  bool compress_frames = true;
  // A compressed frame whose intrinsics are estimated as two residual blocks, its pose rows over
  // every block and its intrinsic rows over the intrinsics only (frame_corners_residual.h): the
  // frames' Jacobian in Ceres 48 % smaller (10 min at 2 x 20 Hz: -43 MB), for a second
  // factorisation of each frame per Jacobian evaluation. 1: always, 0: never, -1: for the cameras
  // with more than kSplitFrameRowsAbove views (long recordings, where the memory matters; not the
  // 60 s demo's 1200 per camera).
  int split_frame_rows = -1;
  static constexpr int kSplitFrameRowsAbove = 5000;
  // Inertial samples as one compressed block per sensor and run of spline segments (analytic path
  // only; inertial_block_residual.h) where that at least halves Ceres' J^T J work (1 kHz IMUs, not
  // the 200-300 Hz sensors of the demo); false: one block per sample everywhere (no stacked
  // blocks either). inertial_block_segments > 0 forces that run length on every inertial sensor
  // (benchmarks and tests).
  bool compress_inertial = true;
  int inertial_block_segments = 0;
  // A compressed inertial block as groups of its factor's rows, each over the blocks it touches
  // (inertial_row_groups.h): the same normal equations, -39 % of those blocks' Jacobian in Ceres
  // (10 min of a 1 kHz IMU: ~-88 MB), one factorisation per run and point shared by its groups.
  bool split_inertial_rows = true;
  // Where the compression does not pay (the demo's rates), the samples of a run of
  // `stacked_inertial_segments` segments as one uncompressed block (the same rows: fewer blocks
  // for Ceres' per-block work; inertial_block_residual.h); 0: one block per sample there.
  int stacked_inertial_segments = 1;
  int threads = 0;  // 0 = every core
  int max_iterations = 50;
  // Huber threshold on the norm of a whitened corner residual during the robust solve.
  double huber_threshold = 3.0;
  // Chi-square gate (probability) on the whitened corner residuals for the outlier removal.
  double outlier_probability = 0.999;
  int min_corners_per_view = 8;
  int min_views = 10;
  int max_rebucket_rounds = 3;
  // The plain solves stop once a step would lower the cost F (1/2 sum of squared whitened
  // residuals) by less than this. Near the optimum a Gauss-Newton step lands on it and lowers F by
  // 1/2 |x - x*|^2 in the information metric, which bounds every scalar's distance to the
  // converged estimate by sqrt(2 stop_cost_change) of its sigma: 0.005 -> 0.1 sigma. The own
  // solver also stops once the step's share of the calibration alone (the trajectory and biases
  // marginalised) is predicted below it, which bounds the calibration's scalars the same way
  // (lm_solver.h StopOnBorderDecrease). 0: Ceres' relative tolerances of 1e-10 alone (the fully
  // converged reference).
  double stop_cost_change = 0.005;
  // The robust solve stops once the next step is predicted to lower the cost by < 1e-4 of it
  // (spline_problem.h RobustStageStop) instead of computing that step; false: Ceres'
  // relative function tolerance of 1e-6 alone.
  bool robust_early_stop = true;
  // The spline solves by SolveLevenbergMarquardt (lm_solver.h: Ceres' Levenberg-Marquardt with
  // J^T J assembled on `threads` threads, the calibration blocks as the Schur border); false:
  // ceres::Solve (the reference of the tests).
  bool lm_solver = true;
  // The noise weighting the final solve and the covariance: estimated from the data by variance
  // component estimation, the stated noise the start (docs/noise_estimation.md); false: the
  // stated noise throughout (`--noise stated`, the behaviour before the estimation).
  // Off by default until validated end to end on real recordings (issue 19): `--noise estimate`.
  bool estimate_noise = false;
  // At most this many rounds of estimate -> reweight -> re-solve; they stop once every sigma moves
  // by < 0.5 %.
  int noise_rounds = 4;
  // Per-frame scales of a camera's corner sigmas, shrunk toward the camera's own with this many
  // pseudo-residuals (ShrunkFrameVariance); 0: one scale per camera.
  double frame_weight_prior = 0.0;
  // Per-window (~2 s) scales of an inertial sensor's white noise, shrunk toward the sensor's with
  // this many pseudo-residuals; 0: one level per sensor.
  double window_weight_prior = 200.0;
  RedundancyOptions redundancy;
  bool compute_covariance = true;
  // Measured vs predicted of every sample, the trajectory, the correlation: the report's data
  // (report_data_builder.h), in SplineCalibrationResult::report_data.
  bool report_data = true;
  // The coarse-guess initialisation before the trajectory is built (init/coarse_init.h).
  CoarseInitOptions coarse_init;
};

struct CameraOutliers {
  std::string camera;
  int corners = 0;  // corner residuals in the problem before removal
  int removed = 0;  // beyond the gate
  int invalid = 0;  // not projectable at the initial guess (never added)
  int views = 0;    // frames with a board pose
};

struct SplineCalibrationResult {
  RigConfig result;  // values, sigma, solver, residuals, observability (SPEC section 7)
  std::vector<CameraOutliers> outliers;
  double knot_spacing_s = 0.0;
  int num_knots = 0;
  int iterations = 0;
  double init_seconds = 0.0;   // coarse-guess initialisation, board views and data selection
  double solve_seconds = 0.0;  // the Ceres solves
  double seconds_per_iteration = 0.0;
  double covariance_seconds = 0.0;
  double total_seconds = 0.0;
  std::vector<std::string> warnings;
  // The noise estimation's rounds (0 with --noise stated) and every group's final statistics.
  int noise_rounds = 0;
  std::vector<VarianceComponent> noise_components;
  // Per inertial sensor, the whitened RMS of its gyro and accelerometer rows per noise window
  // (~2 s, whole bias-spline segments from the start of its samples; accel 0 for a gyro).
  std::map<std::string, std::vector<std::pair<double, double>>> window_rms_whitened;
  // Per camera, each frame's image stamp and the RMS of its corners' sigmas as the final solve
  // weighed them (px; the per-frame weights, frame_weight_prior); empty with --noise stated.
  std::map<std::string, std::vector<std::pair<std::int64_t, double>>> frame_sigma_px;
  // Tangent-space covariance of the estimated quantities, priors included (the left perturbation
  // for rotations, gravity as its 2-dof sphere tangent gravity_W.direction[i]), and the sigma of
  // the data alone (.inf where undetermined), per `covariance_names`; empty without covariance.
  std::vector<std::string> covariance_names;
  Eigen::MatrixXd covariance;
  Eigen::VectorXd data_sigma;
  report::ReportData report_data;  // everything but run_info (the caller's; report_data_builder.h)
};

// Receives every progress line (stages, iterations with their cost, warnings).
using CalibrationLog = std::function<void(const std::string&)>;

// Throws CalibrationInputError naming the option for options no calibration can run with (the
// order, knot spacings, iterations); CalibrateSpline checks them first, a command line can check
// them before it reads any data.
void CheckOptions(const SplineCalibratorOptions& options);

// Throws CalibrationInputError / CalibrationFailure as above.
SplineCalibrationResult CalibrateSpline(const RigConfig& rig,
                                        const std::map<std::string, SensorData>& data,
                                        const SplineCalibratorOptions& options,
                                        const CalibrationLog& log);
// The same, taking the data over: the cameras' loaded corners are released once the calibrator has
// selected its own (a 10 min recording's ~3 M corners hold ~140 MB; docs/performance.md, step 7).
SplineCalibrationResult CalibrateSpline(const RigConfig& rig,
                                        std::map<std::string, SensorData>&& data,
                                        const SplineCalibratorOptions& options,
                                        const CalibrationLog& log);

// The final table of the terminal: one row per estimated scalar with its value and sigma.
std::string FormatParameterTable(const RigConfig& result);

}  // namespace ctcal
