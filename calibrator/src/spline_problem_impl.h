// The continuous-time calibration problem, templated on the trajectory spline's order N and
// representation (split / joint); instantiated in spline_problem_split.cpp / _joint.cpp and
// dispatched from spline_calibrator.cpp. Private to the calibrator library.
#pragma once

#include <ceres/ceres.h>
#include <ceres/sphere_manifold.h>

#include <Eigen/Core>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ctcal/calibrator/calibration_state.h"
#include "ctcal/calibrator/lm_solver.h"
#include "ctcal/calibrator/memory_usage.h"
#include "ctcal/calibrator/report_data_builder.h"
#include "ctcal/calibrator/residuals/residual_support.h"

// TODO(residuals): bias_random_walk_residual.h uses Jacobian<> unqualified; this using makes it
// compile until the header qualifies it.
namespace ctcal {
using residual_internal::Jacobian;
}  // namespace ctcal

#include "ctcal/calibrator/residuals/frame_corners_residual.h"
#include "ctcal/calibrator/residuals/inertial_block_residual.h"
#include "ctcal/calibrator/residuals/inertial_row_groups.h"
#include "ctcal/calibrator/residuals/residuals.h"
#include "ctcal/calibrator/spline_calibrator.h"
#include "ctcal/calibrator/spline_init.h"
#include "ctcal/sensors/parallel_for.h"
#include "ctcal/spline/se3_spline.h"
#include "ctcal/spline/so3.h"
#include "ctcal/spline/so3_manifold.h"
#include "ctcal/targets/board.h"
#include "spline_trajectory_fit.h"

namespace ctcal {
namespace spline_internal {

// The order of the bias splines: linear, so that the knots are the bias at the knot times and the
// random-walk residual (b_k+1 - b_k) / (sigma_bc sqrt(dt_b)) is exactly the Wiener process' density
// of the knot values (the linear interpolation between them is the Brownian bridge's mean).
inline constexpr int kBiasOrder = 2;

// The robust solve ends once its next step is predicted to lower the cost by less than this share
// of it (RobustStageStop).
inline constexpr double kRobustPredictedDecrease = 1e-4;

// Everything the templated problem needs that does not depend on the spline type: the selected
// data, the board views, and the shared run settings (prepared in spline_calibrator.cpp).
// The corners are held compactly (HeldCorner, corner_residual.h): the frame blocks read them
// where they are, and a long recording holds millions.
struct PreparedCamera {
  SensorState* state = nullptr;
  std::vector<HeldCorner> corners;         // corners of frames with a board view, frame by frame
  std::vector<std::int64_t> frame_stamps;  // image stamp of each frame (camera clock)
  std::vector<Eigen::Vector3d> board_W;    // the board's corners by id (world frame)
  std::vector<bool> removed;               // outliers
  std::vector<BoardView> views;
  int invalid = 0;

  // Image stamp of corner i (camera clock).
  std::int64_t Stamp(std::size_t i) const {
    return frame_stamps[static_cast<std::size_t>(corners[i].frame)];
  }
  CornerMeasurement Measurement(std::size_t i) const {
    return MeasurementOf(corners[i], board_W.data());
  }
};

// The whitened residual of every corner left in the problem (evaluated corner by corner, also
// where the problem holds compressed frame blocks), for the residual statistics.
struct CornerResiduals {
  std::string camera;
  std::vector<Eigen::Vector2d> whitened;
  std::vector<double> sigma_px;
};

// The squared whitened residuals of one inertial sensor's samples, summed (the statistics).
struct InertialResidualSums {
  std::string sensor;
  double gyro = 0.0;   // over the gyroscope's 3 rows of every sample
  double accel = 0.0;  // over the accelerometer's 3 rows (IMUs only)
  std::int64_t samples = 0;
};

struct PreparedInertial {
  SensorState* state = nullptr;
  std::vector<ImuSample> imu;    // type imu, samples inside the trajectory's time range
  std::vector<GyroSample> gyro;  // type gyro
};

struct Prepared {
  CalibrationState* state = nullptr;
  std::vector<PreparedCamera> cameras;
  std::vector<PreparedInertial> inertial;  // the base first
  std::vector<TimedPose> base_poses;       // from every camera's views, sorted by time
  std::int64_t t0_ns = 0;                  // trajectory range, base clock
  std::int64_t t1_ns = 0;
  double knot_spacing_s = 0.0;
};

// Selects the data, finds the board views and the trajectory's time range, sizes the bias
// splines. Throws CalibrationInputError naming the sensor for data the calibration cannot use.
// Shared with the discrete calibrator (the same data and board views).
void Prepare(CalibrationState* state, const std::map<std::string, SensorData>& data,
             const SplineCalibratorOptions& options, const CoarseInitResult& init,
             const CalibrationLog& log, Prepared* prep);

// Every camera's intrinsic bounds (CameraModel::ParamBounds: e.g. xi, alpha) on its parameter
// block, where the problem has that block. Shared with the discrete calibrator.
inline void BoundCameraParameters(const std::vector<PreparedCamera>& cameras,
                                  ceres::Problem* problem) {
  for (const PreparedCamera& cam : cameras) {
    Eigen::VectorXd lo, hi;
    cam.state->camera->ParamBounds(&lo, &hi);
    double* p = cam.state->camera->mutable_params();
    if (!problem->HasParameterBlock(p))
      continue;
    for (int i = 0; i < lo.size(); ++i) {
      if (std::isfinite(lo(i)))
        problem->SetParameterLowerBound(p, i, lo(i));
      if (std::isfinite(hi(i)))
        problem->SetParameterUpperBound(p, i, hi(i));
    }
  }
}

// Priors of `prior_sigma` on the estimated blocks, centred on `centers` (one per block, the
// input's guesses); returns their residual ids. Shared with the discrete calibrator.
std::vector<ceres::ResidualBlockId> AddCalibrationPriors(
    ceres::Problem* problem, const std::vector<ParameterBlockInfo>& blocks,
    const std::vector<std::vector<double>>& centers, bool analytic);

// The marginal covariance and residual statistics, written into the result rig
// (spline_calibrator.cpp).
// One log line per camera: views, corners, outliers removed by the chi-square gate, corners not
// projectable at the guess (shared by the spline and the discrete pipelines).
void LogOutliers(const std::vector<CameraOutliers>& outliers, double outlier_probability,
                 const CalibrationLog& log);

// The information of `blocks` with every other free block marginalised, of all residual blocks
// (priors included), from the last solve (LevenbergMarquardt::MarginalizeToBorder).
struct SolvedInformation {
  std::vector<double*> blocks;
  MarginalInformation information;
};

// `solved`: the covariance's information when the solver has it for exactly the estimated
// calibration blocks; else (nullptr) it is computed from the problem.
void FinishResult(ceres::Problem& problem, CalibrationState& state,
                  const std::vector<ceres::ResidualBlockId>& prior_ids,
                  const std::vector<CornerResiduals>& corners,
                  const std::vector<InertialResidualSums>& inertial,
                  const SplineCalibratorOptions& options, const CalibrationLog& log,
                  SplineCalibrationResult* out, const SolvedInformation* solved = nullptr);

ceres::Solver::Options SolverOptions(const SplineCalibratorOptions& options,
                                     ceres::IterationCallback* callback);

// The report data of the final values (report_data_builder.h), from the prepared data
// (spline_report_data.cpp).
// `bias` replaces the state's bias splines per sensor (the discrete method's keyframe biases).
report::ReportData SplineReportData(const Prepared& prep, const TrajectoryEvaluator& trajectory,
                                    const SplineCalibrationResult& result,
                                    std::map<std::string, BiasEvaluator> bias = {});

// Prints each iteration's cost and time.
class IterationLogger : public ceres::IterationCallback {
 public:
  explicit IterationLogger(const CalibrationLog& log) : log_(log) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    char line[160];
    std::snprintf(line, sizeof line,
                  "    iter %3d  cost %.9e  change %+.3e  |step| %.2e  %s %.2f s", s.iteration,
                  s.cost, -s.cost_change, s.step_norm, s.step_is_successful ? "   " : "rej",
                  s.cumulative_time_in_seconds);
    log_(line);
    LogMemory(log_, "iteration " + std::to_string(s.iteration));
    if (!std::isfinite(s.cost))
      return ceres::SOLVER_ABORT;
    return ceres::SOLVER_CONTINUE;
  }

 private:
  CalibrationLog log_;
};

// Ends the robust solve after an accepted step once the decrease is contracting so fast that the
// next step is predicted to lower the cost by less than `relative` of it, instead of paying a
// linear solve and an evaluation for a candidate step that Ceres' function tolerance would then
// refuse (it keeps the current point in both cases). The prediction assumes at least the observed
// rate: next <= (last / previous) x last, with last < 0.1 previous required (Gauss-Newton's fast
// phase; a slow, linear phase keeps iterating). The robust point only seeds the outlier gate and
// the plain solve, which has its own stop criterion in sigma (SplineCalibratorOptions::
// stop_cost_change). Demo: decreases 6.76e6, 5.56e3 -> predicted 4.6 = 1.1e-5 of the cost: the
// same point as before, one linear solve less (docs/performance.md step 7b).
class RobustStageStop : public ceres::IterationCallback {
 public:
  explicit RobustStageStop(double relative) : relative_(relative) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    if (s.iteration == 0 || !s.step_is_successful)
      return ceres::SOLVER_CONTINUE;
    const double last = s.cost_change;  // the accepted step's decrease
    const bool stop = previous_ > 0.0 && last >= 0.0 && last < 0.1 * previous_ &&
                      last * (last / previous_) < relative_ * s.cost;
    previous_ = last;
    return stop ? ceres::SOLVER_TERMINATE_SUCCESSFULLY : ceres::SOLVER_CONTINUE;
  }

 private:
  double relative_;
  double previous_ = 0.0;
};

template <int N, Se3Representation Rep>
class SplineProblem {
 public:
  using Spline = Se3Spline<N, Rep>;
  static constexpr int Nb = kBiasOrder;

  SplineProblem(Prepared* prep, const SplineCalibratorOptions& options, const CalibrationLog& log)
      : prep_(*prep),
        state_(*prep->state),
        options_(options),
        log_(log),
        spline_(MakeTiming(prep->t0_ns, prep->knot_spacing_s),
                NumKnotsFor(prep->t0_ns, prep->t1_ns, prep->knot_spacing_s)) {}

  static KnotTiming MakeTiming(std::int64_t t0_ns, double dt_s) {
    return KnotTiming{t0_ns, static_cast<std::int64_t>(std::llround(dt_s * 1e9))};
  }
  static int NumKnotsFor(std::int64_t t0_ns, std::int64_t t1_ns, double dt_s) {
    const std::int64_t dt_ns = static_cast<std::int64_t>(std::llround(dt_s * 1e9));
    const std::int64_t segments = std::max<std::int64_t>(1, (t1_ns - t0_ns + dt_ns - 1) / dt_ns);
    return static_cast<int>(segments) + N - 1;
  }

  const Spline& spline() const { return spline_; }
  int NumKnots() const { return spline_.NumKnots(); }

  // --- initialisation ---------------------------------------------------------------------------

  // The trajectory and gravity from the base poses and the base IMU (spline_trajectory_fit.h):
  // knots start at the pose nearest to their centre, then Gauss-Newton on the poses, the gyro and
  // the accelerometer, with the base IMU's intrinsics and seeded biases at their guesses.
  void InitializeTrajectory() {
    const auto& poses = prep_.base_poses;
    TrajectoryFit<N, Rep>::SeedKnots(poses, &spline_);
    const PreparedInertial& base = prep_.inertial.front();
    std::vector<BaseRateSample> imu;
    imu.reserve(base.imu.size());
    for (const ImuSample& s : base.imu) {
      BaseRateSample z;
      z.t_ns = s.t_ns;
      base.state->imu->TrueFromRaw(s.w_m, s.a_m, base.state->bias_gyro.Evaluate(s.t_ns),
                                   base.state->bias_accel.Evaluate(s.t_ns), &z.w_I, &z.a_I);
      imu.push_back(z);
    }
    Eigen::Vector3d g_W = state_.gravity();
    const TrajectoryFitReport r =
        TrajectoryFit<N, Rep>(poses, imu, TrajectoryFitOptions{}).Run(&spline_, &g_W);
    state_.SetGravity(g_W);
    char line[200];
    std::snprintf(line, sizeof line,
                  "  spline fit: %d knots (dt %.4f s) to %zu poses and %zu base IMU samples, cost "
                  "%.3e -> %.3e, %d iterations",
                  spline_.NumKnots(), spline_.timing().dt_s(), poses.size(), imu.size(),
                  r.initial_cost, r.final_cost, r.iterations);
    log_(line);
    LogMemory(log_, "trajectory fitted");
  }

  // --- the problem ------------------------------------------------------------------------------

  // Builds a fresh problem from the current values (the residuals' segments follow the current
  // time offsets: this is also the re-bucketing).
  void Build(bool robust) {
    robust_ = robust;
    ceres::Problem::Options po;
    po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    // With an evaluation callback Ceres writes every evaluation point into the parameter blocks'
    // memory before evaluating, which the split frames' intrinsic rows read their pose from
    // (frame_corners_residual.h) and the inertial row groups their earlier knots, counting the
    // points (inertial_row_groups.h); without either nothing reads it, so Ceres need not copy.
    const bool any_split = std::any_of(prep_.cameras.begin(), prep_.cameras.end(),
                                       [&](const PreparedCamera& c) { return SplitsFrameRows(c); });
    point_in_memory_used_ = any_split || options_.split_inertial_rows;
    po.evaluation_callback = point_in_memory_used_ ? &point_in_memory_ : nullptr;
    solver_.reset();  // it reads the old problem
    problem_ = std::make_unique<ceres::Problem>(po);
    kept_corners_.clear();
    inertial_ids_.clear();
    prior_ids_.clear();
    segments_.clear();
    ceres::Problem& P = *problem_;

    for (int k = 0; k < spline_.NumKnots(); ++k) {
      double* d = spline_.KnotData(k);
      if constexpr (Rep == Se3Representation::kJoint) {
        P.AddParameterBlock(d, 7, &se3_right_);
      } else {
        P.AddParameterBlock(d, 4, &so3_right_);
        P.AddParameterBlock(d + 4, 3);
      }
    }
    blocks_ = state_.Blocks();
    for (ParameterBlockInfo& b : blocks_) {
      if (b.key == "gravity_W")
        P.AddParameterBlock(b.values, 3, &sphere_);
      else if (b.left_rotation)
        P.AddParameterBlock(b.values, 4, &so3_left_);
      else
        P.AddParameterBlock(b.values, b.ambient_size);
    }

    for (PreparedCamera& cam : prep_.cameras)
      AddCamera(&cam, robust);
    for (PreparedInertial& in : prep_.inertial)
      AddInertial(in);
    AddPriors();

    // Constant what is not estimated; bounds of the camera models' domains.
    for (ParameterBlockInfo& b : blocks_) {
      if (!P.HasParameterBlock(b.values))
        continue;
      if (!b.estimated)
        P.SetParameterBlockConstant(b.values);
    }
    BoundCameraParameters(prep_.cameras, &P);
    LogMemory(log_, "problem built");
  }

  ceres::Solver::Summary Solve() {
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
      so.function_tolerance =
          std::max(so.function_tolerance, options_.stop_cost_change / last_cost_);
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
      solver_ = std::make_unique<LevenbergMarquardt>(
          so, border, problem_.get(), point_in_memory_used_ ? &point_in_memory_ : nullptr);
      // Long recordings' compressed inertial blocks span many knots: their band (on both threads)
      // would hold more than Ceres' Jacobian and J^T J together (10 min at 1 kHz: +76 MB, with
      // normal equations estimated larger than the Jacobian), so they stay with Ceres
      // (docs/performance.md step 7f; the demo: 58 MB against 127 MB).
      const bool ceres_solves = solver_->NormalEquationsBytes() > solver_->JacobianBytes();
      char line[160];
      std::snprintf(line, sizeof line, "    normal equations %.0f MB, Jacobian %.0f MB: %s",
                    1e-6 * static_cast<double>(solver_->NormalEquationsBytes()),
                    1e-6 * static_cast<double>(solver_->JacobianBytes()),
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

  // Names the sensor a failed solve points at: the first whose whitened residuals are not finite
  // at the current values, else the one with the largest share of the cost.
  std::string DivergenceCulprit() {
    std::vector<std::pair<std::string, double>> cost;  // sum of squared whitened residuals
    for (const PreparedCamera& cam : prep_.cameras) {
      double sum = 0.0;
      for (std::size_t i = 0; i < cam.corners.size(); ++i) {
        Eigen::Vector2d e;
        if (cam.removed[i])
          continue;
        sum +=
            EvaluateCorner(cam, i, &e) ? e.squaredNorm() : std::numeric_limits<double>::infinity();
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
    std::snprintf(share, sizeof share, "%.0f %%",
                  100.0 * largest->second / std::max(total, 1e-300));
    return "sensors." + largest->first + " holds the largest share of the cost (" + share + ")";
  }

  // Marks the corners whose whitened residual norm^2 exceeds the chi-square(2) gate.
  void RemoveOutliers(double probability, std::vector<CameraOutliers>* report) {
    const double gate = -2.0 * std::log(1.0 - probability);  // chi-square, 2 dof
    // One camera per thread, as the residual statistics (Finish): each writes its own slots.
    std::vector<CameraOutliers> found(prep_.cameras.size());
    ParallelFor(options_.threads, prep_.cameras.size(), [&](std::size_t c) {
      PreparedCamera& cam = prep_.cameras[c];
      CameraOutliers& o = found[c];
      o.camera = cam.state->name();
      o.views = static_cast<int>(cam.views.size());
      o.invalid = cam.invalid;
      for (std::size_t i = 0; i < cam.corners.size(); ++i) {
        if (cam.removed[i])
          continue;
        ++o.corners;
        Eigen::Vector2d e;
        if (!EvaluateCorner(cam, i, &e) || e.squaredNorm() > gate) {
          cam.removed[i] = true;
          ++o.removed;
        }
      }
    });
    report->insert(report->end(), found.begin(), found.end());
  }

  // How many residuals the current time offsets have moved out of their segment by more than
  // kRebucketTolerance of a knot interval. A residual just past its segment's end evaluates that
  // segment's polynomial a little beyond it, which differs from the next segment only by the
  // jump of the spline's (N-1)-th derivative times (eps dt)^(N-1) / (N-1)!: at eps = 0.02 that is
  // ~1e-6 of one knot interval's change of that derivative, far below any sensor's noise, so only
  // real moves pay for a rebuild and re-solve.
  int CountRebucket() const {
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

  // RunStages' hooks: nothing to do before the plain solve; a rebuild while the time offsets
  // move residuals to other segments.
  void BeforePlainSolve() {}
  std::string NextRebuild() {
    const int changed = CountRebucket();
    return changed == 0 ? std::string()
                        : std::to_string(changed) +
                              " residuals moved to another spline segment with the time offsets: "
                              "re-bucketed";
  }

  void Finish(SplineCalibrationResult* out) {
    // Every corner on its own (the problem may hold them compressed), one camera per thread.
    std::vector<CornerResiduals> corners(prep_.cameras.size());
    ParallelFor(options_.threads, prep_.cameras.size(), [&](std::size_t k) {
      const PreparedCamera& cam = prep_.cameras[k];
      CornerResiduals& c = corners[k];
      c.camera = cam.state->name();
      for (std::size_t i = 0; i < cam.corners.size(); ++i) {
        Eigen::Vector2d e;
        if (cam.removed[i] || !EvaluateCorner(cam, i, &e))
          continue;
        c.whitened.push_back(e);
        c.sigma_px.push_back(cam.corners[i].sigma_px);
      }
    });
    // Inertial samples one by one too (the problem may hold them compressed per run of segments).
    std::vector<InertialResidualSums> inertial;
    for (PreparedInertial& in : prep_.inertial) {
      InertialResidualSums sums;
      sums.sensor = in.state->name();
      VisitSamples(in, [&](auto& set, auto&& blocks_of) {
        using R = typename std::decay_t<decltype(set)>::Residual;
        double r[R::kNumResiduals];
        for (std::size_t i = 0; i < set.functors.size(); ++i) {
          const std::vector<double*> blocks = blocks_of(set.seg[i], set.bseg[i]);
          R::Analytic::EvaluateSample(set.functors[i], blocks.data(), r, nullptr);
          for (int k = 0; k < R::kNumResiduals; ++k)
            (k < 3 ? sums.gyro : sums.accel) += r[k] * r[k];
        }
        sums.samples += static_cast<std::int64_t>(set.functors.size());
      });
      inertial.push_back(sums);
    }
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

  // Whether the camera's corners enter as compressed per-frame blocks: the analytic path of a
  // global-shutter camera (line_delay 0 and not estimated); rolling shutter reads every corner at
  // its own row time, so its corners keep one block each.
  bool Compressed(const PreparedCamera& cam) const {
    const SensorState& s = *cam.state;
    return options_.analytic && options_.compress_frames &&
           !s.config.Estimates(EstimateItem::kLineDelay) && s.line_delay == 0.0;
  }

  ceres::Problem& problem() { return *problem_; }
  // Destroys the problem (its residual blocks); the values stay in the spline and the state.
  void ReleaseProblem() {
    solver_.reset();
    problem_.reset();
  }

  // T_W_B at base-clock time t_ns, extrapolating the end segments as the residuals do.
  Se3Kinematics<double> EvaluateClamped(std::int64_t t_ns, int derivatives) {
    const int seg = SegmentOf(t_ns, 0.0);
    const SegmentClock clock = SegmentClock::At(t_ns, spline_.timing(), seg);
    Se3Kinematics<double> kin;
    Spline::template EvaluateSegment<double>(spline_.SegmentBlocks(seg).data(), clock.U(),
                                             clock.inv_dt, derivatives, nullptr, &kin);
    return kin;
  }

 private:
  std::int64_t Clamp(std::int64_t t_ns) const {
    return std::min(std::max(t_ns, spline_.MinTimeNs()), spline_.MaxTimeNs());
  }

  // The segment of base-clock time t_ns + shift_s (clamped: a sample moved slightly off the
  // trajectory's ends by its time offset extrapolates its end segment).
  int SegmentOf(std::int64_t t_ns, double shift_s) const {
    return ClampSegment(SegmentCoordinate(t_ns, shift_s));
  }

  // Base-clock time t_ns + shift_s in knot intervals from the spline's start.
  double SegmentCoordinate(std::int64_t t_ns, double shift_s) const {
    const KnotTiming& tm = spline_.timing();
    return (1e-9 * static_cast<double>(t_ns - tm.t0_ns) + shift_s) / tm.dt_s();
  }

  int ClampSegment(double coordinate) const {
    const int last = spline_.NumSegments() - 1;
    return std::min(std::max(static_cast<int>(std::floor(coordinate)), 0), last);
  }

  static int BiasSegmentOf(const BiasSpline& b, std::int64_t t_ns) {
    const std::int64_t k = (t_ns - b.timing.t0_ns) / b.timing.dt_ns;
    return static_cast<int>(std::min<std::int64_t>(std::max<std::int64_t>(k, 0), b.NumKnots() - 2));
  }

  std::vector<double*> TrajBlocks(int segment) {
    const auto a = spline_.SegmentBlocks(segment);
    return std::vector<double*>(a.begin(), a.end());
  }

  static std::vector<double*> BiasBlocks(BiasSpline& b, int segment) {
    return {b.Knot(segment), b.Knot(segment + 1)};
  }

  // The corner's whitened residual at the current values, evaluated on its own (the statistics
  // and the outlier gate need it per corner, also where the problem holds frame blocks).
  bool EvaluateCorner(const PreparedCamera& cam, std::size_t i, Eigen::Vector2d* e) {
    SensorState& s = *cam.state;
    const std::int64_t stamp = cam.Stamp(i);
    const int seg = SegmentOf(stamp, s.time_offset + cam.corners[i].uv.y() * s.line_delay);
    const std::unique_ptr<ceres::CostFunction> cost(
        MakeCornerResidual<N, Rep>(true, s.camera->type(), cam.Measurement(i),
                                   SegmentClock::At(stamp, spline_.timing(), seg)));
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

  // The frames of a camera: [first, last) runs of its corners with one stamp.
  template <class F>
  static void ForEachFrame(const PreparedCamera& cam, F&& f) {
    std::size_t first = 0;
    while (first < cam.corners.size()) {
      std::size_t last = first + 1;
      while (last < cam.corners.size() && cam.corners[last].frame == cam.corners[first].frame)
        ++last;
      f(first, last);
      first = last;
    }
  }

  // Whether frame [first, last) has a corner left in the problem.
  static bool AnyLeft(const PreparedCamera& cam, std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      if (!cam.removed[i])
        return true;
    }
    return false;
  }

  // Visits the segment coordinate (SegmentCoordinate) of every residual in the order Build adds
  // them.
  template <class F>
  void ForEachSegment(F&& f) const {
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

  // One compressed block per frame (frame_corners_residual.h); the robust stage's Huber weights
  // are applied per corner inside the block.
  // The split halves only where the intrinsic rows have a free block (a block of constant
  // blocks only would be evaluated once, at the start, as Ceres' fixed cost).
  bool SplitsFrameRows(const PreparedCamera& cam) const {
    const bool many =
        static_cast<int>(cam.views.size()) > SplineCalibratorOptions::kSplitFrameRowsAbove;
    return (options_.split_frame_rows > 0 || (options_.split_frame_rows < 0 && many)) &&
           cam.state->config.Estimates(EstimateItem::kIntrinsics);
  }

  void AddCameraFrames(PreparedCamera* cam, bool robust) {
    SensorState& s = *cam->state;
    const bool split = SplitsFrameRows(*cam);
    ForEachFrame(*cam, [&](std::size_t first, std::size_t last) {
      if (!AnyLeft(*cam, first, last))
        return;
      const std::int64_t stamp = cam->Stamp(first);
      const int seg = SegmentOf(stamp, s.time_offset);
      segments_.push_back(seg);
      typename FrameCornersResidual<N, Rep>::Parameters p;
      p.traj = TrajBlocks(seg);
      p.q_B_C = s.q_B_S.data();
      p.t_B_C = s.t_B_S.data();
      p.time_offset = &s.time_offset;
      p.params = s.camera->mutable_params();
      const SegmentClock clock = SegmentClock::At(stamp, spline_.timing(), seg);
      const double huber = robust ? options_.huber_threshold : 0.0;
      // The block reads the frame's corners and board points where Prepare put them (prep_
      // outlives the problem): the corners are held once, not once more per block; a frame with
      // outliers removed reads the rest from kept_corners_ (the problem's).
      const HeldCorner* corners = &cam->corners[first];
      const Eigen::Vector3d* board_W = cam->board_W.data();
      int count = static_cast<int>(last - first);
      if (std::any_of(cam->removed.begin() + static_cast<std::ptrdiff_t>(first),
                      cam->removed.begin() + static_cast<std::ptrdiff_t>(last),
                      [](bool r) { return r; })) {
        std::vector<HeldCorner> kept;
        for (std::size_t i = first; i < last; ++i) {
          if (!cam->removed[i])
            kept.push_back(cam->corners[i]);
        }
        kept_corners_.push_back(std::move(kept));
        corners = kept_corners_.back().data();
        count = static_cast<int>(kept_corners_.back().size());
      }
      const std::vector<double*> blocks = FrameCornersResidual<N, Rep>::Blocks(p);
      if (!split) {
        problem_->AddResidualBlock(MakeFrameCornersResidual<N, Rep>(s.camera->type(), corners,
                                                                    count, board_W, clock, huber),
                                   nullptr, blocks);
        return;
      }
      problem_->AddResidualBlock(
          MakeFrameCornersResidual<N, Rep>(s.camera->type(), corners, count, board_W, clock, huber,
                                           FrameRows::kPose),
          nullptr, blocks);
      problem_->AddResidualBlock(
          MakeFrameCornersResidual<N, Rep>(s.camera->type(), corners, count, board_W, clock, huber,
                                           FrameRows::kIntrinsics, blocks),
          nullptr, p.params);
    });
  }

  void AddCamera(PreparedCamera* cam, bool robust) {
    if (Compressed(*cam)) {
      AddCameraFrames(cam, robust);
      return;
    }
    SensorState& s = *cam->state;
    ceres::LossFunction* loss = nullptr;
    for (std::size_t i = 0; i < cam->corners.size(); ++i) {
      if (cam->removed[i])
        continue;
      const std::int64_t stamp = cam->Stamp(i);
      const int seg = SegmentOf(stamp, s.time_offset + cam->corners[i].uv.y() * s.line_delay);
      segments_.push_back(seg);
      const SegmentClock clock = SegmentClock::At(stamp, spline_.timing(), seg);
      typename CornerResidual<N, Rep>::Parameters p;
      p.traj = TrajBlocks(seg);
      p.q_B_C = s.q_B_S.data();
      p.t_B_C = s.t_B_S.data();
      p.time_offset = &s.time_offset;
      p.line_delay = &s.line_delay;
      p.params = s.camera->mutable_params();
      ceres::CostFunction* cost = MakeCornerResidual<N, Rep>(options_.analytic, s.camera->type(),
                                                             cam->Measurement(i), clock);
      if (robust)
        loss = new ceres::HuberLoss(options_.huber_threshold);
      problem_->AddResidualBlock(cost, loss, CornerResidual<N, Rep>::Blocks(p));
    }
  }

  // A sensor's samples as functors of their residual class R, with each sample's trajectory and
  // bias segment; `blocks(seg, bseg)` lists a sample's parameter blocks (R::Blocks) and `sizes`
  // their ambient sizes (R::BlockSizes).
  template <class R>
  struct SampleSetOf {
    using Residual = R;
    // functors[i] is the sample raw[i] of the prepared data (which outlives the problem).
    const typename RawSampleOf<typename R::Setup>::type* raw = nullptr;
    std::vector<typename R::Functor> functors;
    std::vector<int> seg;
    std::vector<int> bseg;
    std::vector<int> sizes;
  };

  // Calls f(set, blocks) for the sensor's IMU samples and for its gyro samples (those present),
  // in time order, the segments following the current time offset.
  template <class F>
  void VisitSamples(PreparedInertial& in, F&& f) {
    SensorState& s = *in.state;
    const InertialNoise& noise = s.config.noise;
    const double shift = s.is_base ? 0.0 : s.time_offset;
    // The sample on its segments (InertialBlockResidual places held samples the same way).
    const auto place = [&](const auto& z, auto* set, auto* setup) {
      const int seg = SegmentOf(z.t_ns, shift);
      const int bseg = BiasSegmentOf(s.bias_gyro, z.t_ns);
      set->seg.push_back(seg);
      set->bseg.push_back(bseg);
      PlaceSample(z, SegmentClock::At(z.t_ns, spline_.timing(), seg),
                  SegmentClock::At(z.t_ns, s.bias_gyro.timing, bseg), setup);
    };
    const auto imu_set = [&](auto* set) {
      set->sizes = std::decay_t<decltype(*set)>::Residual::BlockSizes(s.imu->layout());
      set->raw = in.imu.data();
      set->functors.reserve(in.imu.size());
      ImuSampleSetup setup;
      setup.layout = s.imu->layout();
      setup.W = ImuWhitening::Of(noise);
      for (const ImuSample& z : in.imu) {
        place(z, set, &setup);
        set->functors.emplace_back(setup);
      }
    };
    if (!in.imu.empty() && s.is_base) {
      using R = BaseImuResidual<N, Rep, Nb>;
      SampleSetOf<R> set;
      imu_set(&set);
      f(set, [&](int seg, int bseg) {
        typename R::Parameters p;
        p.traj = TrajBlocks(seg);
        p.g_W = state_.g_W();
        p.bg = BiasBlocks(s.bias_gyro, bseg);
        p.ba = BiasBlocks(s.bias_accel, bseg);
        p.intrinsics = &*s.imu;
        return R::Blocks(p);
      });
    } else if (!in.imu.empty()) {
      using R = AuxImuResidual<N, Rep, Nb>;
      SampleSetOf<R> set;
      imu_set(&set);
      f(set, [&](int seg, int bseg) {
        typename R::Parameters p;
        p.traj = TrajBlocks(seg);
        p.g_W = state_.g_W();
        p.q_B_S = s.q_B_S.data();
        p.t_B_S = s.t_B_S.data();
        p.time_offset = &s.time_offset;
        p.bg = BiasBlocks(s.bias_gyro, bseg);
        p.ba = BiasBlocks(s.bias_accel, bseg);
        p.intrinsics = &*s.imu;
        return R::Blocks(p);
      });
    }
    if (!in.gyro.empty()) {
      using R = AuxGyroResidual<N, Rep, Nb>;
      SampleSetOf<R> set;
      set.sizes = R::BlockSizes(s.gyro->model());
      set.raw = in.gyro.data();
      set.functors.reserve(in.gyro.size());
      GyroSampleSetup setup;
      setup.model = s.gyro->model();
      setup.inv_sigma = 1.0 / noise.GyroSampleSigma();
      for (const GyroSample& z : in.gyro) {
        place(z, &set, &setup);
        set.functors.push_back(typename R::Functor{setup});
      }
      f(set, [&](int seg, int bseg) {
        typename R::Parameters p;
        p.traj = TrajBlocks(seg);
        p.q_B_S = s.q_B_S.data();
        p.time_offset = &s.time_offset;
        p.bg = BiasBlocks(s.bias_gyro, bseg);
        p.intrinsics = &*s.gyro;
        return R::Blocks(p);
      });
    }
  }

  // The run length of the sensor's compressed blocks (inertial_block_residual.h), 0 for one block
  // per sample: from the sensor's rate unless SplineCalibratorOptions forces it.
  template <class Set>
  int InertialSegments(const Set& set, const std::vector<double*>& common) const {
    using R = typename Set::Residual;
    if (!options_.analytic || !options_.compress_inertial || set.seg.size() < 2)
      return 0;
    if (options_.inertial_block_segments > 0)
      return std::min(options_.inertial_block_segments, 255);
    const double span_segments = static_cast<double>(set.seg.back() - set.seg.front() + 1);
    const double per_segment = static_cast<double>(set.seg.size()) / span_segments;
    int cols = 0, rank = 0;
    for (std::size_t b = R::kNumTrajBlocks; b < set.sizes.size(); ++b) {
      cols += set.sizes[b];
      rank += CommonRank(common[b - R::kNumTrajBlocks], set.sizes[b]);
    }
    return InertialBlockSegments(per_segment, R::kNumResiduals, N, cols, rank);
  }

  // The manifold a residual lifts a shared block's Jacobian with (the left rotations), nullptr
  // for the others (gravity's Jacobian is the plain ambient one).
  const ceres::Manifold* LiftedManifold(double* block) const {
    // Bias knots enter the problem with their first residual: not known to it yet, Euclidean.
    return problem_->HasParameterBlock(block) && problem_->GetManifold(block) == &so3_left_
               ? &so3_left_
               : nullptr;
  }
  int CommonRank(double* block, int size) const {
    return LiftedManifold(block) != nullptr ? 3 : size;
  }

  void AddInertial(PreparedInertial& in) {
    SensorState& s = *in.state;
    const InertialNoise& noise = s.config.noise;
    std::vector<ceres::ResidualBlockId> ids;
    VisitSamples(in, [&](auto& set, auto&& blocks_of) {
      using R = typename std::decay_t<decltype(set)>::Residual;
      segments_.insert(segments_.end(), set.seg.begin(), set.seg.end());
      const std::size_t count = set.functors.size();
      std::vector<double*> first = blocks_of(set.seg.front(), set.bseg.front());
      const std::vector<double*> common(first.begin() + R::kNumTrajBlocks, first.end());
      const int compressed = InertialSegments(set, common);
      const bool stacked = compressed == 0 && options_.analytic && options_.compress_inertial &&
                           options_.stacked_inertial_segments > 0;
      const int K = stacked ? std::min(options_.stacked_inertial_segments, 255) : compressed;
      if (K == 0) {
        for (std::size_t i = 0; i < count; ++i) {
          const typename R::Setup& setup = set.functors[i].s;
          ceres::CostFunction* cost =
              options_.analytic ? new typename R::Analytic(setup) : R::MakeAutoDiff(setup);
          ids.push_back(
              problem_->AddResidualBlock(cost, nullptr, blocks_of(set.seg[i], set.bseg[i])));
        }
        return;
      }
      // The row groups of the last runs, added interleaved (AddRowGroups).
      std::vector<std::vector<std::pair<ceres::CostFunction*, std::vector<double*>>>> batch;
      // Runs of at most K segments whose samples share one bias segment.
      std::size_t begin = 0;
      while (begin < count) {
        std::size_t end = begin + 1;
        while (end < count && set.bseg[end] == set.bseg[begin] &&
               set.seg[end] - set.seg[begin] < K && set.seg[end] >= set.seg[end - 1])
          ++end;
        const int first_seg = set.seg[begin];
        const int num_segments = set.seg[end - 1] - first_seg + 1;
        // The block reads its samples where Prepare put them (prep_ outlives the problem).
        HeldInertialSamples<typename InertialBlockResidual<R>::Raw> held;
        held.samples = set.raw + begin;
        held.trajectory = spline_.timing();
        held.first_segment = first_seg;
        held.bias = s.bias_gyro.timing;
        held.bias_segment = set.bseg[begin];
        std::vector<std::uint8_t> offsets;
        for (std::size_t i = begin; i < end; ++i)
          offsets.push_back(static_cast<std::uint8_t>(set.seg[i] - first_seg));
        const std::vector<double*> sample = blocks_of(first_seg, set.bseg[begin]);
        std::vector<double*> blocks =
            InertialBlockResidual<R>::TrajectoryBlocks(spline_, first_seg, num_segments);
        std::vector<const ceres::Manifold*> manifolds;
        for (std::size_t b = R::kNumTrajBlocks; b < sample.size(); ++b) {
          blocks.push_back(sample[b]);
          manifolds.push_back(LiftedManifold(sample[b]));
        }
        auto whole = std::make_unique<InertialBlockResidual<R>>(set.functors[begin], held,
                                                                std::move(offsets), num_segments,
                                                                set.sizes, manifolds, 0.0, stacked);
        begin = end;
        if (stacked || !options_.split_inertial_rows) {
          ids.push_back(problem_->AddResidualBlock(whole.release(), nullptr, blocks));
          continue;
        }
        // The factor's rows in groups over the blocks they touch (inertial_row_groups.h).
        const int num_knot_blocks = static_cast<int>(blocks.size() - manifolds.size());
        const std::vector<InertialRowGroupLayout> groups =
            InertialRowGroups(whole->TangentColumns(), num_knot_blocks, whole->num_residuals());
        const auto run = std::make_shared<SharedInertialRun>(std::move(whole), blocks,
                                                             &point_in_memory_.generation);
        auto& added = batch.emplace_back();
        for (const InertialRowGroupLayout& g : groups) {
          added.emplace_back(new InertialRowGroup(run, g.first_block, g.row0, g.rows,
                                                  static_cast<int>(groups.size())),
                             std::vector<double*>(blocks.begin() + g.first_block, blocks.end()));
        }
        if (static_cast<int>(batch.size()) >= std::max(1, options_.threads) || begin == count)
          AddRowGroups(&batch, &ids);
      }
    });
    // Bias random walks between consecutive knots (these are part of the inertial model, kept
    // with the sensor's residuals but not in its residual statistics).
    const double dt_b = s.bias_gyro.timing.dt_s();
    for (int k = 0; k + 1 < s.bias_gyro.NumKnots(); ++k) {
      problem_->AddResidualBlock(
          MakeBiasRandomWalkResidual(options_.analytic, noise.gyroscope_random_walk, dt_b), nullptr,
          s.bias_gyro.Knot(k), s.bias_gyro.Knot(k + 1));
    }
    for (int k = 0; k + 1 < s.bias_accel.NumKnots(); ++k) {
      problem_->AddResidualBlock(
          MakeBiasRandomWalkResidual(options_.analytic, noise.accelerometer_random_walk, dt_b),
          nullptr, s.bias_accel.Knot(k), s.bias_accel.Knot(k + 1));
    }
    inertial_ids_.emplace_back(s.name(), std::move(ids));
  }

  // Adds the row groups of up to `threads` runs (inertial_row_groups.h) interleaved, group k of
  // every run before group k + 1: Ceres 2.1 hands residual block j to thread j mod threads, so
  // every group of one run goes to one thread, which factors the run once and reads it in turn,
  // instead of the run's groups meeting on two threads where one would wait for the other's
  // factorisation.
  void AddRowGroups(
      std::vector<std::vector<std::pair<ceres::CostFunction*, std::vector<double*>>>>* batch,
      std::vector<ceres::ResidualBlockId>* ids) {
    std::size_t most = 0;
    for (const auto& run : *batch)
      most = std::max(most, run.size());
    for (std::size_t k = 0; k < most; ++k) {
      for (const auto& run : *batch) {
        if (k < run.size())
          ids->push_back(problem_->AddResidualBlock(run[k].first, nullptr, run[k].second));
      }
    }
    batch->clear();
  }

  // Priors of `prior_sigma` on the estimated blocks, centred on the input's guesses.
  void AddPriors() {
    if (prior_center_.empty()) {
      // On the rig file's values, not on the initialisation's (coarse_init.h): same block order.
      CalibrationState guess(state_.rig());
      for (const ParameterBlockInfo& b : guess.Blocks())
        prior_center_.emplace_back(b.values, b.values + b.ambient_size);
    }
    const std::vector<ceres::ResidualBlockId> ids =
        AddCalibrationPriors(problem_.get(), blocks_, prior_center_, options_.analytic);
    prior_ids_.insert(prior_ids_.end(), ids.begin(), ids.end());
  }

  Prepared& prep_;
  CalibrationState& state_;
  SplineCalibratorOptions options_;
  CalibrationLog log_;
  Spline spline_;
  std::unique_ptr<ceres::Problem> problem_;
  std::unique_ptr<LevenbergMarquardt> solver_;  // of the last solve (lm_solver)
  std::vector<ParameterBlockInfo> blocks_;
  std::vector<std::vector<double>> prior_center_;
  std::vector<std::pair<std::string, std::vector<ceres::ResidualBlockId>>> inertial_ids_;
  std::vector<ceres::ResidualBlockId> prior_ids_;
  std::vector<int> segments_;
  std::vector<std::vector<HeldCorner>> kept_corners_;  // frames with outliers removed
  bool robust_ = false;
  double last_cost_ = 0.0;  // of the last solve

  // Its presence makes Ceres write each point into the blocks (Build); it counts the evaluation
  // passes, which identify the point for the inertial row groups' shared factor.
  struct PointInMemory : ceres::EvaluationCallback {
    void PrepareForEvaluation(bool, bool) override {
      generation.fetch_add(1, std::memory_order_acq_rel);
    }
    std::atomic<std::uint64_t> generation{0};
  } point_in_memory_;
  bool point_in_memory_used_ = false;  // the problem's evaluation callback (Build)
  So3RightManifold so3_right_;
  Se3RightManifold se3_right_;
  So3LeftManifold so3_left_;
  ceres::SphereManifold<3> sphere_;
};

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
  const ceres::Solver::Summary last = RunStages(&sp, solve, options.outlier_probability,
                                                options.max_rebucket_rounds, log, &out->outliers);
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
