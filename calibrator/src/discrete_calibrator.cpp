// The discrete MVIS calibration problem (discrete_calibrator.h): keyframe states, preintegration
// factors, interpolated auxiliary and camera residuals, and the spline method's data selection,
// initial trajectory, priors, solver settings and result writing (spline_problem_impl.h).
#include "ctcal/calibrator/discrete_calibrator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <thread>

#include "ctcal/calibrator/discrete/discrete_residuals.h"
#include "ctcal/calibrator/discrete/frame_corners.h"
#include "ctcal/calibrator/observability/motion_prediction.h"
#include "ctcal/calibrator/report_data_builder.h"
#include "spline_problem_impl.h"

namespace ctcal {
namespace {

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

std::string Fmt(const char* format, double a, double b = 0.0, double c = 0.0) {
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
  void Initialize(SplineCalibrationResult* out) {
    const std::int64_t t0 = prep_.t0_ns;
    const auto sec = [t0](std::int64_t t_ns) { return 1e-9 * static_cast<double>(t_ns - t0); };
    const PreparedInertial& base_in = prep_.inertial.front();
    for (const ImuSample& z : base_in.imu)
      base_samples_.push_back(RawImuSample{sec(z.t_ns), z.w_m, z.a_m});
    for (std::size_t i = 1; i < prep_.inertial.size(); ++i) {
      AuxStates a;
      a.in = &prep_.inertial[i];
      for (const ImuSample& z : a.in->imu)
        a.samples.push_back(RawImuSample{sec(z.t_ns), z.w_m, z.a_m});
      for (const GyroSample& z : a.in->gyro)
        a.samples.push_back(RawImuSample{sec(z.t_ns), z.w_m, Eigen::Vector3d::Zero()});
      aux_.push_back(std::move(a));
    }

    ChooseKeyframes();
    out->num_knots = 0;

    spline_internal::SplineProblem<4, Se3Representation::kSplit> sp(&prep_, spline_options_, log_);
    sp.InitializeTrajectory();  // also gravity
    out->knot_spacing_s = prep_.knot_spacing_s;
    out->num_knots = sp.NumKnots();
    const auto& spline = sp.spline();
    const auto kin_at = [&](double t) {
      const std::int64_t t_ns = t0 + static_cast<std::int64_t>(std::llround(t * 1e9));
      return spline.Evaluate(std::min(std::max(t_ns, spline.MinTimeNs()), spline.MaxTimeNs()), 1);
    };
    for (Keyframe& k : kf_) {
      const Se3Kinematics<double> kin = kin_at(k.t);
      const Eigen::Quaterniond q(kin.R_W_B);
      k.q_W_B = {q.x(), q.y(), q.z(), q.w()};
      for (int i = 0; i < 3; ++i) {
        k.p_W_B[static_cast<std::size_t>(i)] = kin.p_W_B(i);
        k.v_W[static_cast<std::size_t>(i)] = kin.v_W(i);
      }
    }
    for (AuxStates& a : aux_) {
      const SensorState& s = *a.in->state;
      const std::size_t n = kf_.size();
      a.v.assign(n, {0.0, 0.0, 0.0});
      a.bg.assign(n, {0.0, 0.0, 0.0});
      a.ba.assign(n, {0.0, 0.0, 0.0});
      for (std::size_t k = 0; k < n; ++k) {
        const Se3Kinematics<double> kin = kin_at(kf_[k].t);
        const Eigen::Vector3d v = kin.v_W + kin.R_W_B * kin.w_B.cross(s.p_B_S());
        a.v[k] = {v.x(), v.y(), v.z()};
      }
    }
    const Eigen::Vector3d g = state_.gravity();
    log_(Fmt("  gravity_W initialised to [%.4f, %.4f, %.4f]", g.x(), g.y(), g.z()));
  }

  // The largest change of a sensor's time offset since the keyframes were chosen: the cameras'
  // place the keyframes, the auxiliary sensors' anchor their intervals (at tau = t_k - offset)
  // and bound the common time range.
  double KeyframeDrift() const {
    double drift = 0.0;
    std::size_t i = 0;
    for (const PreparedCamera& cam : prep_.cameras)
      drift = std::max(drift, std::abs(cam.state->time_offset - offsets_at_keyframes_[i++]));
    for (const AuxStates& a : aux_)
      drift = std::max(drift, std::abs(a.in->state->time_offset - offsets_at_keyframes_[i++]));
    return drift;
  }

  // Re-chooses the keyframes (RechooseKeyframes) when a time offset has moved by more than
  // rechoose_keyframes_fraction of the A.1 window since they were chosen; says so, or returns
  // empty.
  std::string MaybeRechoose() {
    const double drift = KeyframeDrift();
    if (drift <= options_.rechoose_keyframes_fraction * options_.kinematic_window_s)
      return {};
    RechooseKeyframes();
    ++rechoices_;
    return Fmt("keyframes re-chosen: offsets moved %.2f ms", 1e3 * drift);
  }

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
  void RechooseKeyframes() {
    problem_.reset();  // reads the old keyframes' memory
    const std::vector<Keyframe> old = kf_;
    std::vector<double> t_old;
    for (const Keyframe& k : old)
      t_old.push_back(k.t);
    ImuIntrinsics* base = &*state_.base().imu;
    const TrajectoryEvaluator motion =
        KeyframeTrajectory(old, base, state_.gravity(), prep_.t0_ns, nullptr);
    const auto kin_at = [&](double t) {
      return motion(prep_.t0_ns + static_cast<std::int64_t>(std::llround(t * 1e9)), 1);
    };
    // The old keyframe whose interval holds t (clamped to the ends).
    const auto interval_of = [&](double t) {
      const auto it = std::upper_bound(t_old.begin(), t_old.end(), t);
      return static_cast<std::size_t>(std::clamp<std::ptrdiff_t>(
          it - t_old.begin() - 1, 0, static_cast<std::ptrdiff_t>(t_old.size()) - 2));
    };
    std::vector<std::vector<Eigen::Vector3d>> deviation(aux_.size());
    for (std::size_t i = 0; i < aux_.size(); ++i) {
      const AuxStates& a = aux_[i];
      const double s = a.in->state->time_offset - a.time_offset_at_build;
      for (std::size_t k = 0; k < old.size(); ++k) {
        const Se3Kinematics<double> kin = kin_at(old[k].t + s);
        const Eigen::Vector3d rigid = kin.v_W + kin.R_W_B * kin.w_B.cross(a.in->state->p_B_S());
        deviation[i].push_back(Eigen::Vector3d(a.v[k].data()) - rigid);
      }
    }

    ChooseKeyframes();
    for (Keyframe& k : kf_) {
      const Se3Kinematics<double> kin = kin_at(k.t);
      const Eigen::Quaterniond q(kin.R_W_B);
      k.q_W_B = {q.x(), q.y(), q.z(), q.w()};
      Eigen::Map<Eigen::Vector3d>(k.p_W_B.data()) = kin.p_W_B;
      Eigen::Map<Eigen::Vector3d>(k.v_W.data()) = kin.v_W;
      const Keyframe& from = old[interval_of(k.t)];
      k.b_g = from.b_g;
      k.b_a = from.b_a;
    }
    for (std::size_t i = 0; i < aux_.size(); ++i) {
      AuxStates& a = aux_[i];
      const double s = a.in->state->time_offset - a.time_offset_at_build;
      const std::size_t n = kf_.size();
      std::vector<std::array<double, 3>> v(n), bg(n), ba(n);
      for (std::size_t k = 0; k < n; ++k) {
        const double t = kf_[k].t - s;  // on the old states' time axis
        const std::size_t j = interval_of(t);
        const double u = std::clamp((t - t_old[j]) / (t_old[j + 1] - t_old[j]), 0.0, 1.0);
        const Se3Kinematics<double> kin = kin_at(kf_[k].t);
        const Eigen::Vector3d v_k = kin.v_W + kin.R_W_B * kin.w_B.cross(a.in->state->p_B_S()) +
                                    (1.0 - u) * deviation[i][j] + u * deviation[i][j + 1];
        v[k] = {v_k.x(), v_k.y(), v_k.z()};
        bg[k] = a.bg[j];
        ba[k] = a.ba[j];
      }
      a.v = std::move(v);
      a.bg = std::move(bg);
      a.ba = std::move(ba);
    }
  }

  void Build(bool robust) {
    robust_ = robust;
    ceres::Problem::Options po;
    po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_ = std::make_unique<ceres::Problem>(po);
    corner_slots_.clear();
    inertial_ids_.clear();
    slots_.clear();
    ceres::Problem& P = *problem_;
    blocks_ = state_.Blocks();
    if (prior_center_.empty()) {
      // On the rig file's values, not on the initialisation's (coarse_init.h), as the spline's.
      CalibrationState guess(state_.rig());
      for (const ParameterBlockInfo& b : guess.Blocks())
        prior_center_.emplace_back(b.values, b.values + b.ambient_size);
    }
    for (ParameterBlockInfo& b : blocks_) {
      if (b.key == "gravity_W")
        P.AddParameterBlock(b.values, 3, &sphere_);
      else if (b.left_rotation)
        P.AddParameterBlock(b.values, 4, &so3_left_);
      else
        P.AddParameterBlock(b.values, b.ambient_size);
    }
    for (Keyframe& k : kf_)
      P.AddParameterBlock(k.q_W_B.data(), 4, &so3_left_);

    AddBaseImu();
    for (AuxStates& a : aux_)
      AddAux(&a);
    for (PreparedCamera& cam : prep_.cameras)
      AddCamera(&cam, robust);
    prior_ids_ = spline_internal::AddCalibrationPriors(problem_.get(), blocks_, prior_center_,
                                                       spline_options_.analytic);

    // Constant: every calibration block not estimated (also those only a residual reads, e.g. a
    // global-shutter camera's line delay or the base intrinsics of an A.1 interpolation).
    std::set<double*> estimated;
    for (const ParameterBlockInfo& b : blocks_) {
      if (b.estimated)
        estimated.insert(b.values);
    }
    for (double* p : calib_ptrs_) {
      if (P.HasParameterBlock(p) && estimated.count(p) == 0)
        P.SetParameterBlockConstant(p);
    }
    for (const ParameterBlockInfo& b : blocks_) {
      if (P.HasParameterBlock(b.values) && !b.estimated)
        P.SetParameterBlockConstant(b.values);
    }
    spline_internal::BoundCameraParameters(prep_.cameras, &P);
  }

  // The spline problem's solver settings (SplineProblem::Solve): Gauss-Newton steps from the
  // start (trust region 1e8; every solve starts in the basin: the initial trajectory, then the
  // previous solve's states), a relative cost change of 1e-6 for the robust solve (it only seeds
  // the outlier gate), and the plain solves stop once a step would lower the cost by less than
  // stop_cost_change (every scalar within sqrt(2 stop_cost_change) sigma of the converged one).
  ceres::Solver::Summary Solve() {
    spline_internal::IterationLogger logger(log_);
    ceres::Solver::Options so = spline_internal::SolverOptions(spline_options_, &logger);
    so.initial_trust_region_radius = 1e8;
    if (robust_)
      so.function_tolerance = 1e-6;
    else if (spline_options_.stop_cost_change > 0.0 && last_cost_ > 0.0)
      so.function_tolerance =
          std::max(so.function_tolerance, spline_options_.stop_cost_change / last_cost_);
    ceres::Solver::Summary summary;
    ceres::Solve(so, problem_.get(), &summary);
    last_cost_ = summary.final_cost;
    if (summary.termination_type == ceres::FAILURE || !std::isfinite(summary.final_cost))
      throw CalibrationFailure("the solve diverged (" + summary.message +
                               "): check the initial guesses and the noise settings");
    return summary;
  }

  // Marks the corners whose whitened residual norm^2 exceeds the chi-square(2) gate.
  void RemoveOutliers(double probability, std::vector<CameraOutliers>* report) {
    const double gate = -2.0 * std::log(1.0 - probability);
    for (std::size_t c = 0; c < prep_.cameras.size(); ++c) {
      PreparedCamera& cam = prep_.cameras[c];
      CameraOutliers o;
      o.camera = cam.state->name();
      o.views = static_cast<int>(cam.views.size());
      o.invalid = cam.invalid;
      const auto& in_problem = corner_slots_[c];
      o.corners = static_cast<int>(in_problem.size());
      for (const auto& [i, slot] : in_problem) {
        Eigen::Vector2d e;
        if (!EvaluateCorner(cam, i, slot, &e) || e.squaredNorm() > gate) {
          cam.removed[i] = true;
          ++o.removed;
        }
      }
      report->push_back(o);
    }
  }

  // Residuals that the current time offsets would attach to other keyframes (or interpolation),
  // plus auxiliary sensors whose offset moved beyond the A.1 window since the build.
  int CountRebuild() const {
    int changed = 0;
    std::size_t i = 0;
    for (const PreparedCamera& cam : prep_.cameras) {
      for (std::size_t c = 0; c < cam.corners.size(); ++c) {
        if (cam.removed[c])
          continue;
        if (i >= slots_.size() || SlotOf(CornerTime(cam, c)) != slots_[i])
          ++changed;
        ++i;
      }
    }
    for (const AuxStates& a : aux_) {
      if (std::abs(a.in->state->time_offset - a.time_offset_at_build) >
          0.5 * options_.kinematic_window_s)
        changed += static_cast<int>(kf_.size());
    }
    return changed;
  }

  // RunStages' hooks (spline_problem_impl.h). Keyframes placed at the guessed time offsets are
  // re-placed once the offsets have moved (the robust stage's corners stayed on the keyframes
  // they were built with, through A.1 at the offset's change, so its outlier gate is unaffected);
  // otherwise a rebuild while the offsets move residuals to other keyframes or interpolation.
  void BeforePlainSolve() {
    const std::string why = MaybeRechoose();
    if (!why.empty())
      log_("  " + why);
  }
  std::string NextRebuild() {
    std::string why = MaybeRechoose();
    if (why.empty()) {
      const int changed = CountRebuild();
      if (changed > 0)
        why = std::to_string(changed) +
              " residuals moved to other keyframes with the time offsets: rebuilt";
    }
    return why;
  }
  int Rechoices() const { return rechoices_; }

  // Corners of the current problem read through A.1 and through A.2.
  void CountInterpolation(int* kinematic, int* geodesic) const {
    *kinematic = *geodesic = 0;
    for (const auto& cam : corner_slots_) {
      for (const auto& entry : cam)
        ++(entry.second.kinematic ? *kinematic : *geodesic);
    }
  }

  void Finish(SplineCalibrationResult* out) {
    // Corner statistics: FinishResult's, from every corner evaluated on its own (also where the
    // problem holds frame blocks); the preintegration factors' below.
    std::vector<spline_internal::CornerResiduals> corners;
    for (std::size_t c = 0; c < prep_.cameras.size(); ++c) {
      const PreparedCamera& cam = prep_.cameras[c];
      spline_internal::CornerResiduals rc;
      rc.camera = cam.state->name();
      for (const auto& [i, slot] : corner_slots_[c]) {
        Eigen::Vector2d e;
        if (!EvaluateCorner(cam, i, slot, &e))
          continue;
        rc.whitened.push_back(e);
        rc.sigma_px.push_back(cam.corners[i].sigma_px);
      }
      corners.push_back(std::move(rc));
    }
    spline_internal::FinishResult(*problem_, state_, prior_ids_, corners, {}, spline_options_, log_,
                                  out);
    for (const auto& [name, ids] : inertial_ids_) {
      const SensorState* s = state_.Find(name);
      const bool imu = s->config.type == SensorType::kImu;
      const int m = imu ? 9 : 3;
      double wr = 0.0, wva = 0.0;
      for (const ceres::ResidualBlockId id : ids) {
        double e[9];
        problem_->EvaluateResidualBlock(id, false, nullptr, e, nullptr);
        for (int i = 0; i < 3; ++i)
          wr += e[i] * e[i];
        for (int i = 3; i < m; ++i)
          wva += e[i] * e[i];
      }
      const double n = std::max<double>(1.0, static_cast<double>(ids.size()));
      SensorResiduals r;
      r.count = static_cast<std::int64_t>(m * ids.size());
      r.rms_whitened_gyro = std::sqrt(wr / (3.0 * n));
      r.rms_gyro = *r.rms_whitened_gyro * s->config.noise.GyroSampleSigma();
      if (imu) {
        r.rms_whitened_accel = std::sqrt(wva / (6.0 * n));
        r.rms_accel = *r.rms_whitened_accel * s->config.noise.AccelSampleSigma();
      }
      r.rms_whitened = std::sqrt((wr + wva) / (static_cast<double>(m) * n));
      out->result.residuals[name] = r;
      char line[256];
      std::snprintf(line, sizeof line,
                    "  %-8s whitened RMS %.3f over %lld preintegrated residuals (rotation %.3f)",
                    name.c_str(), *r.rms_whitened, static_cast<long long>(r.count),
                    *r.rms_whitened_gyro);
      log_(line);
    }
    if (spline_options_.report_data)
      out->report_data = ReportData(*out);
  }

  // The report's data (report_data_builder.h): poses as the corner residuals read them, the
  // keyframe states' biases.
  report::ReportData ReportData(const SplineCalibrationResult& out) {
    std::vector<double> t;
    std::vector<Eigen::Vector3d> bg, ba;
    for (const Keyframe& k : kf_) {
      t.push_back(k.t);
      bg.emplace_back(k.b_g.data());
      ba.emplace_back(k.b_a.data());
    }
    std::map<std::string, BiasEvaluator> bias;
    bias[state_.base().name()] = KeyframeBiases(t, bg, ba, prep_.t0_ns, 0.0);
    for (const AuxStates& a : aux_) {
      std::vector<Eigen::Vector3d> abg, aba;
      for (std::size_t k = 0; k < kf_.size(); ++k) {
        abg.emplace_back(a.bg[k].data());
        if (a.in->state->config.type == SensorType::kImu)
          aba.emplace_back(a.ba[k].data());
      }
      bias[a.in->state->name()] =
          KeyframeBiases(t, abg, aba, prep_.t0_ns, a.in->state->time_offset);
    }
    const auto slot = [this](double time) {
      const CornerSlot s = SlotOf(time);
      return KeyframeSlot{s.k, s.kinematic};
    };
    return spline_internal::SplineReportData(
        prep_, KeyframeTrajectory(kf_, &*state_.base().imu, state_.gravity(), prep_.t0_ns, slot),
        out, std::move(bias));
  }

 private:
  // --- keyframes --------------------------------------------------------------------------------

  // The common time range of every inertial sensor (base clock), less a margin for the time
  // offsets and the interpolation stencil.
  void CommonRange(double* lo, double* hi) const {
    *lo = base_samples_.front().t;
    *hi = base_samples_.back().t;
    for (const AuxStates& a : aux_) {
      *lo = std::max(*lo, a.samples.front().t + a.in->state->time_offset);
      *hi = std::min(*hi, a.samples.back().t + a.in->state->time_offset);
    }
    *lo += 0.03;
    *hi -= 0.03;
  }

  void ChooseKeyframes() {
    double lo = 0.0, hi = 0.0;
    CommonRange(&lo, &hi);
    std::vector<double> times;
    if (options_.keyframe_rate_hz > 0.0) {
      // At most one keyframe per base sample: a higher rate holds no preintegrated interval
      // between keyframes, and 1e300 Hz added 1e-300 s to t forever (killed for its memory).
      const double sample_rate = static_cast<double>(base_samples_.size() - 1) /
                                 (base_samples_.back().t - base_samples_.front().t);
      if (!(options_.keyframe_rate_hz <= sample_rate))
        throw CalibrationInputError(
            Fmt("--keyframe-rate %.6g Hz is above the base IMU's sample "
                "rate (%.1f Hz): at most one keyframe per sample",
                options_.keyframe_rate_hz, sample_rate));
      const double step = 1.0 / options_.keyframe_rate_hz;
      for (int k = 0; lo + k * step <= hi; ++k)
        times.push_back(lo + k * step);
    } else {
      std::vector<double> frames;
      for (const PreparedCamera& cam : prep_.cameras) {
        for (const BoardView& v : cam.views) {
          const double t =
              1e-9 * static_cast<double>(v.t_ns - prep_.t0_ns) + cam.state->time_offset;
          if (t >= lo && t <= hi)
            frames.push_back(t);
        }
      }
      std::sort(frames.begin(), frames.end());
      for (const double t : frames) {
        if (!times.empty() && t - times.back() < MergeSpacing())
          continue;
        if (!times.empty() && t - times.back() > options_.max_gap_s) {
          const double gap = t - times.back();
          const int extra = static_cast<int>(std::ceil(gap / options_.max_gap_s)) - 1;
          const double t_prev = times.back();
          for (int e = 1; e <= extra; ++e)
            times.push_back(t_prev + gap * e / (extra + 1));
        }
        times.push_back(t);
      }
    }
    offsets_at_keyframes_.clear();
    for (const PreparedCamera& cam : prep_.cameras)
      offsets_at_keyframes_.push_back(cam.state->time_offset);
    for (const AuxStates& a : aux_)
      offsets_at_keyframes_.push_back(a.in->state->time_offset);
    if (times.size() < 3)
      throw CalibrationInputError("too few keyframes (" + std::to_string(times.size()) +
                                  ") in the sensors' common time range");
    kf_.resize(times.size());
    for (std::size_t k = 0; k < times.size(); ++k) {
      kf_[k].t = times[k];
      kf_[k].raw = RawAt(base_samples_, times[k]);
      // d/dt of the raw readings' cubic (central difference: exact to O(eps^2) on a cubic).
      const double eps = 1e-4;
      const RawImuSample after = RawAt(base_samples_, times[k] + eps);
      const RawImuSample before = RawAt(base_samples_, times[k] - eps);
      kf_[k].raw_rate.w_m = (after.w_m - before.w_m) / (2.0 * eps);
      kf_[k].raw_rate.a_m = (after.a_m - before.a_m) / (2.0 * eps);
    }
    log_(Fmt("  %.0f keyframes over %.3f s (mean spacing %.4f s)", static_cast<double>(kf_.size()),
             times.back() - times.front(),
             (times.back() - times.front()) / static_cast<double>(times.size() - 1)));
  }

  // Camera frames closer than this share a keyframe: merge_s, and at least 1.5 sample periods of
  // every IMU, so that each preintegration interval holds a sample. An interval without one is
  // a single integration step, whose [dv, dp] covariance has rank 3 (dp = dv h / 2 for the one
  // reading): the whitening fails (seed 302 of the 5 s Monte Carlo, two frames 2.04 ms apart at
  // 250 Hz). The later frame's corners are read through A.1 at up to that distance (6 ms at
  // 250 Hz, where the midpoint A.1 errs by ~1e-6 rad).
  double MergeSpacing() const {
    double period = 0.0;
    const auto longest = [&period](const std::vector<RawImuSample>& z) {
      if (z.size() > 1)
        period = std::max(period, (z.back().t - z.front().t) / static_cast<double>(z.size() - 1));
    };
    longest(base_samples_);
    for (const AuxStates& a : aux_) {
      if (a.in->state->config.type == SensorType::kImu)
        longest(a.samples);
    }
    return std::max(options_.merge_s, 1.5 * period);
  }

  static RawImuSample RawAt(const std::vector<RawImuSample>& s, double t) {
    const auto it = std::upper_bound(s.begin(), s.end(), t,
                                     [](double x, const RawImuSample& r) { return x < r.t; });
    const std::size_t k = static_cast<std::size_t>(std::max<std::ptrdiff_t>(
        0,
        std::min<std::ptrdiff_t>(it - s.begin() - 1, static_cast<std::ptrdiff_t>(s.size()) - 2)));
    return discrete::detail::InterpolateRaw(s, k, t);
  }

  // --- residuals --------------------------------------------------------------------------------

  bool BaseIntrinsicsEstimated() const {
    for (const ParameterBlockInfo& b : blocks_) {
      if (b.sensor == state_.base().name() && b.estimated)
        return true;
    }
    return false;
  }

  void AddBaseImu() {
    SensorState& s = state_.base();
    ImuIntrinsics& intr = *s.imu;
    const InertialNoise& noise = s.config.noise;
    const bool reintegrate = BaseIntrinsicsEstimated();
    std::vector<ceres::ResidualBlockId> ids;
    for (double* p : {intr.Dw(), intr.Da(), intr.Tg(), intr.q_rotation()}) {
      if (p != nullptr)
        calib_ptrs_.insert(p);
    }
    for (std::size_t k = 0; k + 1 < kf_.size(); ++k) {
      Keyframe& a = kf_[k];
      Keyframe& b = kf_[k + 1];
      auto pre = std::make_shared<Preintegration>(base_samples_, a.t, b.t, intr, noise,
                                                  Eigen::Vector3d(a.b_g.data()),
                                                  Eigen::Vector3d(a.b_a.data()));
      std::vector<double*> blocks{a.q_W_B.data(), a.p_W_B.data(), a.v_W.data(),
                                  a.b_g.data(),   a.b_a.data(),   b.q_W_B.data(),
                                  b.p_W_B.data(), b.v_W.data(),   state_.g_W()};
      ceres::CostFunction* cost = nullptr;
      if (reintegrate) {
        for (double* p : {intr.Dw(), intr.Da(), intr.Tg(), intr.q_rotation()}) {
          if (p != nullptr)
            blocks.push_back(p);
        }
        cost = discrete::ReintegrationFactor::CreateSplit(pre, intr);
      } else {
        cost = discrete::PreintegrationFactor::Create(pre);
      }
      ids.push_back(problem_->AddResidualBlock(cost, nullptr, blocks));
      const double dt = b.t - a.t;
      problem_->AddResidualBlock(MakeBiasRandomWalkResidual(true, noise.gyroscope_random_walk, dt),
                                 nullptr, a.b_g.data(), b.b_g.data());
      problem_->AddResidualBlock(
          MakeBiasRandomWalkResidual(true, noise.accelerometer_random_walk, dt), nullptr,
          a.b_a.data(), b.b_a.data());
    }
    inertial_ids_.emplace_back(s.name(), std::move(ids));
  }

  void AddAux(AuxStates* a) {
    SensorState& s = *a->in->state;
    SensorState& base = state_.base();
    const InertialNoise& noise = s.config.noise;
    const bool imu = s.config.type == SensorType::kImu;
    const bool rigid = options_.aux_velocity == AuxVelocityModel::kRigid;
    a->time_offset_at_build = s.time_offset;
    std::vector<ceres::ResidualBlockId> ids;
    calib_ptrs_.insert(s.q_B_S.data());
    calib_ptrs_.insert(s.t_B_S.data());
    calib_ptrs_.insert(&s.time_offset);
    if (imu) {
      for (double* p : {s.imu->Dw(), s.imu->Da(), s.imu->Tg(), s.imu->q_rotation()}) {
        if (p != nullptr)
          calib_ptrs_.insert(p);
      }
    } else if (s.gyro->Dw() != nullptr) {
      calib_ptrs_.insert(s.gyro->Dw());
    }
    for (std::size_t k = 0; k + 1 < kf_.size(); ++k) {
      const double tau_i = kf_[k].t - s.time_offset;
      const double tau_j = kf_[k + 1].t - s.time_offset;
      BlockList list;
      const BaseSource src_i = BaseSource::Add(&list, &kf_[k], nullptr, &*base.imu, state_.g_W());
      const BaseSource src_j =
          BaseSource::Add(&list, &kf_[k + 1], nullptr, &*base.imu, state_.g_W());
      ceres::CostFunction* cost = nullptr;
      if (imu) {
        AuxImuIndex ix;
        ix.intr = ImuBlockIndex::Add(&list, &*s.imu);
        ix.q_B_A = list.Add(s.q_B_S.data(), 4);
        ix.t_B_A = list.Add(s.t_B_S.data(), 3);
        ix.time_offset = list.Add(&s.time_offset, 1);
        if (!rigid) {
          ix.v_i = list.Add(a->v[k].data(), 3);
          ix.v_j = list.Add(a->v[k + 1].data(), 3);
        }
        ix.bg = list.Add(a->bg[k].data(), 3);
        ix.ba = list.Add(a->ba[k].data(), 3);
        auto pre = std::make_shared<Preintegration>(a->samples, tau_i, tau_j, *s.imu, noise,
                                                    Eigen::Vector3d(a->bg[k].data()),
                                                    Eigen::Vector3d(a->ba[k].data()));
        cost = discrete::MakeSplitIntegration(AuxImuFunctor{pre, src_i, src_j, ix}, list, 9);
      } else {
        AuxGyroIndex ix;
        ix.model = s.gyro->model();
        if (s.gyro->Dw() != nullptr)
          ix.Dw = list.Add(s.gyro->Dw(), s.gyro->DwSize());
        ix.q_B_G = list.Add(s.q_B_S.data(), 4);
        ix.time_offset = list.Add(&s.time_offset, 1);
        ix.bg = list.Add(a->bg[k].data(), 3);
        auto pre = std::make_shared<GyroPreintegration>(a->samples, tau_i, tau_j, *s.gyro, noise,
                                                        Eigen::Vector3d(a->bg[k].data()));
        cost = discrete::MakeSplitIntegration(AuxGyroFunctor{pre, src_i, src_j, ix}, list, 3);
      }
      ids.push_back(problem_->AddResidualBlock(cost, nullptr, list.blocks()));
      const double dt = tau_j - tau_i;
      problem_->AddResidualBlock(MakeBiasRandomWalkResidual(true, noise.gyroscope_random_walk, dt),
                                 nullptr, a->bg[k].data(), a->bg[k + 1].data());
      if (imu)
        problem_->AddResidualBlock(
            MakeBiasRandomWalkResidual(true, noise.accelerometer_random_walk, dt), nullptr,
            a->ba[k].data(), a->ba[k + 1].data());
    }
    inertial_ids_.emplace_back(s.name(), std::move(ids));
  }

  double CornerTime(const PreparedCamera& cam, std::size_t i) const {
    const SensorState& s = *cam.state;
    return 1e-9 * static_cast<double>(cam.Stamp(i) - prep_.t0_ns) + s.time_offset +
           cam.corners[i].uv.y() * s.line_delay;
  }

  // A.1 from the nearest keyframe within the window, else A.2 on the interval holding t; k = -1
  // outside the keyframes.
  CornerSlot SlotOf(double t) const {
    const auto it = std::lower_bound(kf_.begin(), kf_.end(), t,
                                     [](const Keyframe& k, double x) { return k.t < x; });
    const int hi = static_cast<int>(it - kf_.begin());
    int nearest = hi;
    if (hi == static_cast<int>(kf_.size()) || (hi > 0 && t - kf_[hi - 1].t < kf_[hi].t - t))
      nearest = hi - 1;
    CornerSlot slot;
    if (std::abs(t - kf_[nearest].t) <= options_.kinematic_window_s) {
      slot.k = nearest;
      slot.kinematic = true;
    } else if (hi > 0 && hi < static_cast<int>(kf_.size())) {
      slot.k = hi - 1;
      slot.kinematic = false;
    }
    return slot;
  }

  // The per-corner residual's blocks for a corner of `cam` read through `slot`.
  ceres::CostFunction* CornerCost(PreparedCamera* cam, std::size_t i, const CornerSlot& slot,
                                  BlockList* list) {
    SensorState& s = *cam->state;
    const std::size_t k = static_cast<std::size_t>(slot.k);
    const BaseSource src = BaseSource::Add(list, &kf_[k], slot.kinematic ? nullptr : &kf_[k + 1],
                                           &*state_.base().imu, state_.g_W());
    CornerIndex c;
    c.q_B_C = list->Add(s.q_B_S.data(), 4);
    c.t_B_C = list->Add(s.t_B_S.data(), 3);
    c.time_offset = list->Add(&s.time_offset, 1);
    c.line_delay = list->Add(&s.line_delay, 1);
    c.params = list->Add(s.camera->mutable_params(), s.camera->NumParams());
    return discrete::MakeDiscreteCorner(s.camera->type(), cam->Measurement(i), Stamp(*cam, i), src,
                                        c, *list);
  }

  double Stamp(const PreparedCamera& cam, std::size_t i) const {
    return 1e-9 * static_cast<double>(cam.Stamp(i) - prep_.t0_ns);
  }

  // The corner's whitened residual at the current values, evaluated on its own (the statistics
  // and the outlier gate need it per corner, also where the problem holds frame blocks).
  bool EvaluateCorner(const PreparedCamera& cam, std::size_t i, const CornerSlot& slot,
                      Eigen::Vector2d* e) {
    BlockList list;
    const std::unique_ptr<ceres::CostFunction> cost(
        CornerCost(const_cast<PreparedCamera*>(&cam), i, slot, &list));
    return cost->Evaluate(list.blocks().data(), e->data(), nullptr) && e->allFinite();
  }

  // Whether the camera's corners enter as compressed per-frame blocks (frame_corners.h): a
  // global-shutter camera (line_delay 0 and not estimated), whose corners of one frame share the
  // pose; rolling shutter reads every corner at its own row time and keeps one block per corner.
  bool Compressed(const PreparedCamera& cam) const {
    const SensorState& s = *cam.state;
    return options_.compress_frames && !s.config.Estimates(EstimateItem::kLineDelay) &&
           s.line_delay == 0.0;
  }

  void AddCamera(PreparedCamera* cam, bool robust) {
    SensorState& s = *cam->state;
    std::vector<std::pair<std::size_t, CornerSlot>> in_problem;
    for (double* p : {s.q_B_S.data(), s.t_B_S.data(), &s.time_offset, &s.line_delay,
                      s.camera->mutable_params()})
      calib_ptrs_.insert(p);
    for (std::size_t i = 0; i < cam->corners.size(); ++i) {
      if (cam->removed[i])
        continue;
      const CornerSlot slot = SlotOf(CornerTime(*cam, i));
      slots_.push_back(slot);
      if (slot.k >= 0)
        in_problem.emplace_back(i, slot);
    }
    if (Compressed(*cam)) {
      AddCameraFrames(cam, in_problem, robust);
    } else {
      for (const auto& [i, slot] : in_problem) {
        BlockList list;
        ceres::CostFunction* cost = CornerCost(cam, i, slot, &list);
        ceres::LossFunction* loss =
            robust ? new ceres::HuberLoss(options_.huber_threshold) : nullptr;
        problem_->AddResidualBlock(cost, loss, list.blocks());
      }
    }
    corner_slots_.push_back(std::move(in_problem));
  }

  // One compressed block per frame (frame_corners.h): runs of `in_problem` with one stamp, which
  // share the slot (global shutter: one exposure time); the robust stage's Huber weights are
  // applied per corner inside the block.
  void AddCameraFrames(PreparedCamera* cam,
                       const std::vector<std::pair<std::size_t, CornerSlot>>& in_problem,
                       bool robust) {
    SensorState& s = *cam->state;
    std::size_t first = 0;
    while (first < in_problem.size()) {
      const std::size_t i0 = in_problem[first].first;
      const CornerSlot slot = in_problem[first].second;
      std::size_t last = first + 1;
      while (last < in_problem.size() &&
             cam->corners[in_problem[last].first].frame == cam->corners[i0].frame)
        ++last;
      std::vector<CornerMeasurement> corners;
      for (std::size_t j = first; j < last; ++j)
        corners.push_back(cam->Measurement(in_problem[j].first));
      BlockList list;
      const std::size_t k = static_cast<std::size_t>(slot.k);
      const BaseSource src = BaseSource::Add(&list, &kf_[k], slot.kinematic ? nullptr : &kf_[k + 1],
                                             &*state_.base().imu, state_.g_W());
      discrete::FramePoseIndex c;
      c.q_B_C = list.Add(s.q_B_S.data(), 4);
      c.t_B_C = list.Add(s.t_B_S.data(), 3);
      c.time_offset = list.Add(&s.time_offset, 1);
      list.Add(s.camera->mutable_params(), s.camera->NumParams());
      problem_->AddResidualBlock(
          discrete::MakeDiscreteFrameCorners(s.camera->type(), std::move(corners), Stamp(*cam, i0),
                                             src, c, list, robust ? options_.huber_threshold : 0.0),
          nullptr, list.blocks());
      first = last;
    }
  }

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

}  // namespace

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
  SplineCalibratorOptions so;
  so.threads = options.threads;
  so.max_iterations = options.max_iterations;
  so.huber_threshold = options.huber_threshold;
  so.outlier_probability = options.outlier_probability;
  so.min_corners_per_view = options.min_corners_per_view;
  so.min_views = options.min_views;
  so.compute_covariance = options.compute_covariance;
  so.stop_cost_change = options.stop_cost_change;

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
