// The discrete MVIS calibrator's entry (discrete_calibrator.h): the spline method's
// initialisation and data selection, then the discrete problem's stages (discrete_problem.h).
#include "ctcal/calibrator/discrete_calibrator.h"

#include <chrono>
#include <cstdio>
#include <thread>

#include "discrete_problem.h"

namespace ctcal {

using discrete_internal::DiscreteProblem;
using discrete_internal::Fmt;
using spline_internal::Prepared;

DiscreteCalibrationResult CalibrateDiscrete(const RigConfig& rig,
                                            const std::map<std::string, SensorData>& data,
                                            const DiscreteCalibratorOptions& options_in,
                                            const CalibrationLog& log) {
  using Clock = std::chrono::steady_clock;
  const auto t_start = Clock::now();
  DiscreteCalibratorOptions options = options_in;
  if (options.threads <= 0)
    options.threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  if (rig.IsCameraOnly())
    throw CalibrationInputError("camera-only rigs have no inertial states: use --method spline");
  for (const SensorConfig& s : rig.sensors) {
    // The discrete method's corner factors are compiled per SPEC section 4 model.
    if (s.type == SensorType::kCamera && s.camera_model == "mrcal")
      throw CalibrationInputError("sensors." + s.name +
                                  ": camera_model mrcal runs with --method spline only");
  }
  SplineCalibratorOptions so;
  so.threads = options.threads;
  so.max_iterations = options.max_iterations;
  so.huber_threshold = options.huber_threshold;
  so.outlier_probability = options.outlier_probability;
  so.min_corners_per_view = options.min_corners_per_view;
  so.min_views = options.min_views;
  so.compute_covariance = options.compute_covariance;
  so.stop_cost_change = options.stop_cost_change;
  // The stated noise and the bandwidth rule's knots, as before the spline method's noise
  // estimation (docs/noise_estimation.md covers the spline method only).
  so.estimate_noise = false;
  so.knot_spacing_by_fit = false;

  log("[1/6] rig: " + std::to_string(rig.sensors.size()) + " sensors, base " + rig.base_imu +
      " (discrete, aux velocity " +
      (options.aux_velocity == AuxVelocityModel::kState ? "state" : "rigid") + ")");
  CalibrationState state(rig);
  // The spline method's coarse-guess initialisation and data selection (the same start).
  const CoarseInitResult init = InitializeFromData(&state, data, so.coarse_init, log);
  Prepared prep;
  log("[2/6] board views and data selection");
  spline_internal::Prepare(&state, data, so, init, log, &prep);

  DiscreteCalibrationResult out;
  DiscreteProblem dp(&prep, options, so, log);
  log("[3/6] keyframes and their initial states (from the initial trajectory spline)");
  dp.Initialize(&out);
  out.num_keyframes = dp.NumKeyframes();

  int iterations = 0;
  double solve_seconds = 0.0;
  const auto solve = [&](const char* what) {
    log(what);
    const ceres::Solver::Summary s = dp.Solve();
    iterations += static_cast<int>(s.iterations.size()) - 1;
    solve_seconds += s.total_time_in_seconds;
    char line[200];
    std::snprintf(line, sizeof line, "  %s: cost %.6e -> %.6e, %d iterations, %.2f s",
                  ceres::TerminationTypeToString(s.termination_type), s.initial_cost, s.final_cost,
                  static_cast<int>(s.iterations.size()) - 1, s.total_time_in_seconds);
    log(line);
    return s;
  };
  const ceres::Solver::Summary last = spline_internal::RunStages(
      &dp, solve, options.outlier_probability, options.max_rebuild_rounds, log, &out.outliers);
  out.keyframe_rechoices = dp.Rechoices();
  out.num_keyframes = dp.NumKeyframes();
  dp.CountInterpolation(&out.num_kinematic_corners, &out.num_geodesic_corners);
  log(Fmt("  %.0f keyframes; corners interpolated by A.1: %.0f, by A.2: %.0f",
          static_cast<double>(out.num_keyframes), static_cast<double>(out.num_kinematic_corners),
          static_cast<double>(out.num_geodesic_corners)));
  out.iterations = iterations;
  out.solve_seconds = solve_seconds;
  out.seconds_per_iteration = iterations > 0 ? solve_seconds / iterations : 0.0;
  SolverSummary summary;
  summary.method = "discrete";
  summary.iterations = iterations;
  summary.final_cost = last.final_cost;
  summary.seconds = solve_seconds;
  out.result.solver = summary;
  log("[6/6] covariance and residuals");
  const auto t_cov = Clock::now();
  dp.Finish(&out);
  CompleteObservability(rig, data, &out.result, log, &out.warnings);
  out.covariance_seconds = std::chrono::duration<double>(Clock::now() - t_cov).count();
  out.total_seconds = std::chrono::duration<double>(Clock::now() - t_start).count();
  if (out.result.solver)
    out.result.solver->seconds = out.total_seconds;
  return out;
}

}  // namespace ctcal
