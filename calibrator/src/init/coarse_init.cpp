#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <exception>
#include <limits>
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include "ctcal/calibrator/init/coarse_init.h"
#include "ctcal/calibrator/spline_calibrator.h"
#include "ctcal/sensors/parallel_for.h"
#include "ctcal/spline/so3.h"
#include "ctcal/targets/board.h"

namespace ctcal {

namespace {

std::int64_t Nanoseconds(double t_s) {
  return static_cast<std::int64_t>(std::llround(t_s * 1e9));
}

const char* PolicyName(GuessPolicy p) {
  switch (p) {
    case GuessPolicy::kOff:
      return "off";
    case GuessPolicy::kAlways:
      return "always";
    default:
      return "beyond-prior";
  }
}

// The run's shared state: the rig's sensors, the log, the policy and what was decided.
class CoarseInit {
 public:
  CoarseInit(CalibrationState* state, const std::map<std::string, SensorData>& data,
             const CoarseInitOptions& options, const InitLog& log, CoarseInitResult* result)
      : state_(*state),
        data_(data),
        options_(options),
        log_(log),
        result_(*result),
        board_(state->rig().target) {
    stage_log_ = [this](const std::string& line) {
      if (log_)
        log_("    " + line);
    };
  }

  void Run() {
    SensorState& base = state_.base();
    base_imu_ = CorrectedImu(base, DataOf(base).imu);
    if (base_imu_.size() < 2)
      throw InitError("data", base.name(), "the base IMU has no samples");
    base_rates_ = RatesFromImu(base_imu_);

    Log("  cameras: intrinsics and board poses");
    FitIntrinsicsSideBySide();
    for (auto& sp : state_.sensors())
      if (sp->config.type == SensorType::kCamera)
        InitCamera(*sp);
    if (cameras_.empty())
      throw InitError("board poses", state_.rig().base_imu,
                      "the rig has no camera: nothing anchors the trajectory");
    // The reference camera: the one with the most board views.
    reference_ = &*std::max_element(
        cameras_.begin(), cameras_.end(),
        [](const CameraViews& a, const CameraViews& b) { return a.views.size() < b.views.size(); });

    Log("  time offsets (rate correlation, +-" +
        FormatInitLine("%.0f ms around each guess)", options_.max_offset_s * 1e3));
    for (auto& sp : state_.sensors())
      if (!sp->is_base)
        InitOffset(*sp);

    Log("  rotations (hand-eye), camera-to-camera poses, lever arms");
    InitCameraExtrinsics();
    for (auto& sp : state_.sensors())
      if (!sp->is_base && sp->config.IsInertial())
        InitInertialExtrinsics(*sp);

    Log("  gravity");
    const GravityResult g =
        InitGravity(base.name(), base_imu_, reference_->state->name(), reference_->views,
                    reference_->state->R_B_S(), reference_->state->time_offset,
                    state_.rig().gravity_magnitude, options_.gravity, stage_log_);
    state_.SetGravity(g.g_W);
  }

 private:
  struct CameraViews {
    SensorState* state = nullptr;
    std::vector<BoardView> views;
    std::vector<RateSample> rates;
  };

  void Log(const std::string& line) const {
    if (log_)
      log_(line);
  }
  void Warn(const std::string& line) {
    result_.warnings.push_back(line);
    Log("    warning: " + line);
  }

  // Stage 1's intrinsics fit of every estimating camera, one camera per thread: each fit is
  // single-threaded (its solve, for the same bits on any thread count: camera_init.cpp) and
  // reads only its own camera's guess and corners, so the cameras can run side by side (EuRoC's
  // two: ~0.65 s each). Their log lines are held and written by InitCamera in the rig's order, as
  // before, and a fit's error is thrown there too, after the checks that precede it.
  struct PendingIntrinsics {
    std::optional<IntrinsicsInitResult> result;
    std::exception_ptr error;
    std::vector<std::string> lines;
  };

  void FitIntrinsicsSideBySide() {
    std::vector<const SensorState*> cameras;
    for (const auto& sp : state_.sensors()) {
      if (sp->config.type != SensorType::kCamera ||
          !sp->config.Estimates(EstimateItem::kIntrinsics) || sp->camera->mrcal_lens())
        continue;
      const auto it = data_.find(sp->name());
      if (it != data_.end() && it->second.has_corners && !it->second.corners.empty())
        cameras.push_back(sp.get());
    }
    if (cameras.size() < 2 || options_.threads < 2)
      return;  // InitCamera fits it in place
    std::vector<PendingIntrinsics> pending(cameras.size());
    ParallelFor(options_.threads, cameras.size(), [&](std::size_t i) {
      PendingIntrinsics& p = pending[i];
      const SensorState& s = *cameras[i];
      try {
        p.result.emplace(InitCameraIntrinsics(
            s.name(), *s.camera, board_, DataOf(s).corners, options_.intrinsics,
            [&p](const std::string& line) { p.lines.push_back("    " + line); }));
      } catch (...) {
        p.error = std::current_exception();
      }
    });
    for (std::size_t i = 0; i < cameras.size(); ++i)
      pending_intrinsics_[cameras[i]] = std::move(pending[i]);
  }

  IntrinsicsInitResult FitIntrinsics(const SensorState& s, const SensorData& d) {
    const auto it = pending_intrinsics_.find(&s);
    if (it == pending_intrinsics_.end())
      return InitCameraIntrinsics(s.name(), *s.camera, board_, d.corners, options_.intrinsics,
                                  stage_log_);
    PendingIntrinsics p = std::move(it->second);
    pending_intrinsics_.erase(it);
    for (const std::string& line : p.lines)
      Log(line);
    if (p.error)
      std::rethrow_exception(p.error);
    return std::move(*p.result);
  }

  const SensorData& DataOf(const SensorState& s) const {
    const auto it = data_.find(s.name());
    if (it == data_.end())
      throw CalibrationInputError("sensors." + s.name() + ": no data loaded");
    return it->second;
  }

  // The rates and specific forces of an inertial sensor through its guessed intrinsics (identity
  // for a drawing; close to the truth for a table4 guess), biases left in.
  static std::vector<ImuSample> CorrectedImu(const SensorState& s,
                                             const std::vector<ImuSample>& raw) {
    std::vector<ImuSample> out = raw;
    for (ImuSample& z : out)
      s.imu->TrueFromRaw(z.w_m, z.a_m, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), &z.w_m,
                         &z.a_m);
    return out;
  }

  std::vector<RateSample> InertialRates(const SensorState& s) const {
    const SensorData& d = DataOf(s);
    if (s.config.type == SensorType::kImu)
      return RatesFromImu(CorrectedImu(s, d.imu));
    std::vector<RateSample> rates = RatesFromGyro(d.gyro);
    for (RateSample& r : rates)
      r.w_S = s.gyro->TrueFromRaw(r.w_S, Eigen::Vector3d::Zero());
    return rates;
  }

  // The prior sigmas of `keys` (with their sizes) per tangent dimension, infinite where a key has
  // none; empty when no key has a prior.
  static std::vector<double> PriorSigmas(const SensorState& s,
                                         const std::vector<std::pair<std::string, int>>& keys) {
    std::vector<double> sigma;
    bool any = false;
    for (const auto& [key, size] : keys) {
      const std::vector<double>* p = s.config.prior_sigma.Find(key);
      any = any || p != nullptr;
      for (int i = 0; i < size; ++i)
        sigma.push_back(p != nullptr && i < static_cast<int>(p->size())
                            ? (*p)[static_cast<std::size_t>(i)]
                            : std::numeric_limits<double>::infinity());
    }
    return any ? sigma : std::vector<double>{};
  }

  // Whether the data's value replaces the guess (see GuessPolicy). `delta` is the data's value
  // minus the guess in the prior's tangent (the left perturbation for rotations), `sigma` the
  // guess's prior per dimension (PriorSigmas).
  bool Replace(const SensorState& s, const std::string& what, const Eigen::VectorXd& delta,
               const std::vector<double>& sigma) {
    if (options_.policy == GuessPolicy::kAlways || sigma.empty())
      return Replaced(s, what);
    double worst = 0.0;
    for (Eigen::Index i = 0; i < delta.size() && i < static_cast<Eigen::Index>(sigma.size()); ++i)
      worst = std::max(worst, std::abs(delta[i]) / sigma[static_cast<std::size_t>(i)]);
    if (worst <= options_.prior_gate) {
      Log(FormatInitLine("    %s.%s: guess kept (the data agree within %.1f of its prior sigmas)",
                         s.name().c_str(), what.c_str(), worst));
      return false;
    }
    Warn(
        FormatInitLine("%s.%s: the data disagree with the guess by %.1f prior sigmas (gate %.1f): "
                       "started from the data's value, the prior stays on the guess",
                       s.name().c_str(), what.c_str(), worst, options_.prior_gate));
    return Replaced(s, what);
  }
  bool Replaced(const SensorState& s, const std::string& what) {
    result_.replaced.push_back(s.name() + "." + what);
    return true;
  }
  // A prior'd guess survives a stage that cannot determine its quantity (kBeyondPrior).
  bool HasPrior(const SensorState& s, const char* key) const {
    return options_.policy == GuessPolicy::kBeyondPrior &&
           s.config.prior_sigma.Find(key) != nullptr;
  }

  // Stage 1 (and 2a): intrinsics of an estimating camera, then its board poses.
  void InitCamera(SensorState& s) {
    const SensorData& d = DataOf(s);
    if (!d.has_corners)
      throw CalibrationInputError("sensors." + s.name() +
                                  ": no corners.csv (run `ctcal detect` on its images first)");
    if (d.corners.empty())
      throw InitError(
          "board poses", s.name(),
          "the camera never sees the board (sensors." + s.name() + ": corners.csv has no corners)");
    // Count the usable frames first: the stages below need min_views of them.
    std::map<std::int64_t, int> per_frame;
    for (const CornerObservation& c : d.corners)
      ++per_frame[c.t_ns];
    int frames = 0;
    for (const auto& [stamp, n] : per_frame)
      frames += n >= options_.min_corners ? 1 : 0;
    const auto too_few = [&](int views) {
      return InitError(
          "board poses", s.name(),
          FormatInitLine("too few views of the board: sensors.%s has %d frames with a board "
                         "pose from >= %d corners, need %d",
                         s.name().c_str(), views, options_.min_corners, options_.min_views));
    };
    if (frames < options_.min_views)
      throw too_few(frames);
    // The intrinsics stage fits SPEC section 4's models only: an mrcal lens keeps its guess.
    if (s.config.Estimates(EstimateItem::kIntrinsics) && s.camera->mrcal_lens()) {
      Log("    " + s.name() + ".intrinsics: mrcal " + s.camera->distortion_model() +
          ", guess kept");
    } else if (s.config.Estimates(EstimateItem::kIntrinsics)) {
      std::optional<IntrinsicsInitResult> r;
      try {
        r.emplace(FitIntrinsics(s, d));
      } catch (const InitError& e) {
        if (!HasPrior(s, "intrinsics"))
          throw;
        Warn(std::string(e.what()) + "; the prior'd guess is kept");
      }
      // Distortion terms the views hardly determine (a wide lens' outer field) can differ from a
      // good guess by many prior sigmas without the guess being wrong, so a prior'd guess is
      // judged in the image: kept while it reprojects (with its own PnP poses) nearly as well as
      // the refined model.
      if (r && options_.policy == GuessPolicy::kBeyondPrior &&
          (HasPrior(s, "intrinsics") || HasPrior(s, "distortion_coeffs"))) {
        if (r->rms_px_guess <= options_.guess_rms_ratio * r->rms_px) {
          Log(FormatInitLine(
              "    %s.intrinsics: guess kept (RMS %.3f px, the data's model %.3f px)",
              s.name().c_str(), r->rms_px_guess, r->rms_px));
        } else {
          Warn(FormatInitLine(
              "%s.intrinsics: the guess reprojects at %.3f px RMS, the data's model at "
              "%.3f px: started from the data's model, the prior stays on the guess",
              s.name().c_str(), r->rms_px_guess, r->rms_px));
          Replaced(s, "intrinsics");
          s.camera->SetParams(r->camera.params());
        }
      } else if (r) {
        Replaced(s, "intrinsics");
        s.camera->SetParams(r->camera.params());
      }
    }
    CoarseInitResult::CameraViews& handed = result_.board_views[s.name()];
    handed.params = s.camera->params();
    handed.min_corners = std::min(options_.min_corners, options_.views_min_corners);
    handed.views = InitBoardPoses(s.name(), *s.camera, board_, d.corners, handed.min_corners, 0,
                                  stage_log_, options_.threads)
                       .views;
    CameraViews cam;
    cam.state = &s;
    for (const BoardView& v : handed.views) {
      if (v.inliers >= options_.min_corners)
        cam.views.push_back(v);
    }
    if (static_cast<int>(cam.views.size()) < options_.min_views)
      throw too_few(static_cast<int>(cam.views.size()));
    cam.rates = RatesFromBoardViews(cam.views);
    cameras_.push_back(std::move(cam));
  }

  const CameraViews* CameraOf(const SensorState& s) const {
    for (const CameraViews& c : cameras_)
      if (c.state == &s)
        return &c;
    return nullptr;
  }

  std::vector<RateSample> RatesOf(const SensorState& s) const {
    if (s.config.IsInertial())
      return InertialRates(s);
    const CameraViews* c = CameraOf(s);
    return c != nullptr ? c->rates : std::vector<RateSample>{};
  }

  // Stage 3: the time offset, searched around the guess.
  void InitOffset(SensorState& s) {
    if (!s.config.Estimates(EstimateItem::kTimeOffset))
      return;
    const std::vector<RateSample> rates = RatesOf(s);
    const double guess = s.time_offset;
    const double prior3 = [&] {
      const std::vector<double>* p = s.config.prior_sigma.Find("time_offset");
      return p != nullptr && !p->empty() ? 3.0 * p->front() : options_.max_offset_s;
    }();
    // Overlap with the base at the guess, widened by the search range.
    if (!rates.empty()) {
      const double lo = InitSeconds(rates.front().t_ns) + guess,
                   hi = InitSeconds(rates.back().t_ns) + guess;
      const double b_lo = InitSeconds(base_rates_.front().t_ns),
                   b_hi = InitSeconds(base_rates_.back().t_ns);
      if (std::min(hi, b_hi) - std::max(lo, b_lo) < 1.0 - 2.0 * options_.max_offset_s)
        throw InitError(
            "time offset", s.name(),
            FormatInitLine("sensor time ranges do not overlap: sensors.%s [%.3f, %.3f] s on "
                           "the base clock at time_offset %.3f s, base %s [%.3f, %.3f] s",
                           s.name().c_str(), lo, hi, guess, state_.base().name().c_str(), b_lo,
                           b_hi));
    }
    TimeOffsetOptions to;
    to.max_offset = options_.max_offset_s;
    to.threads = options_.threads;
    // The stage searches lags around 0: stamp the rates at the guessed base time.
    const auto search = [&](const std::vector<RateSample>& sensor_rates) {
      std::vector<RateSample> shifted = sensor_rates;
      for (RateSample& r : shifted)
        r.t_ns += Nanoseconds(guess);
      return InitTimeOffset(s.name(), base_rates_, shifted, to, stage_log_);
    };
    TimeOffsetResult r;
    try {
      try {
        r = search(rates);
      } catch (const InitError& e) {
        // Noisy corners (pixel_sigma 1.5 px on a 215 px fisheye: rate noise ~0.1 rad/s between
        // views 50 ms apart) drown a camera's rate; over 2 and 4 frame periods the same pose noise
        // weighs 2 and 4 times less, and the base rate is integrated over the same span.
        const CameraViews* cam = CameraOf(s);
        if (cam == nullptr)
          throw;
        Log(FormatInitLine("    %s: %s; again with rates over 2, then 4 frame periods",
                           s.name().c_str(), e.what()));
        for (int stride = 2;; stride *= 2) {
          try {
            r = search(RatesFromBoardViews(cam->views, stride));
            break;
          } catch (const InitError&) {
            if (stride >= 4)
              throw;
          }
        }
      }
    } catch (const InitError& e) {
      if (!HasPrior(s, "time_offset"))
        throw;
      Warn(std::string(e.what()) + "; the prior'd guess is kept");
      result_.offset_uncertainty_s[s.name()] = prior3;
      return;
    }
    const double found = guess + r.time_offset;
    Log(FormatInitLine("    %s: time offset %+.3f ms on the base clock (guess %+.3f ms)",
                       s.name().c_str(), found * 1e3, guess * 1e3));
    Eigen::VectorXd delta(1);
    delta[0] = r.time_offset;
    if (Replace(s, "time_offset", delta, PriorSigmas(s, {{"time_offset", 1}})))
      s.time_offset = found;
    // The full problem moves the offset from its start to about where the data put it.
    result_.offset_uncertainty_s[s.name()] =
        std::abs(s.time_offset - found) + options_.offset_accuracy_s;
  }

  // R_B_S (and t_B_S) of a sensor from a finding, per the policy.
  void SetExtrinsics(SensorState& s, const Eigen::Matrix3d& R_B_S,
                     const std::optional<Eigen::Vector3d>& t_B_S) {
    const Eigen::Vector3d dtheta =
        LogSO3<double>(Eigen::Quaterniond(R_B_S * s.R_B_S().transpose()).normalized());
    if (Replace(s, "R_B_S", dtheta, PriorSigmas(s, {{"R_B_S", 3}}))) {
      const Eigen::Quaterniond q = Eigen::Quaterniond(R_B_S).normalized();
      s.q_B_S = {q.x(), q.y(), q.z(), q.w()};
    }
    if (t_B_S && Replace(s, "t_B_S", *t_B_S - s.p_B_S(), PriorSigmas(s, {{"t_B_S", 3}})))
      for (int i = 0; i < 3; ++i)
        s.t_B_S[static_cast<std::size_t>(i)] = (*t_B_S)[i];
  }

  // Stage 4 for cameras: the reference camera by hand-eye (also the base gyro bias: a camera
  // rate has none), every other camera through its pose relative to the reference, by hand-eye
  // where they share too few views.
  void InitCameraExtrinsics() {
    SensorState& ref = *reference_->state;
    const HandEyeResult he = HandEye(ref, reference_->rates);
    if (he.pairs > 0) {
      const Eigen::Vector3d c = he.c_B;  // = b_B for a camera (true units of the base gyro)
      Eigen::Vector3d w_m, a_m;
      state_.base().imu->RawFromTrue(c, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(),
                                     Eigen::Vector3d::Zero(), &w_m, &a_m);
      result_.gyro_bias[state_.base().name()] = w_m;
      base_bias_true_ = c;
      if (ref.config.Estimates(EstimateItem::kExtrinsics))
        SetExtrinsics(ref, he.R_B_S, std::nullopt);
    }
    for (CameraViews& cam : cameras_) {
      SensorState& s = *cam.state;
      if (&cam == reference_ || !s.config.Estimates(EstimateItem::kExtrinsics))
        continue;
      try {
        const RelativePoseResult rel =
            InitCameraRelativePose(ref.name(), reference_->views, ref.time_offset, s.name(),
                                   cam.views, s.time_offset, stage_log_);
        const Eigen::Isometry3d T_B_S = ref.T_B_S() * rel.T_Ci_Cj;
        SetExtrinsics(s, T_B_S.linear(), Eigen::Vector3d(T_B_S.translation()));
        continue;
      } catch (const InitError& e) {
        Log(std::string("    ") + e.what() + ": " + s.name() + " by hand-eye alone");
      }
      const HandEyeResult r = HandEye(s, cam.rates);
      if (r.pairs > 0)
        SetExtrinsics(s, r.R_B_S, std::nullopt);
    }
  }

  // The hand-eye stage, or an empty result (pairs 0) where it cannot run on a prior'd guess.
  HandEyeResult HandEye(SensorState& s, const std::vector<RateSample>& rates) {
    try {
      return InitRotationHandEye(s.name(), base_rates_, rates, s.time_offset, options_.hand_eye,
                                 stage_log_);
    } catch (const InitError& e) {
      if (s.config.Estimates(EstimateItem::kExtrinsics) && !HasPrior(s, "R_B_S"))
        throw;
      Warn(std::string(e.what()) + "; the guess of R_B_S is kept");
      return HandEyeResult{};
    }
  }

  // Stages 4 and 5 for an auxiliary IMU or gyro: hand-eye rotation, the gyro bias, the lever arm.
  void InitInertialExtrinsics(SensorState& s) {
    const HandEyeResult he = HandEye(s, InertialRates(s));
    if (he.pairs > 0 && base_bias_true_) {
      // c = b_B - R_B_S b_S (true units) -> b_S, then into the sensor's raw units.
      const Eigen::Vector3d b_S = he.R_B_S.transpose() * (*base_bias_true_ - he.c_B);
      Eigen::Vector3d w_m = b_S, a_m;
      if (s.imu)
        s.imu->RawFromTrue(b_S, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(),
                           Eigen::Vector3d::Zero(), &w_m, &a_m);
      else
        w_m = s.gyro->RawFromTrue(b_S, Eigen::Vector3d::Zero());
      result_.gyro_bias[s.name()] = w_m;
    }
    if (!s.config.Estimates(EstimateItem::kExtrinsics) || he.pairs == 0)
      return;
    std::optional<Eigen::Vector3d> t_B_S;
    if (s.config.type == SensorType::kImu) {
      try {
        t_B_S = InitLeverArm(s.name(), base_imu_, CorrectedImu(s, DataOf(s).imu), he.R_B_S,
                             s.time_offset, options_.lever_arm, stage_log_)
                    .t_B_S;
      } catch (const InitError& e) {
        if (!HasPrior(s, "t_B_S"))
          throw;
        Warn(std::string(e.what()) + "; the guess of t_B_S is kept");
      }
    }
    SetExtrinsics(s, he.R_B_S, t_B_S);
  }

  CalibrationState& state_;
  const std::map<std::string, SensorData>& data_;
  const CoarseInitOptions& options_;
  InitLog log_;
  InitLog stage_log_;
  CoarseInitResult& result_;
  Board board_;
  std::vector<ImuSample> base_imu_;
  std::vector<RateSample> base_rates_;
  std::vector<CameraViews> cameras_;
  CameraViews* reference_ = nullptr;
  std::optional<Eigen::Vector3d> base_bias_true_;
  std::map<const SensorState*, PendingIntrinsics> pending_intrinsics_;
};

}  // namespace

double CoarseInitResult::OffsetUncertainty(const std::string& sensor) const {
  const auto it = offset_uncertainty_s.find(sensor);
  return it == offset_uncertainty_s.end() ? 0.0 : it->second;
}

CoarseInitResult InitializeFromData(CalibrationState* state,
                                    const std::map<std::string, SensorData>& data,
                                    const CoarseInitOptions& options, const InitLog& log) {
  CoarseInitResult result;
  if (options.policy == GuessPolicy::kOff) {
    // The guesses go in as they are: their offsets may move by 3 prior sigmas.
    for (const auto& sp : state->sensors()) {
      const std::vector<double>* p = sp->config.prior_sigma.Find("time_offset");
      if (!sp->is_base && sp->config.Estimates(EstimateItem::kTimeOffset) && p != nullptr &&
          !p->empty())
        result.offset_uncertainty_s[sp->name()] = 3.0 * p->front();
    }
    return result;
  }
  const auto t_start = std::chrono::steady_clock::now();
  const std::clock_t cpu_start = std::clock();
  if (log)
    log(std::string("[init] coarse-guess initialisation (policy ") + PolicyName(options.policy) +
        ")");
  try {
    CoarseInit(state, data, options, log, &result).Run();
  } catch (const InitError& e) {
    throw CalibrationInputError(e.what());
  }
  result.ran = true;
  result.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  if (log) {
    std::string replaced;
    for (const std::string& r : result.replaced)
      replaced += " " + r;
    log(FormatInitLine(
            "  initialisation done in %.2f s (CPU %.2f s); taken from the data:", result.seconds,
            static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC) +
        (replaced.empty() ? std::string(" nothing (every guess agrees with its prior)")
                          : replaced));
  }
  return result;
}

void SeedBiasSplines(const CoarseInitResult& init, CalibrationState* state) {
  for (auto& sp : state->sensors()) {
    const auto it = init.gyro_bias.find(sp->name());
    if (it == init.gyro_bias.end())
      continue;
    for (int k = 0; k < sp->bias_gyro.NumKnots(); ++k)
      Eigen::Map<Eigen::Vector3d>(sp->bias_gyro.Knot(k)) = it->second;
  }
}

}  // namespace ctcal
