// The discrete problem's keyframes (discrete_problem.h): their times, their initial states from
// the initial trajectory spline, and their re-choice when the time offsets move them.
#include "discrete_problem.h"

namespace ctcal {
namespace discrete_internal {

void DiscreteProblem::Initialize(SplineCalibrationResult* out) {
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

double DiscreteProblem::KeyframeDrift() const {
  double drift = 0.0;
  std::size_t i = 0;
  for (const PreparedCamera& cam : prep_.cameras)
    drift = std::max(drift, std::abs(cam.state->time_offset - offsets_at_keyframes_[i++]));
  for (const AuxStates& a : aux_)
    drift = std::max(drift, std::abs(a.in->state->time_offset - offsets_at_keyframes_[i++]));
  return drift;
}

std::string DiscreteProblem::MaybeRechoose() {
  const double drift = KeyframeDrift();
  if (drift <= options_.rechoose_keyframes_fraction * options_.kinematic_window_s)
    return {};
  RechooseKeyframes();
  ++rechoices_;
  return Fmt("keyframes re-chosen: offsets moved %.2f ms", 1e3 * drift);
}

void DiscreteProblem::RechooseKeyframes() {
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

void DiscreteProblem::CommonRange(double* lo, double* hi) const {
  *lo = base_samples_.front().t;
  *hi = base_samples_.back().t;
  for (const AuxStates& a : aux_) {
    *lo = std::max(*lo, a.samples.front().t + a.in->state->time_offset);
    *hi = std::min(*hi, a.samples.back().t + a.in->state->time_offset);
  }
  *lo += 0.03;
  *hi -= 0.03;
}

void DiscreteProblem::ChooseKeyframes() {
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
        const double t = 1e-9 * static_cast<double>(v.t_ns - prep_.t0_ns) + cam.state->time_offset;
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

double DiscreteProblem::MergeSpacing() const {
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

}  // namespace discrete_internal
}  // namespace ctcal
