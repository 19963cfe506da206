// The continuous-time problem's solving (SplineProblem, spline_problem.h): the solves, the
// outlier gate, the re-bucketing check, the final residuals and covariance; and the solve
// stages and the whole pipeline shared by both calibrators. Included through
// spline_problem_impl.h.
#pragma once

#include "spline_problem.h"
#include "spline_problem_noise.h"

namespace ctcal {
namespace spline_internal {

template <int N, Se3Representation Rep>
ceres::Solver::Summary SplineProblem<N, Rep>::Solve() {
  IterationLogger logger(log_);
  RobustStageStop robust_stop(kRobustPredictedDecrease);
  ceres::Solver::Options so = SolverOptions(options_, &logger);
  // Gauss-Newton steps right away instead of Levenberg-Marquardt's default damping 1e-4, which
  // crawls along the weak directions: the trajectory fit starts every solve inside the basin
  // (the radius still shrinks after a rejected step). Demo: 8 robust iterations -> 2.
  so.initial_trust_region_radius = 1e8;
  // No Jacobi scaling: CHOLMOD's Cholesky is indifferent to a diagonal scaling of the normal
  // equations, and Levenberg-Marquardt's damping is relative to diag(J^T J) with or without
  // it, so the scaling only cost a pass over J per evaluation and one per linear solve, serial
  // in Ceres (~4 % of the demo's CPU; docs/performance.md step 7c).
  so.jacobi_scaling = false;
  if (robust_) {
    // The robust solve only seeds the outlier gate and the plain solve: a relative cost change
    // of 1e-6 (~0.5 at the demo's cost) is enough.
    so.function_tolerance = 1e-6;
    if (options_.robust_early_stop)
      so.callbacks.push_back(&robust_stop);
  } else if (options_.stop_cost_change > 0.0 && last_cost_ > 0.0) {
    // Stop when a step would lower the cost by less than stop_cost_change
    // (SplineCalibratorOptions derives the sigma bound); Ceres' tolerance is relative to the
    // current cost.
    so.function_tolerance = std::max(so.function_tolerance, options_.stop_cost_change / last_cost_);
  }
  ceres::Solver::Summary summary;
  solver_.reset();
  if (options_.lm_solver) {
    // The estimated calibration blocks couple to nearly every residual: the dense border. The
    // solver stays for the covariance (Finish), which needs H at the last solve's final point.
    std::vector<double*> border;
    for (const ParameterBlockInfo& b : blocks_) {
      if (b.estimated)
        border.push_back(b.values);
    }
    if (factorisation_ == nullptr)
      factorisation_ = MakeNuisanceFactorisation();
    solver_ = std::make_unique<LevenbergMarquardt>(
        so, border, problem_.get(), point_in_memory_used_ ? &point_in_memory_ : nullptr,
        factorisation_);
    // The plain solves' stopping rule is about the calibration (the border), whose scalars the
    // result reports: stop once the step would move it by < stop_cost_change in its marginal
    // metric, however the trajectory still moves (EuRoC's knots crawl along directions its
    // calibration barely sees; docs/performance.md, issue 23 session 15).
    if (!robust_ && options_.stop_cost_change > 0.0)
      solver_->StopOnBorderDecrease(options_.stop_cost_change);
    // The solver that holds less: long recordings' compressed inertial blocks span many knots,
    // and their band can exceed Ceres' Jacobian and J^T J together (10 min at 1 kHz). Since the
    // threads share one H (lm_solver.cpp PartitionBlocks), EuRoC's 36 s (34 MB against 49 MB)
    // and the demo solve here (docs/performance.md, issue 23).
    const bool ceres_solves = solver_->NormalEquationsBytes() > solver_->CeresBytes();
    char line[160];
    std::snprintf(line, sizeof line,
                  "    normal equations %.0f MB, Ceres' Jacobian and J^T J %.0f MB: %s",
                  1e-6 * static_cast<double>(solver_->NormalEquationsBytes()),
                  1e-6 * static_cast<double>(solver_->CeresBytes()),
                  ceres_solves ? "Ceres solves" : "own Levenberg-Marquardt");
    log_(line);
    if (ceres_solves) {
      solver_.reset();
      ReleaseFreedMemory();  // its pattern, before Ceres' Jacobian takes the heap
    }
  }
  if (solver_ != nullptr)
    solver_->Solve(&summary);
  else
    ceres::Solve(so, problem_.get(), &summary);
  last_cost_ = summary.final_cost;
  if (summary.termination_type == ceres::FAILURE || !std::isfinite(summary.final_cost))
    throw CalibrationFailure("the solve diverged (" + summary.message +
                             "): " + DivergenceCulprit() +
                             ": check its initial guesses and noise settings");
  return summary;
}

template <int N, Se3Representation Rep>
std::string SplineProblem<N, Rep>::DivergenceCulprit() {
  std::vector<std::pair<std::string, double>> cost;  // sum of squared whitened residuals
  for (const PreparedCamera& cam : prep_.cameras) {
    double sum = 0.0;
    for (std::size_t i = 0; i < cam.corners.size(); ++i) {
      Eigen::Vector2d e;
      if (cam.removed[i])
        continue;
      sum += EvaluateCorner(cam, i, &e) ? e.squaredNorm() : std::numeric_limits<double>::infinity();
    }
    cost.emplace_back(cam.state->name(), sum);
  }
  for (const auto& [name, ids] : inertial_ids_) {
    double sum = 0.0;
    for (const ceres::ResidualBlockId id : ids) {
      double c = 0.0;
      sum += problem_->EvaluateResidualBlock(id, false, &c, nullptr, nullptr)
                 ? 2.0 * c
                 : std::numeric_limits<double>::infinity();
    }
    cost.emplace_back(name, sum);
  }
  double total = 0.0;
  const std::pair<std::string, double>* largest = nullptr;
  for (const auto& c : cost) {
    if (!std::isfinite(c.second))
      return "the whitened residuals of sensors." + c.first + " are not finite";
    total += c.second;
    if (largest == nullptr || c.second > largest->second)
      largest = &c;
  }
  if (largest == nullptr)
    return "no residual to blame";
  char share[64];
  std::snprintf(share, sizeof share, "%.0f %%", 100.0 * largest->second / std::max(total, 1e-300));
  return "sensors." + largest->first + " holds the largest share of the cost (" + share + ")";
}

template <int N, Se3Representation Rep>
void SplineProblem<N, Rep>::RemoveOutliers(double probability,
                                           std::vector<CameraOutliers>* report) {
  const double gate = -2.0 * std::log(1.0 - probability);  // chi-square, 2 dof
  std::vector<Eigen::Vector2d> e;
  std::vector<char> ok;
  for (PreparedCamera& cam : prep_.cameras) {
    CameraOutliers o;
    o.camera = cam.state->name();
    o.views = static_cast<int>(cam.views.size());
    o.invalid = cam.invalid;
    EvaluateCameraCorners(cam, &e, &ok);
    for (std::size_t i = 0; i < cam.corners.size(); ++i) {
      if (cam.removed[i])
        continue;
      ++o.corners;
      if (!ok[i] || e[i].squaredNorm() > gate) {
        cam.removed[i] = true;
        ++o.removed;
      }
    }
    report->push_back(o);
  }
}

template <int N, Se3Representation Rep>
int SplineProblem<N, Rep>::CountRebucket() const {
  constexpr double kRebucketTolerance = 0.02;
  int changed = 0;
  std::size_t i = 0;
  ForEachSegment([&](double coordinate) {
    if (i >= segments_.size()) {
      ++changed;
    } else if (segments_[i] != ClampSegment(coordinate)) {
      const double u = coordinate - segments_[i];
      if (u < -kRebucketTolerance || u > 1.0 + kRebucketTolerance)
        ++changed;
    }
    ++i;
  });
  return changed;
}

template <int N, Se3Representation Rep>
std::string SplineProblem<N, Rep>::NextRebuild() {
  const int changed = CountRebucket();
  return changed == 0 ? std::string()
                      : std::to_string(changed) +
                            " residuals moved to another spline segment with the time offsets: "
                            "re-bucketed";
}

template <int N, Se3Representation Rep>
void SplineProblem<N, Rep>::CollectResiduals(std::vector<CornerResiduals>* corners_out,
                                             std::vector<InertialResidualSums>* inertial_out) {
  // Every corner on its own (the problem may hold them compressed), frames on the threads.
  std::vector<CornerResiduals>& corners = *corners_out;
  corners.assign(prep_.cameras.size(), CornerResiduals{});
  std::vector<Eigen::Vector2d> e;
  std::vector<char> ok;
  for (std::size_t k = 0; k < prep_.cameras.size(); ++k) {
    const PreparedCamera& cam = prep_.cameras[k];
    CornerResiduals& c = corners[k];
    c.camera = cam.state->name();
    EvaluateCameraCorners(cam, &e, &ok);
    const auto left = static_cast<std::size_t>(std::count(ok.begin(), ok.end(), char{1}));
    c.whitened.reserve(left);
    c.sigma_px.reserve(left);
    c.frame.reserve(left);
    for (std::size_t i = 0; i < cam.corners.size(); ++i) {
      if (!ok[i])
        continue;
      c.whitened.push_back(e[i]);
      c.sigma_px.push_back(cam.corners[i].sigma_px);
      c.frame.push_back(cam.corners[i].frame);
    }
  }
  // Inertial samples one by one too (the problem may hold them compressed per run of segments).
  std::vector<InertialResidualSums>& inertial = *inertial_out;
  inertial.clear();
  for (PreparedInertial& in : prep_.inertial) {
    InertialResidualSums sums;
    sums.sensor = in.state->name();
    const auto windows = static_cast<std::size_t>(in.NumWindows());
    sums.window_gyro.assign(windows, 0.0);
    sums.window_accel.assign(windows, 0.0);
    sums.window_samples.assign(windows, 0);
    VisitSamples(in, [&](auto& set, auto&& blocks_of) {
      using R = typename std::decay_t<decltype(set)>::Residual;
      double r[R::kNumResiduals];
      for (std::size_t i = 0; i < set.functors.size(); ++i) {
        const std::vector<double*> blocks = blocks_of(set.seg[i], set.bseg[i]);
        R::Analytic::EvaluateSample(set.functors[i], blocks.data(), r, nullptr);
        const auto w = static_cast<std::size_t>(in.WindowOf(set.bseg[i]));
        for (int k = 0; k < R::kNumResiduals; ++k) {
          (k < 3 ? sums.gyro : sums.accel) += r[k] * r[k];
          (k < 3 ? sums.window_gyro : sums.window_accel)[w] += r[k] * r[k];
        }
        ++sums.window_samples[w];
      }
      sums.samples += static_cast<std::int64_t>(set.functors.size());
    });
    inertial.push_back(sums);
  }
}

template <int N, Se3Representation Rep>
void SplineProblem<N, Rep>::Finish(SplineCalibrationResult* out) {
  std::vector<CornerResiduals> corners;
  std::vector<InertialResidualSums> inertial;
  CollectResiduals(&corners, &inertial);
  // The covariance from the last solve's normal equations at its final point, where it has them.
  std::optional<SolvedInformation> solved;
  if (solver_ != nullptr) {
    solved.emplace();
    solved->blocks = solver_->Border();
    solved->information = solver_->MarginalizeToBorder();
    solver_.reset();
  }
  FinishResult(*problem_, state_, prior_ids_, corners, inertial, options_, log_, out,
               solved ? &*solved : nullptr);
}

template <int N, Se3Representation Rep>
bool SplineProblem<N, Rep>::EvaluateCorner(const PreparedCamera& cam, std::size_t i,
                                           Eigen::Vector2d* e) {
  SensorState& s = *cam.state;
  const std::int64_t stamp = cam.Stamp(i);
  const int seg = SegmentOf(stamp, s.time_offset + cam.corners[i].uv.y() * s.line_delay);
  const std::unique_ptr<ceres::CostFunction> cost(MakeCameraCornerResidual<N, Rep>(
      true, *s.camera, cam.Measurement(i), SegmentClock::At(stamp, spline_.timing(), seg)));
  typename CornerResidual<N, Rep>::Parameters p;
  p.traj = TrajBlocks(seg);
  p.q_B_C = s.q_B_S.data();
  p.t_B_C = s.t_B_S.data();
  p.time_offset = &s.time_offset;
  p.line_delay = &s.line_delay;
  p.params = s.camera->mutable_params();
  const std::vector<double*> blocks = CornerResidual<N, Rep>::Blocks(p);
  return cost->Evaluate(blocks.data(), e->data(), nullptr) && e->allFinite();
}

template <int N, Se3Representation Rep>
void SplineProblem<N, Rep>::EvaluateCameraCorners(const PreparedCamera& cam,
                                                  std::vector<Eigen::Vector2d>* e,
                                                  std::vector<char>* ok) {
  e->assign(cam.corners.size(), Eigen::Vector2d::Zero());
  ok->assign(cam.corners.size(), 0);
  std::vector<std::pair<std::size_t, std::size_t>> frames;
  ForEachFrame(cam, [&](std::size_t first, std::size_t last) { frames.emplace_back(first, last); });
  SensorState& s = *cam.state;
  const auto one_by_one = [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i)
      (*ok)[i] = !cam.removed[i] && EvaluateCorner(cam, i, &(*e)[i]);
  };
  // A line delay gives every corner its own time; an mrcal lens has no compile-time model.
  if (s.line_delay != 0.0 || s.camera->mrcal_lens() != nullptr) {
    ParallelFor(options_.threads, frames.size(),
                [&](std::size_t f) { one_by_one(frames[f].first, frames[f].second); });
    return;
  }
  VisitCameraModel(s.camera->type(), [&](auto model) {
    using Model = decltype(model);
    const Eigen::Matrix3d R_B_C =
        Eigen::Map<const Eigen::Quaterniond>(s.q_B_S.data()).toRotationMatrix();
    const Eigen::Vector3d t_B_C = Eigen::Map<const Eigen::Vector3d>(s.t_B_S.data());
    const double* params = s.camera->mutable_params();
    ParallelFor(options_.threads, frames.size(), [&](std::size_t f) {
      const auto [first, last] = frames[f];
      // CornerResidual::Analytic's residual-only evaluation (WhitenedCornerResidual,
      // corner_residual.h), its pose shared: the shift time_offset + v line_delay is time_offset
      // for every corner here (no line delay on this path).
      const std::int64_t stamp = cam.Stamp(first);
      const double shift = s.time_offset;
      const int seg = SegmentOf(stamp, shift);
      const SegmentClock clock = SegmentClock::At(stamp, spline_.timing(), seg);
      const std::vector<double*> blocks = TrajBlocks(seg);
      Se3Kinematics<double> kin;
      Spline::template EvaluateSegment<double>(blocks.data(), clock.U(shift), clock.inv_dt, 0,
                                               nullptr, &kin, nullptr);
      for (std::size_t i = first; i < last; ++i) {
        if (cam.removed[i])
          continue;
        CornerPoints points;
        if (!WhitenedCornerResidual<Model>(cam.Measurement(i), kin.R_W_B, kin.p_W_B, R_B_C, t_B_C,
                                           params, &points, &(*e)[i]))
          continue;
        (*ok)[i] = (*e)[i].allFinite();
      }
    });
  });
}

template <int N, Se3Representation Rep>
template <class F>
void SplineProblem<N, Rep>::ForEachSegment(F&& f) const {
  for (const PreparedCamera& cam : prep_.cameras) {
    const SensorState& s = *cam.state;
    if (Compressed(cam)) {
      ForEachFrame(cam, [&](std::size_t first, std::size_t last) {
        if (AnyLeft(cam, first, last))
          f(SegmentCoordinate(cam.Stamp(first), s.time_offset));
      });
      continue;
    }
    for (std::size_t i = 0; i < cam.corners.size(); ++i) {
      if (cam.removed[i])
        continue;
      f(SegmentCoordinate(cam.Stamp(i), s.time_offset + cam.corners[i].uv.y() * s.line_delay));
    }
  }
  for (const PreparedInertial& in : prep_.inertial) {
    const double shift = in.state->is_base ? 0.0 : in.state->time_offset;
    for (const ImuSample& z : in.imu)
      f(SegmentCoordinate(z.t_ns, shift));
    for (const GyroSample& z : in.gyro)
      f(SegmentCoordinate(z.t_ns, shift));
  }
}

// The solve stages of both calibrators on a problem type P (SplineProblem, the discrete
// problem): robust solve, the outlier gate, P::BeforePlainSolve() (the discrete problem re-places
// its keyframes there), the plain solve, then up to `max_rounds` rebuilds and re-solves while
// P::NextRebuild() names a reason (after preparing the rebuild; empty: none needed).
// `solve(title)` runs and logs one solve. Returns the last plain solve's summary.
template <class P, class SolveFn>
ceres::Solver::Summary RunStages(P* p, const SolveFn& solve, double outlier_probability,
                                 int max_rounds, const CalibrationLog& log,
                                 std::vector<CameraOutliers>* outliers) {
  p->Build(true);
  solve("[4/6] robust solve (Huber on the corners)");
  p->RemoveOutliers(outlier_probability, outliers);
  LogOutliers(*outliers, outlier_probability, log);
  p->BeforePlainSolve();
  p->Build(false);
  ceres::Solver::Summary last = solve("[5/6] final solve (plain L2)");
  for (int round = 0; round < max_rounds; ++round) {
    const std::string why = p->NextRebuild();
    if (why.empty())
      break;
    log("  " + why);
    p->Build(false);
    last = solve("  re-solve");
  }
  return last;
}

// The whole pipeline for one spline type (stages 1-4 of spline_calibrator.h).
template <int N, Se3Representation Rep>
void RunPipeline(Prepared* prep, const SplineCalibratorOptions& options, const CalibrationLog& log,
                 SplineCalibrationResult* out) {
  using Clock = std::chrono::steady_clock;
  SplineProblem<N, Rep> sp(prep, options, log);
  out->knot_spacing_s = prep->knot_spacing_s;
  out->num_knots = sp.NumKnots();
  log("[3/6] initialising the trajectory spline");
  sp.InitializeTrajectory();
  {
    const Eigen::Vector3d g = prep->state->gravity();
    char line[120];
    std::snprintf(line, sizeof line, "  gravity_W initialised to [%.4f, %.4f, %.4f]", g.x(), g.y(),
                  g.z());
    log(line);
  }
  int iterations = 0;
  double solve_seconds = 0.0;
  const auto solve = [&](const char* what) {
    log(what);
    const std::clock_t cpu0 = std::clock();
    const ceres::Solver::Summary s = sp.Solve();
    const double cpu = static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
    iterations += static_cast<int>(s.iterations.size()) - 1;
    solve_seconds += s.total_time_in_seconds;
    char line[300];
    std::snprintf(line, sizeof line, "  %s: cost %.6e -> %.6e, %d iterations, %.2f s",
                  ceres::TerminationTypeToString(s.termination_type), s.initial_cost, s.final_cost,
                  static_cast<int>(s.iterations.size()) - 1, s.total_time_in_seconds);
    log(line);
    // Where the time went (wall, except the process CPU time over all threads): the profile of
    // docs/performance.md.
    std::snprintf(line, sizeof line,
                  "    time: residual %.2f s, jacobian %.2f s, linear solver %.2f s, other %.2f s; "
                  "%d linear solves, %d residual blocks, %d rows; CPU %.2f s",
                  s.residual_evaluation_time_in_seconds, s.jacobian_evaluation_time_in_seconds,
                  s.linear_solver_time_in_seconds,
                  s.total_time_in_seconds - s.residual_evaluation_time_in_seconds -
                      s.jacobian_evaluation_time_in_seconds - s.linear_solver_time_in_seconds,
                  s.num_linear_solves, s.num_residual_blocks, s.num_residuals, cpu);
    log(line);
    ReleaseFreedMemory();  // Ceres' Jacobian and factor of this solve
    LogMemory(log, "solved");
    return s;
  };
  ceres::Solver::Summary last = RunStages(&sp, solve, options.outlier_probability,
                                          options.max_rebucket_rounds, log, &out->outliers);
  std::optional<StatedNoise> stated;
  if (options.estimate_noise && options.noise_rounds > 0) {
    stated = KeepStatedNoise(*prep);
    EstimateNoise(
        &sp, prep,
        [&](const char* what) {
          last = solve(what);
          return last;
        },
        options, log, out);
  }
  out->iterations = iterations;
  out->solve_seconds = solve_seconds;
  out->seconds_per_iteration = iterations > 0 ? solve_seconds / iterations : 0.0;
  SolverSummary summary;
  summary.method = "spline";
  summary.iterations = iterations;
  summary.final_cost = last.final_cost;
  summary.seconds = solve_seconds;
  out->result.solver = summary;
  log("[6/6] covariance and residuals");
  const auto t_cov = Clock::now();
  const std::clock_t cpu_cov = std::clock();
  sp.Finish(out);
  if (stated)
    ReportNoise(*stated, *prep, log, out);
  sp.ReleaseProblem();  // the report data need the spline only
  ReleaseFreedMemory();
  out->covariance_seconds = std::chrono::duration<double>(Clock::now() - t_cov).count();
  {
    char line[160];
    std::snprintf(line, sizeof line, "  covariance and residual statistics: %.2f s (CPU %.2f s)",
                  out->covariance_seconds,
                  static_cast<double>(std::clock() - cpu_cov) / CLOCKS_PER_SEC);
    log(line);
    LogMemory(log, "covariance");
  }
  if (options.report_data) {
    const auto t_report = Clock::now();
    out->report_data = SplineReportData(
        *prep, [&sp](std::int64_t t_ns, int d) { return sp.EvaluateClamped(t_ns, d); }, *out);
    char line[120];
    std::snprintf(line, sizeof line, "  report data: every measurement at the final values, %.2f s",
                  std::chrono::duration<double>(Clock::now() - t_report).count());
    log(line);
    LogMemory(log, "report data");
  }
}

}  // namespace spline_internal
}  // namespace ctcal
