// The discrete MVIS calibration problem (discrete_calibrator.h): keyframe states, preintegration
// factors, interpolated auxiliary and camera residuals, and the spline method's data selection,
// initial trajectory, priors, solver settings and result writing (spline_problem_impl.h).
// Its keyframes are in problem_keyframes.cpp, its building in problem_build.cpp, its solving in
// problem_solve.cpp. Private to the calibrator library.
#pragma once

#include "ctcal/calibrator/discrete_calibrator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <thread>

#include "../problem/spline_problem_impl.h"
#include "ctcal/calibrator/discrete/discrete_residuals.h"
#include "ctcal/calibrator/discrete/frame_corners.h"
#include "ctcal/calibrator/observability/motion_prediction.h"
#include "ctcal/calibrator/report_data_builder.h"

namespace ctcal {
namespace discrete_internal {

using discrete::AuxGyroFunctor;
using discrete::AuxGyroIndex;
using discrete::AuxImuFunctor;
using discrete::AuxImuIndex;
using discrete::BaseSource;
using discrete::BlockList;
using discrete::CornerIndex;
using discrete::GyroPreintegration;
using discrete::ImuBlockIndex;
using discrete::Keyframe;
using discrete::Preintegration;
using discrete::RawImuSample;
using spline_internal::Prepared;
using spline_internal::PreparedCamera;
using spline_internal::PreparedInertial;

inline std::string Fmt(const char* format, double a, double b = 0.0, double c = 0.0) {
  char line[256];
  std::snprintf(line, sizeof line, format, a, b, c);
  return line;
}

// Per-keyframe states of one auxiliary inertial sensor.
struct AuxStates {
  PreparedInertial* in = nullptr;
  std::vector<RawImuSample> samples;  // own clock, s relative to t0
  std::vector<std::array<double, 3>> v, bg, ba;
  double time_offset_at_build = 0.0;
};

// Which keyframe(s) a corner reads (to detect when the time offsets moved it).
struct CornerSlot {
  int k = -1;
  bool kinematic = true;
  bool operator!=(const CornerSlot& o) const { return k != o.k || kinematic != o.kinematic; }
};

class DiscreteProblem {
 public:
  DiscreteProblem(Prepared* prep, const DiscreteCalibratorOptions& options,
                  const SplineCalibratorOptions& spline_options, const CalibrationLog& log)
      : prep_(*prep),
        state_(*prep->state),
        options_(options),
        spline_options_(spline_options),
        log_(log) {}

  int NumKeyframes() const { return static_cast<int>(kf_.size()); }

  // Keyframe times, the initial states from the spline method's initial trajectory (sampled at
  // the keyframes: pose, velocity, rate), gravity, biases 0; auxiliary velocities as the rigid
  // body's (report section 3.2).
  void Initialize(SplineCalibrationResult* out);

  // The largest change of a sensor's time offset since the keyframes were chosen: the cameras'
  // place the keyframes, the auxiliary sensors' anchor their intervals (at tau = t_k - offset)
  // and bound the common time range.
  double KeyframeDrift() const;

  // Re-chooses the keyframes (RechooseKeyframes) when a time offset has moved by more than
  // rechoose_keyframes_fraction of the A.1 window since they were chosen; says so, or returns
  // empty.
  std::string MaybeRechoose();

  // Keyframes at the frame times of the current time offsets, with the current solution carried
  // over from the old keyframes (the caller rebuilds the problem):
  //  - base pose and velocity: the report's C2 interpolation of the old keyframe states
  //    (KeyframeTrajectory: position quintic through p, v and the A.1 acceleration at both ends,
  //    rotation cubic through the corrected rates), which follows the IMU's motion between
  //    keyframes, where the geodesic A.2 errs by millimetres;
  //  - biases: the old interval's, as its factors held them;
  //  - auxiliary velocities: the rigid-body velocity of the interpolated base motion at the new
  //    time plus the old state's deviation from it, linearly interpolated (the deviation is
  //    smooth; the velocity itself changes by ~m/s^2 x 25 ms between keyframes). The old state k
  //    sits at base time t_k + s, s the offset's change since the last build (AuxImuFunctor).
  void RechooseKeyframes();

  void Build(bool robust);

  // The spline problem's solver settings (SplineProblem::Solve): Gauss-Newton steps from the
  // start (trust region 1e8; every solve starts in the basin: the initial trajectory, then the
  // previous solve's states), a relative cost change of 1e-6 for the robust solve (it only seeds
  // the outlier gate), and the plain solves stop once a step would lower the cost by less than
  // stop_cost_change (every scalar within sqrt(2 stop_cost_change) sigma of the converged one).
  ceres::Solver::Summary Solve();

  // Marks the corners whose whitened residual norm^2 exceeds the chi-square(2) gate.
  void RemoveOutliers(double probability, std::vector<CameraOutliers>* report);

  // Residuals that the current time offsets would attach to other keyframes (or interpolation),
  // plus auxiliary sensors whose offset moved beyond the A.1 window since the build.
  int CountRebuild() const;

  // RunStages' hooks (spline_problem_solve.h). Keyframes placed at the guessed time offsets are
  // re-placed once the offsets have moved (the robust stage's corners stayed on the keyframes
  // they were built with, through A.1 at the offset's change, so its outlier gate is unaffected);
  // otherwise a rebuild while the offsets move residuals to other keyframes or interpolation.
  void BeforePlainSolve() {
    const std::string why = MaybeRechoose();
    if (!why.empty())
      log_("  " + why);
  }
  std::string NextRebuild();
  int Rechoices() const { return rechoices_; }

  // Corners of the current problem read through A.1 and through A.2.
  void CountInterpolation(int* kinematic, int* geodesic) const;

  void Finish(SplineCalibrationResult* out);

  // The report's data (report_data_builder.h): poses as the corner residuals read them, the
  // keyframe states' biases.
  report::ReportData ReportData(const SplineCalibrationResult& out);

 private:
  // --- keyframes --------------------------------------------------------------------------------

  // The common time range of every inertial sensor (base clock), less a margin for the time
  // offsets and the interpolation stencil.
  void CommonRange(double* lo, double* hi) const;

  void ChooseKeyframes();

  // Camera frames closer than this share a keyframe: merge_s, and at least 1.5 sample periods of
  // every IMU, so that each preintegration interval holds a sample. An interval without one is
  // a single integration step, whose [dv, dp] covariance has rank 3 (dp = dv h / 2 for the one
  // reading): the whitening fails (seed 302 of the 5 s Monte Carlo, two frames 2.04 ms apart at
  // 250 Hz). The later frame's corners are read through A.1 at up to that distance (6 ms at
  // 250 Hz, where the midpoint A.1 errs by ~1e-6 rad).
  double MergeSpacing() const;

  static RawImuSample RawAt(const std::vector<RawImuSample>& s, double t);

  // --- residuals --------------------------------------------------------------------------------

  bool BaseIntrinsicsEstimated() const;

  void AddBaseImu();

  void AddAux(AuxStates* a);

  double CornerTime(const PreparedCamera& cam, std::size_t i) const;

  // A.1 from the nearest keyframe within the window, else A.2 on the interval holding t; k = -1
  // outside the keyframes.
  CornerSlot SlotOf(double t) const;

  // The per-corner residual's blocks for a corner of `cam` read through `slot`.
  ceres::CostFunction* CornerCost(PreparedCamera* cam, std::size_t i, const CornerSlot& slot,
                                  BlockList* list);

  double Stamp(const PreparedCamera& cam, std::size_t i) const;

  // The corner's whitened residual at the current values, evaluated on its own (the statistics
  // and the outlier gate need it per corner, also where the problem holds frame blocks).
  bool EvaluateCorner(const PreparedCamera& cam, std::size_t i, const CornerSlot& slot,
                      Eigen::Vector2d* e);

  // Whether the camera's corners enter as compressed per-frame blocks (frame_corners.h): a
  // global-shutter camera (line_delay 0 and not estimated), whose corners of one frame share the
  // pose; rolling shutter reads every corner at its own row time and keeps one block per corner.
  bool Compressed(const PreparedCamera& cam) const;

  void AddCamera(PreparedCamera* cam, bool robust);

  // One compressed block per frame (frame_corners.h): runs of `in_problem` with one stamp, which
  // share the slot (global shutter: one exposure time); the robust stage's Huber weights are
  // applied per corner inside the block.
  void AddCameraFrames(PreparedCamera* cam,
                       const std::vector<std::pair<std::size_t, CornerSlot>>& in_problem,
                       bool robust);

  Prepared& prep_;
  CalibrationState& state_;
  DiscreteCalibratorOptions options_;
  SplineCalibratorOptions spline_options_;
  CalibrationLog log_;
  std::vector<Keyframe> kf_;
  std::vector<RawImuSample> base_samples_;
  std::vector<AuxStates> aux_;
  std::unique_ptr<ceres::Problem> problem_;
  std::vector<ParameterBlockInfo> blocks_;
  std::vector<std::vector<double>> prior_center_;
  std::set<double*> calib_ptrs_;
  // Per camera, the corners in the problem and the keyframe(s) each reads.
  std::vector<std::vector<std::pair<std::size_t, CornerSlot>>> corner_slots_;
  std::vector<std::pair<std::string, std::vector<ceres::ResidualBlockId>>> inertial_ids_;
  std::vector<ceres::ResidualBlockId> prior_ids_;
  std::vector<CornerSlot> slots_;
  // Per camera, then per auxiliary sensor: the time offsets the keyframes were chosen with.
  std::vector<double> offsets_at_keyframes_;
  bool robust_ = false;
  double last_cost_ = 0.0;  // of the last solve
  int rechoices_ = 0;
  So3LeftManifold so3_left_;
  ceres::SphereManifold<3> sphere_;
};

}  // namespace discrete_internal
}  // namespace ctcal
