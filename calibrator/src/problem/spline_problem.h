// The continuous-time calibration problem, templated on the trajectory spline's order N and
// representation (split / joint): the prepared data shared with the discrete calibrator and the
// problem's declaration. Its building is in spline_problem_build.h, its solving and the pipeline
// in spline_problem_solve.h (all three through spline_problem_impl.h); instantiated in
// spline_problem_split.cpp / _joint.cpp and dispatched from spline_calibrator.cpp. Private to the
// calibrator library.
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
#include "ctcal/calibrator/noise/variance_components.h"
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
#include "ctcal/calibrator/residuals/mrcal_corner_residual.h"
#include "ctcal/calibrator/residuals/mrcal_regularization.h"
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
  std::vector<std::int32_t> frame;  // the corner's frame (index into the camera's frame stamps)
};

// The squared whitened residuals of one inertial sensor's samples, summed (the statistics).
struct InertialResidualSums {
  std::string sensor;
  double gyro = 0.0;   // over the gyroscope's 3 rows of every sample
  double accel = 0.0;  // over the accelerometer's 3 rows (IMUs only)
  std::int64_t samples = 0;
  // The same per noise window (PreparedInertial::WindowOf).
  std::vector<double> window_gyro;
  std::vector<double> window_accel;
  std::vector<std::int64_t> window_samples;
};

// The noise windows of an inertial sensor: runs of whole bias-spline segments of ~2 s, so that a
// compressed or stacked block (which shares one bias segment) lies in one window.
inline constexpr double kNoiseWindowS = 2.0;

struct PreparedInertial {
  SensorState* state = nullptr;
  std::vector<ImuSample> imu;    // type imu, samples inside the trajectory's time range
  std::vector<GyroSample> gyro;  // type gyro
  // Per noise window, its white-noise sigmas relative to the sensor's (the noise estimation's
  // per-window scales; empty: 1 everywhere).
  std::vector<double> window_gyro_scale;
  std::vector<double> window_accel_scale;

  int BiasSegmentsPerWindow() const {
    const double dt = state->bias_gyro.timing.dt_s();
    return std::max(1, static_cast<int>(std::lround(kNoiseWindowS / dt)));
  }
  int WindowOf(int bias_segment) const { return bias_segment / BiasSegmentsPerWindow(); }
  int NumWindows() const { return WindowOf(state->bias_gyro.NumKnots() - 2) + 1; }
  double GyroScale(int bias_segment) const {
    return window_gyro_scale.empty()
               ? 1.0
               : window_gyro_scale[static_cast<std::size_t>(WindowOf(bias_segment))];
  }
  double AccelScale(int bias_segment) const {
    return window_accel_scale.empty()
               ? 1.0
               : window_accel_scale[static_cast<std::size_t>(WindowOf(bias_segment))];
  }
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
  void InitializeTrajectory();

  // --- the problem ------------------------------------------------------------------------------

  // Builds a fresh problem from the current values (the residuals' segments follow the current
  // time offsets: this is also the re-bucketing).
  void Build(bool robust);

  ceres::Solver::Summary Solve();

  // Names the sensor a failed solve points at: the first whose whitened residuals are not finite
  // at the current values, else the one with the largest share of the cost.
  std::string DivergenceCulprit();

  // Marks the corners whose whitened residual norm^2 exceeds the chi-square(2) gate.
  void RemoveOutliers(double probability, std::vector<CameraOutliers>* report);
  // The noise estimation's (spline_problem_noise.h): every corner back in the problem (the next
  // RemoveOutliers gates them all at the current weights), and per camera the robust variance
  // factor of all its corners (also those a gate removed) at the current values,
  // median |e|^2 / (2 ln 2).
  void RestoreCorners();
  std::vector<double> RobustCornerFactors();

  // How many residuals the current time offsets have moved out of their segment by more than
  // kRebucketTolerance of a knot interval. A residual just past its segment's end evaluates that
  // segment's polynomial a little beyond it, which differs from the next segment only by the
  // jump of the spline's (N-1)-th derivative times (eps dt)^(N-1) / (N-1)!: at eps = 0.02 that is
  // ~1e-6 of one knot interval's change of that derivative, far below any sensor's noise, so only
  // real moves pay for a rebuild and re-solve.
  int CountRebucket() const;

  // RunStages' hooks: nothing to do before the plain solve; a rebuild while the time offsets
  // move residuals to other segments.
  void BeforePlainSolve() {}
  std::string NextRebuild();

  void Finish(SplineCalibrationResult* out);

  // --- noise estimation (spline_problem_noise.h) ---

  // The whitened residual of every corner left and the inertial sums, at the current values.
  void CollectResiduals(std::vector<CornerResiduals>* corners,
                        std::vector<InertialResidualSums>* inertial);
  // Every noise group's e^T W e, n and hat-matrix trace at the current values: the cameras in
  // prep order, then each inertial sensor's gyro rows and (IMUs) accelerometer rows. `corners`
  // and `inertial` (optional) receive the residuals they were summed from (per-frame and
  // per-window weights).
  std::vector<VarianceComponent> NoiseComponents(
      const RedundancyOptions& options, std::vector<CornerResiduals>* corners = nullptr,
      std::vector<InertialResidualSums>* inertial = nullptr);

  // Whether the camera's corners enter as compressed per-frame blocks: the analytic path of a
  // global-shutter camera (line_delay 0 and not estimated); rolling shutter reads every corner at
  // its own row time, so its corners keep one block each. An mrcal lens (run-time parameter
  // count) has per-corner blocks only (mrcal_corner_residual.h).
  bool Compressed(const PreparedCamera& cam) const {
    const SensorState& s = *cam.state;
    return options_.analytic && options_.compress_frames &&
           !s.config.Estimates(EstimateItem::kLineDelay) && s.line_delay == 0.0 &&
           !s.camera->mrcal_lens();
  }

  ceres::Problem& problem() { return *problem_; }
  // Destroys the problem (its residual blocks); the values stay in the spline and the state.
  void ReleaseProblem() {
    solver_.reset();
    factorisation_.reset();
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
  bool EvaluateCorner(const PreparedCamera& cam, std::size_t i, Eigen::Vector2d* e);
  // EvaluateCorner for every corner of `cam` not removed, frames on the threads: (*ok)[i] whether
  // corner i is left and projects, (*e)[i] its residual then. Where a frame's corners share one
  // time (no line delay) and the camera has a compile-time model, the spline's pose is evaluated
  // once for the frame and each corner is projected with CornerResidual's own arithmetic: the same
  // bits as EvaluateCorner's, without a cost function, a block list and a spline evaluation per
  // corner (the gate and the statistics were ~4 % of the demo's CPU that way).
  void EvaluateCameraCorners(const PreparedCamera& cam, std::vector<Eigen::Vector2d>* e,
                             std::vector<char>* ok);

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
  void ForEachSegment(F&& f) const;

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

  void AddCameraFrames(PreparedCamera* cam, bool robust);

  void AddCamera(PreparedCamera* cam, bool robust);
  void AddLensRegularization(const PreparedCamera& cam);

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
  void VisitSamples(PreparedInertial& in, F&& f);

  // The run length of the sensor's compressed blocks (inertial_block_residual.h), 0 for one block
  // per sample: from the sensor's rate unless SplineCalibratorOptions forces it.
  template <class Set>
  int InertialSegments(const Set& set, const std::vector<double*>& common) const;

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

  void AddInertial(PreparedInertial& in);

  // Adds the row groups of up to `threads` runs (inertial_row_groups.h) interleaved, group k of
  // every run before group k + 1: Ceres 2.1 hands residual block j to thread j mod threads, so
  // every group of one run goes to one thread, which factors the run once and reads it in turn,
  // instead of the run's groups meeting on two threads where one would wait for the other's
  // factorisation.
  void AddRowGroups(
      std::vector<std::vector<std::pair<ceres::CostFunction*, std::vector<double*>>>>* batch,
      std::vector<ceres::ResidualBlockId>* ids);

  // Priors of `prior_sigma` on the estimated blocks, centred on the input's guesses.
  void AddPriors();

  Prepared& prep_;
  CalibrationState& state_;
  SplineCalibratorOptions options_;
  CalibrationLog log_;
  Spline spline_;
  std::unique_ptr<ceres::Problem> problem_;
  std::unique_ptr<LevenbergMarquardt> solver_;  // of the last solve (lm_solver)
  // The solves' factorisation: the robust and final solve and the covariance share its analysis.
  std::shared_ptr<NuisanceFactorisation> factorisation_;
  std::vector<ParameterBlockInfo> blocks_;
  std::vector<std::vector<double>> prior_center_;
  std::vector<std::pair<std::string, std::vector<ceres::ResidualBlockId>>> inertial_ids_;
  std::vector<std::vector<ceres::ResidualBlockId>> camera_ids_;  // per prep camera
  // Per inertial sensor: its blocks hold whole samples' rows (one per sample or stacked), not a
  // compressed factor that mixes the gyro and accelerometer rows (NoiseComponents).
  std::vector<bool> inertial_rows_per_sample_;
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

}  // namespace spline_internal
}  // namespace ctcal
