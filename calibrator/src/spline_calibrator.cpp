#include "ctcal/calibrator/spline_calibrator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <limits>
#include <optional>
#include <sstream>
#include <thread>

#include "ctcal/calibrator/init/coarse_init.h"
#include "ctcal/calibrator/knot_fit.h"
#include "ctcal/calibrator/knot_spacing.h"
#include "ctcal/calibrator/marginal_covariance.h"
#include "ctcal/calibrator/memory_usage.h"
#include "ctcal/calibrator/observability/motion_prediction.h"
#include "ctcal/calibrator/observability/numeric_observability.h"
#include "problem/spline_problem_impl.h"

namespace ctcal {

namespace spline_internal {
// Instantiated in spline_problem_split.cpp / spline_problem_joint.cpp.
#define CTCAL_DECLARE_PIPELINE(N, REP)                         \
  extern template void RunPipeline<N, Se3Representation::REP>( \
      Prepared*, const SplineCalibratorOptions&, const CalibrationLog&, SplineCalibrationResult*);
CTCAL_DECLARE_PIPELINE(4, kSplit)
CTCAL_DECLARE_PIPELINE(5, kSplit)
CTCAL_DECLARE_PIPELINE(6, kSplit)
CTCAL_DECLARE_PIPELINE(4, kJoint)
CTCAL_DECLARE_PIPELINE(5, kJoint)
CTCAL_DECLARE_PIPELINE(6, kJoint)
#undef CTCAL_DECLARE_PIPELINE
}  // namespace spline_internal

namespace {

using spline_internal::Prepared;
using spline_internal::PreparedCamera;
using spline_internal::PreparedInertial;

std::string Seconds(std::int64_t t_ns) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3f", 1e-9 * static_cast<double>(t_ns));
  return b;
}

std::string Fmt(const char* format, double a, double b = 0.0, double c = 0.0) {
  char line[256];
  std::snprintf(line, sizeof line, format, a, b, c);
  return line;
}

}  // namespace

namespace spline_internal {

void Prepare(CalibrationState* state, const std::map<std::string, SensorData>& data,
             const SplineCalibratorOptions& options, const CoarseInitResult& init,
             const CalibrationLog& log, Prepared* prep) {
  prep->state = state;
  const RigConfig& rig = state->rig();
  const Board board(rig.target);
  const auto data_of = [&](const std::string& name) -> const SensorData& {
    const auto it = data.find(name);
    if (it == data.end())
      throw CalibrationInputError("sensors." + name + ": no data loaded");
    return it->second;
  };

  // Board views and base poses of every camera.
  std::int64_t cam_lo = std::numeric_limits<std::int64_t>::max();
  std::int64_t cam_hi = std::numeric_limits<std::int64_t>::min();
  for (auto& sp : state->sensors()) {
    SensorState& s = *sp;
    if (s.config.type != SensorType::kCamera)
      continue;
    const SensorData& d = data_of(s.name());
    if (!d.has_corners)
      throw CalibrationInputError("sensors." + s.name() +
                                  ": no corners.csv (run `ctcal detect` on its images first)");
    if (d.corners.empty())
      throw CalibrationInputError("sensors." + s.name() + ": the camera never sees the board");
    PreparedCamera cam;
    cam.state = &s;
    // The initialisation's views when it solved them with this camera and threshold.
    const auto handed = init.board_views.find(s.name());
    if (handed != init.board_views.end() &&
        handed->second.min_corners == options.min_corners_per_view &&
        handed->second.params.size() == s.camera->params().size() &&
        handed->second.params == s.camera->params())
      cam.views = handed->second.views;
    else
      cam.views = EstimateBoardViews(*s.camera, board, d.corners, options.min_corners_per_view,
                                     options.threads);
    if (static_cast<int>(cam.views.size()) < options.min_views)
      throw CalibrationInputError(
          "sensors." + s.name() + ": too few views of the board (" +
          std::to_string(cam.views.size()) +
          " frames with a board pose from >= " + std::to_string(options.min_corners_per_view) +
          " corners, need " + std::to_string(options.min_views) + ")");
    const std::vector<TimedPose> poses = BasePosesFromViews(cam.views, s.T_B_S(), s.time_offset);
    prep->base_poses.insert(prep->base_poses.end(), poses.begin(), poses.end());
    cam_lo = std::min(cam_lo, poses.front().t_ns);
    cam_hi = std::max(cam_hi, poses.back().t_ns);
    prep->cameras.push_back(std::move(cam));
    log("  " + s.name() + ": " + std::to_string(prep->cameras.back().views.size()) +
        " board views from " + std::to_string(d.corners.size()) + " corners");
  }
  if (prep->cameras.empty())
    throw CalibrationInputError("the rig has no camera: nothing anchors the trajectory");
  std::sort(prep->base_poses.begin(), prep->base_poses.end(),
            [](const TimedPose& a, const TimedPose& b) { return a.t_ns < b.t_ns; });

  // The trajectory spans the base IMU and the camera views together.
  SensorState& base = state->base();
  const SensorData& base_data = data_of(base.name());
  if (base_data.imu.size() < 2)
    throw CalibrationInputError("sensors." + base.name() + ": no IMU samples");
  prep->t0_ns = std::max(base_data.imu.front().t_ns, cam_lo);
  prep->t1_ns = std::min(base_data.imu.back().t_ns, cam_hi);
  if (prep->t1_ns - prep->t0_ns < 1000000000LL)
    throw CalibrationInputError("sensor time ranges do not overlap: " + base.name() + " [" +
                                Seconds(base_data.imu.front().t_ns) + ", " +
                                Seconds(base_data.imu.back().t_ns) + "] s, camera views [" +
                                Seconds(cam_lo) + ", " + Seconds(cam_hi) +
                                "] s (base clock); need >= 1 s in common");

  // Knot spacing from the motion's bandwidth, measured on the base IMU.
  if (options.knot_spacing_s > 0.0) {
    prep->knot_spacing_s = options.knot_spacing_s;
  } else {
    std::vector<std::int64_t> t;
    std::vector<Eigen::Vector3d> w, a;
    for (const ImuSample& z : base_data.imu) {
      if (z.t_ns < prep->t0_ns || z.t_ns > prep->t1_ns)
        continue;
      t.push_back(z.t_ns);
      w.push_back(z.w_m);
      a.push_back(z.a_m);
    }
    const InertialNoise& n = base.config.noise;
    const MotionBandwidth bw =
        ChooseKnotSpacing(t, w, a, n.GyroSampleSigma(), n.AccelSampleSigma());
    log(Fmt("  motion bandwidth: gyro %.2f Hz, accel %.2f Hz (the bandwidth rule: %.4f s)",
            bw.gyro_hz, bw.accel_hz, bw.knot_spacing_s));
    prep->knot_spacing_s = bw.knot_spacing_s;
    // The spacing itself from how well splines of each spacing fit the base IMU's signals per
    // window (knot_fit.h): the bandwidth rule's spacing, with the stated noise as its floor, left
    // the IMU residuals of a real recording 32 % redundancy (docs/noise_estimation.md).
    if (options.knot_spacing_by_fit) {
      KnotFitOptions fit_options;
      fit_options.order = options.order;
      const KnotFitChoice fit = ChooseKnotSpacingByFit(t, w, a, fit_options);
      prep->knot_spacing_s = fit.knot_spacing_s;
      std::string ladder;
      for (const KnotFitCandidate& c : fit.candidates) {
        ladder += Fmt(" %.4f:%.2f", c.spacing_s, c.share_excess);
        if (c.share_excess > fit_options.misfit_tolerance)
          break;
      }
      log("  knot spacing by fit (spacing s: excess variance of the " +
          Fmt("%.0f %% best-fitted 2 s windows of the base IMU, allowed %.2f):",
              100.0 * fit_options.window_share, fit_options.misfit_tolerance) +
          ladder + Fmt(" -> %.4f s", fit.knot_spacing_s));
    }
  }

  // Samples whose base time lies inside the trajectory, kept 10 ms plus the sensor's remaining
  // time-offset uncertainty (coarse_init.h) away from its ends: the offsets still move in the
  // solve, and a sample moved past an end would extrapolate the end segment.
  const auto margin_ns = [&](const SensorState& s) {
    return 10000000LL +
           static_cast<std::int64_t>(std::llround(init.OffsetUncertainty(s.name()) * 1e9));
  };
  const auto inside = [&](std::int64_t t_ns, double offset, std::int64_t margin) {
    const std::int64_t tb = t_ns + static_cast<std::int64_t>(std::llround(offset * 1e9));
    return tb >= prep->t0_ns + margin && tb <= prep->t1_ns - margin;
  };
  const auto log_dropped = [&](const SensorState& s, std::size_t dropped, std::size_t total,
                               std::int64_t margin) {
    if (dropped > 0)
      log("  " + s.name() + ": " + std::to_string(dropped) + " of " + std::to_string(total) +
          " samples outside the trajectory at time offset " +
          Fmt("%.4f s (margin %.1f ms) dropped", s.is_base ? 0.0 : s.time_offset,
              1e-6 * static_cast<double>(margin)));
  };
  for (PreparedCamera& cam : prep->cameras) {
    SensorState& s = *cam.state;
    const SensorData& d = data_of(s.name());
    const std::int64_t margin = margin_ns(s);
    std::size_t v = 0, dropped = 0;
    // Nearly every corner is kept: reserve once instead of growing to up to twice the size.
    cam.corners.reserve(d.corners.size());
    cam.frame_stamps.reserve(cam.views.size());
    cam.board_W.assign(board.Corners().begin(), board.Corners().end());
    for (const CornerObservation& c : d.corners) {
      while (v < cam.views.size() && cam.views[v].t_ns < c.t_ns)
        ++v;
      if (v == cam.views.size() || cam.views[v].t_ns != c.t_ns)
        continue;
      if (!inside(c.t_ns, s.time_offset, margin)) {
        ++dropped;
        continue;
      }
      // Only corners that project validly at the guess enter (the residual fails elsewhere).
      const Eigen::Vector3d p_C = cam.views[v].T_C_W * board.Corner(c.corner_id);
      Eigen::Vector2d uv;
      if (!s.camera->Project(p_C, &uv)) {
        ++cam.invalid;
        continue;
      }
      if (cam.frame_stamps.empty() || cam.frame_stamps.back() != c.t_ns)
        cam.frame_stamps.push_back(c.t_ns);
      HeldCorner m;
      m.uv = Eigen::Vector2d(c.u, c.v);
      m.sigma_px = c.sigma.value_or(s.config.pixel_sigma);
      m.corner_id = c.corner_id;
      m.frame = static_cast<std::int32_t>(cam.frame_stamps.size() - 1);
      cam.corners.push_back(m);
    }
    log_dropped(s, dropped, d.corners.size(), margin);
    cam.removed.assign(cam.corners.size(), false);
  }

  // Inertial sensors (the base first) and their bias splines on their own clocks.
  const auto add_inertial = [&](SensorState& s) {
    const SensorData& d = data_of(s.name());
    PreparedInertial in;
    in.state = &s;
    const double offset = s.is_base ? 0.0 : s.time_offset;
    const std::int64_t margin = margin_ns(s);
    std::int64_t first = 0, last = 0, own_lo = 0, own_hi = 0;
    if (s.config.type == SensorType::kImu) {
      if (!d.imu.empty()) {
        own_lo = d.imu.front().t_ns;
        own_hi = d.imu.back().t_ns;
      }
      in.imu.reserve(d.imu.size());
      for (const ImuSample& z : d.imu) {
        if (inside(z.t_ns, offset, margin))
          in.imu.push_back(z);
      }
      if (!in.imu.empty()) {
        first = in.imu.front().t_ns;
        last = in.imu.back().t_ns;
      }
    } else {
      if (!d.gyro.empty()) {
        own_lo = d.gyro.front().t_ns;
        own_hi = d.gyro.back().t_ns;
      }
      in.gyro.reserve(d.gyro.size());
      for (const GyroSample& z : d.gyro) {
        if (inside(z.t_ns, offset, margin))
          in.gyro.push_back(z);
      }
      if (!in.gyro.empty()) {
        first = in.gyro.front().t_ns;
        last = in.gyro.back().t_ns;
      }
    }
    const std::size_t n = in.imu.size() + in.gyro.size();
    if (!s.is_base)
      log_dropped(s, d.imu.size() + d.gyro.size() - n, d.imu.size() + d.gyro.size(), margin);
    if (n < 100 || last - first < 1000000000LL)
      throw CalibrationInputError(
          "sensor time ranges do not overlap: sensors." + s.name() + " [" + Seconds(own_lo) + ", " +
          Seconds(own_hi) + "] s on its clock (time_offset " + Fmt("%.6f", offset) +
          " s) vs the trajectory [" + Seconds(prep->t0_ns) + ", " + Seconds(prep->t1_ns) +
          "] s: " + std::to_string(n) + " samples in common");
    const std::int64_t dt_b =
        static_cast<std::int64_t>(std::llround(options.bias_knot_spacing_s * 1e9));
    const int knots = static_cast<int>((last - first + dt_b - 1) / dt_b) + 1;
    s.bias_gyro.timing = KnotTiming{first, dt_b};
    s.bias_gyro.knots.assign(3 * static_cast<std::size_t>(std::max(knots, 2)), 0.0);
    if (s.config.type == SensorType::kImu) {
      s.bias_accel.timing = s.bias_gyro.timing;
      s.bias_accel.knots = s.bias_gyro.knots;
    }
    prep->inertial.push_back(std::move(in));
  };
  add_inertial(base);
  for (auto& sp : state->sensors()) {
    if (!sp->is_base && sp->config.IsInertial())
      add_inertial(*sp);
  }
}

}  // namespace spline_internal

namespace {

// sigma of gravity_W (m/s^2, per component) from the 2x2 covariance of its sphere tangent.
Eigen::Vector3d GravitySigma(const double* g, const Eigen::Matrix2d& cov_tangent) {
  ceres::SphereManifold<3> sphere;
  Eigen::Matrix<double, 3, 2, Eigen::RowMajor> J;
  sphere.PlusJacobian(g, J.data());
  const Eigen::Matrix3d cov = J * cov_tangent * J.transpose();
  return cov.diagonal().cwiseMax(0.0).cwiseSqrt();
}

}  // namespace

namespace spline_internal {

void LogOutliers(const std::vector<CameraOutliers>& outliers, double outlier_probability,
                 const CalibrationLog& log) {
  for (const CameraOutliers& o : outliers) {
    char line[200];
    std::snprintf(line, sizeof line,
                  "  %s: %d views, %d corners, %d outliers removed (chi-square %.1f %% gate), %d "
                  "not projectable at the guess",
                  o.camera.c_str(), o.views, o.corners, o.removed, 100.0 * outlier_probability,
                  o.invalid);
    log(line);
  }
}

ceres::Solver::Options SolverOptions(const SplineCalibratorOptions& options,
                                     ceres::IterationCallback* callback) {
  ceres::Solver::Options so;
  so.minimizer_type = ceres::TRUST_REGION;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  so.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  so.num_threads = options.threads;
  so.max_num_iterations = options.max_iterations;
  // A cost change of 0.5 moves an estimate by one sigma: converge far below that.
  so.function_tolerance = 1e-10;
  so.parameter_tolerance = 1e-10;
  so.gradient_tolerance = 1e-12;
  so.logging_type = ceres::SILENT;
  if (callback != nullptr)
    so.callbacks.push_back(callback);
  return so;
}

std::vector<ceres::ResidualBlockId> AddCalibrationPriors(
    ceres::Problem* problem, const std::vector<ParameterBlockInfo>& blocks,
    const std::vector<std::vector<double>>& centers, bool analytic) {
  std::vector<ceres::ResidualBlockId> ids;
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    const ParameterBlockInfo& b = blocks[i];
    if (!b.estimated || b.prior_sigma.empty())
      continue;
    const std::vector<double>& c = centers[i];
    const Eigen::VectorXd sigma =
        Eigen::Map<const Eigen::VectorXd>(b.prior_sigma.data(), b.tangent_size);
    ceres::CostFunction* cost = nullptr;
    if (b.left_rotation) {
      cost = MakeRotationPrior(analytic, Eigen::Quaterniond(c[3], c[0], c[1], c[2]),
                               Eigen::Vector3d(sigma));
    } else {
      cost = MakeVectorPrior(analytic, Eigen::Map<const Eigen::VectorXd>(c.data(), b.ambient_size),
                             sigma);
    }
    ids.push_back(problem->AddResidualBlock(cost, nullptr, b.values));
  }
  return ids;
}

void FinishResult(ceres::Problem& problem, CalibrationState& state,
                  const std::vector<ceres::ResidualBlockId>& prior_ids,
                  const std::vector<CornerResiduals>& corners,
                  const std::vector<InertialResidualSums>& inertial,
                  const SplineCalibratorOptions& options, const CalibrationLog& log,
                  SplineCalibrationResult* out, const SolvedInformation* solved) {
  RigConfig& result = out->result;
  const std::optional<SolverSummary> solver = result.solver;
  result = state.ToRig();
  result.solver = solver;

  // --- residual statistics ---
  // Corners one by one (the problem may hold them compressed per frame).
  for (const CornerResiduals& c : corners) {
    SensorResiduals r;
    double raw = 0.0, white = 0.0;
    for (std::size_t i = 0; i < c.whitened.size(); ++i) {
      const double sq = c.whitened[i].squaredNorm();
      white += sq;
      raw += sq * c.sigma_px[i] * c.sigma_px[i];
    }
    r.count = static_cast<std::int64_t>(2 * c.whitened.size());
    const double n = std::max<double>(1.0, static_cast<double>(r.count));
    r.rms_whitened = std::sqrt(white / n);
    r.rms_px = std::sqrt(raw / n);
    result.residuals[c.camera] = r;
  }
  for (const InertialResidualSums& in : inertial) {
    const std::string& name = in.sensor;
    SensorResiduals r;
    const SensorState* s = state.Find(name);
    const InertialNoise& noise = s->config.noise;
    const bool imu = s->config.type == SensorType::kImu;
    const int m = imu ? 6 : 3;
    const double wg = in.gyro, wa = in.accel;
    const double n = std::max<double>(1.0, static_cast<double>(in.samples));
    r.count = static_cast<std::int64_t>(m * in.samples);
    r.rms_whitened_gyro = std::sqrt(wg / (3.0 * n));
    r.rms_gyro = *r.rms_whitened_gyro * noise.GyroSampleSigma();
    if (imu) {
      r.rms_whitened_accel = std::sqrt(wa / (3.0 * n));
      r.rms_accel = *r.rms_whitened_accel * noise.AccelSampleSigma();
    }
    r.rms_whitened = std::sqrt((wg + wa) / (static_cast<double>(m) * n));
    result.residuals[name] = r;
    // Per noise window (~2 s): where the residuals are noise and where spline misfit.
    std::string windows;
    auto& rms = out->window_rms_whitened[name];
    rms.clear();
    for (std::size_t w = 0; w < in.window_samples.size(); ++w) {
      if (in.window_samples[w] == 0)
        continue;
      const double k = 3.0 * static_cast<double>(in.window_samples[w]);
      rms.emplace_back(std::sqrt(in.window_gyro[w] / k), std::sqrt(in.window_accel[w] / k));
      windows += imu ? Fmt(" %.2f/%.2f", rms.back().first, rms.back().second)
                     : Fmt(" %.2f", rms.back().first);
    }
    log("  " + name + " whitened RMS per 2 s window (" + (imu ? "gyro/accel" : "gyro") +
        "):" + windows);
  }
  for (const auto& [name, r] : result.residuals) {
    char line[256];
    std::snprintf(line, sizeof line, "  %-8s whitened RMS %.3f over %lld residuals", name.c_str(),
                  *r.rms_whitened, static_cast<long long>(r.count));
    log(line);
    if (*r.rms_whitened > 1.5 || *r.rms_whitened < 0.67) {
      // With the noise estimated, what is left is the share of the residuals' degrees of freedom
      // the trajectory takes (sqrt(r / n)) or a model error.
      const std::string w =
          "warning: sensors." + name + ": whitened residual RMS " + Fmt("%.3f", *r.rms_whitened) +
          (options.estimate_noise
               ? " is far from 1 with the estimated noise: the trajectory absorbs much of the "
                 "residuals (knots too fine) or the model does not fit"
               : " is far from 1: its stated noise (noise: / pixel_sigma) is wrong");
      log("  " + w);
      out->warnings.push_back(w);
    }
  }

  LogMemory(log, "residual statistics");
  if (!options.compute_covariance)
    return;

  // --- marginal covariance ---
  std::vector<ParameterBlockInfo> blocks = state.Blocks();
  std::vector<CalibrationBlock> calib;
  std::vector<const ParameterBlockInfo*> used;
  for (const ParameterBlockInfo& b : blocks) {
    if (!b.estimated || !problem.HasParameterBlock(b.values) ||
        problem.IsParameterBlockConstant(b.values))
      continue;
    calib.push_back(CalibrationBlock{b.values, b.names, b.unit});
    used.push_back(&b);
  }
  std::vector<ceres::ResidualBlockId> all, data_only;
  problem.GetResidualBlocks(&all);
  {
    std::vector<ceres::ResidualBlockId> priors(prior_ids);
    std::sort(priors.begin(), priors.end());
    for (const ceres::ResidualBlockId id : all) {
      if (!std::binary_search(priors.begin(), priors.end(), id))
        data_only.push_back(id);
    }
  }
  // One Schur complement of the data; the priors (on calibration blocks only) add to it. The
  // solver's is of the data and the priors: the priors' J^T J (at most their sigma's 1 / (a few
  // sigma of the data)^2 of it, and exact) taken out gives the data's.
  std::vector<double*> calib_values;
  for (const CalibrationBlock& b : calib)
    calib_values.push_back(b.values);
  MarginalInformation info_data, info;
  if (solved != nullptr && solved->blocks == calib_values) {
    info = solved->information;
    for (const CalibrationBlock& b : calib) {
      info.names.insert(info.names.end(), b.names.begin(), b.names.end());
      info.unit.conservativeResize(info.unit.size() + static_cast<Eigen::Index>(b.unit.size()));
      info.unit.tail(static_cast<Eigen::Index>(b.unit.size())) = Eigen::Map<const Eigen::VectorXd>(
          b.unit.data(), static_cast<Eigen::Index>(b.unit.size()));
    }
    info_data = info;
    AddCalibrationInformation(problem, calib, prior_ids, &info_data, -1.0);
  } else {
    info_data = ComputeMarginalInformation(problem, calib, data_only, options.threads);
    info = info_data;
    AddCalibrationInformation(problem, calib, prior_ids, &info);
  }
  LogMemory(log, "marginal information");
  const CalibrationCovariance cov = InvertInformation(info);
  const CalibrationCovariance cov_data = prior_ids.empty() ? cov : InvertInformation(info_data);
  if (info.nuisance_damping > 0.0)
    log(Fmt("  warning: the trajectory/bias states needed damping %.1e to be factored",
            info.nuisance_damping));

  std::vector<bool> undetermined(static_cast<std::size_t>(cov.sigma.size()), false);
  for (std::size_t i = 0; i < undetermined.size(); ++i)
    undetermined[i] = cov.undetermined[i] || cov_data.undetermined[i];
  // Observability of the data alone (numeric_observability.h); the motion half is added by
  // the calibrator (CompleteObservability), which has the raw data.
  const double duration_s = (out->num_knots - options.order + 1) * out->knot_spacing_s;
  result.observability = NumericObservability(info_data, cov_data, result, duration_s);
  out->covariance_names = info.names;
  out->covariance = cov.covariance;
  out->data_sigma = cov_data.sigma;

  const double inf = std::numeric_limits<double>::infinity();
  int offset = 0;
  for (const ParameterBlockInfo* b : used) {
    std::vector<double> sig(static_cast<std::size_t>(b->tangent_size));
    for (int i = 0; i < b->tangent_size; ++i) {
      const auto k = static_cast<std::size_t>(offset + i);
      sig[static_cast<std::size_t>(i)] = undetermined[k] ? inf : cov.sigma(offset + i);
    }
    if (b->key == "gravity_W") {
      if (undetermined[static_cast<std::size_t>(offset)] ||
          undetermined[static_cast<std::size_t>(offset + 1)])
        result.sigma_gravity_W = Eigen::Vector3d::Constant(inf);
      else
        result.sigma_gravity_W =
            GravitySigma(b->values, cov.covariance.block<2, 2>(offset, offset));
    } else {
      SensorConfig* c = result.Find(b->sensor);
      if (b->key == "params") {
        const int ni = state.Find(b->sensor)->camera->NumIntrinsics();
        c->sigma.values["intrinsics"] = std::vector<double>(sig.begin(), sig.begin() + ni);
        if (b->tangent_size > ni)
          c->sigma.values["distortion_coeffs"] = std::vector<double>(sig.begin() + ni, sig.end());
      } else {
        c->sigma.values[b->key] = sig;
      }
    }
    offset += b->tangent_size;
  }
}

}  // namespace spline_internal

namespace {

// CalibrateSpline on `data`; with `owned` (the same map, the caller's to give up) the cameras'
// corners are released once Prepare has selected them.
SplineCalibrationResult Calibrate(const RigConfig& rig,
                                  const std::map<std::string, SensorData>& data,
                                  std::map<std::string, SensorData>* owned,
                                  const SplineCalibratorOptions& options_in,
                                  const CalibrationLog& log) {
  const auto t_start = std::chrono::steady_clock::now();
  SplineCalibratorOptions options = options_in;
  if (options.threads <= 0)
    options.threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  CheckOptions(options);
  if (rig.IsCameraOnly())
    throw CalibrationInputError(
        "camera-only rigs are not supported by --method spline yet (the rig has no IMU)");

  log("[1/6] rig: " + std::to_string(rig.sensors.size()) + " sensors, base " + rig.base_imu);
  CalibrationState state(rig);
  options.coarse_init.threads = options.threads;
  options.coarse_init.views_min_corners = options.min_corners_per_view;
  LogMemory(log, "calibration starts");
  const CoarseInitResult init = InitializeFromData(&state, data, options.coarse_init, log);
  ReleaseFreedMemory();
  LogMemory(log, "coarse initialisation");
  Prepared prep;
  log("[2/6] board views and data selection");
  const auto t_prepare = std::chrono::steady_clock::now();
  const std::clock_t cpu_prepare = std::clock();
  Prepare(&state, data, options, init, log, &prep);
  SeedBiasSplines(init, &state);
  // The observability's motion half reads the raw inertial data: analysed now, so that a caller
  // who gives the data up has them released before the solves (below).
  std::optional<Observability> motion;
  if (options.compute_covariance) {
    motion.emplace();
    AnalyseMotion(rig, data, MotionOptions{}, &*motion);
  }
  if (owned != nullptr) {
    // Prepare holds the selected corners and samples, and the rest of the run reads them only:
    // the loaded ones go (10 min of 1 kHz IMU and 2 cameras: ~175 MB).
    for (auto& [name, d] : *owned) {
      std::vector<CornerObservation>().swap(d.corners);
      std::vector<ImuSample>().swap(d.imu);
      std::vector<GyroSample>().swap(d.gyro);
    }
  }
  ReleaseFreedMemory();
  log(Fmt("  board views and data selection: %.2f s (CPU %.2f s)",
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t_prepare).count(),
          static_cast<double>(std::clock() - cpu_prepare) / CLOCKS_PER_SEC));
  log(Fmt("  trajectory: %.3f .. %.3f s (base clock), knot spacing %.4f s",
          1e-9 * static_cast<double>(prep.t0_ns), 1e-9 * static_cast<double>(prep.t1_ns),
          prep.knot_spacing_s));
  LogMemory(log, "data selected");

  SplineCalibrationResult out;
  out.init_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  using spline_internal::RunPipeline;
  const bool split = options.representation == Se3Representation::kSplit;
  switch (options.order) {
    case 4:
      split ? RunPipeline<4, Se3Representation::kSplit>(&prep, options, log, &out)
            : RunPipeline<4, Se3Representation::kJoint>(&prep, options, log, &out);
      break;
    case 5:
      split ? RunPipeline<5, Se3Representation::kSplit>(&prep, options, log, &out)
            : RunPipeline<5, Se3Representation::kJoint>(&prep, options, log, &out);
      break;
    default:
      split ? RunPipeline<6, Se3Representation::kSplit>(&prep, options, log, &out)
            : RunPipeline<6, Se3Representation::kJoint>(&prep, options, log, &out);
      break;
  }
  // The prepared corners and samples are done with: returned to the system before the caller
  // renders the report (10 min at 1 kHz: freed but still resident, they made the report's
  // rendering the command's peak; docs/performance.md step 7e).
  prep = Prepared();
  ReleaseFreedMemory();
  if (motion)
    CompleteObservability(*motion, &out.result, log, &out.warnings);
  out.total_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  if (out.result.solver)
    out.result.solver->seconds = out.total_seconds;
  return out;
}

}  // namespace

void CheckOptions(const SplineCalibratorOptions& options) {
  if (options.order < 4 || options.order > 6)
    throw CalibrationInputError("spline order must be 4, 5 or 6, got " +
                                std::to_string(options.order));
  // A bias knot spacing below a nanosecond divided by zero when the bias splines were laid out
  // (Prepare: SIGFPE); below a millisecond it is knots faster than any IMU's samples.
  if (!(options.bias_knot_spacing_s >= 1e-3 && std::isfinite(options.bias_knot_spacing_s)))
    throw CalibrationInputError("bias knot spacing (--bias-knot-spacing) must be >= 0.001 s, got " +
                                Fmt("%g", options.bias_knot_spacing_s));
  // 0 means "from the motion's bandwidth"; a negative spacing meant it as well, silently, and
  // 1e-6 s laid out millions of knots until the process was killed for its memory.
  if (!(options.knot_spacing_s == 0.0 ||
        (options.knot_spacing_s >= 1e-3 && std::isfinite(options.knot_spacing_s))))
    throw CalibrationInputError(
        "trajectory knot spacing (--knot-spacing) must be 0 (from the motion's bandwidth) or "
        ">= 0.001 s, got " +
        Fmt("%g", options.knot_spacing_s));
  // Ceres rejects it only at the first solve, which then reads as a diverged solve.
  if (options.max_iterations < 0)
    throw CalibrationInputError("max iterations (--max-iterations) must be >= 0, got " +
                                std::to_string(options.max_iterations));
}

SplineCalibrationResult CalibrateSpline(const RigConfig& rig,
                                        const std::map<std::string, SensorData>& data,
                                        const SplineCalibratorOptions& options,
                                        const CalibrationLog& log) {
  return Calibrate(rig, data, nullptr, options, log);
}

SplineCalibrationResult CalibrateSpline(const RigConfig& rig,
                                        std::map<std::string, SensorData>&& data,
                                        const SplineCalibratorOptions& options,
                                        const CalibrationLog& log) {
  return Calibrate(rig, data, &data, options, log);
}

std::string FormatParameterTable(const RigConfig& result) {
  std::ostringstream os;
  char line[200];
  std::snprintf(line, sizeof line, "%-28s %16s %14s\n", "parameter", "value", "sigma");
  os << line;
  for (const ScalarParameter& p : ScalarParameters(result, true)) {
    double value = 0.0;
    try {
      value = ParameterValue(result, p);
    } catch (const std::exception&) {
      continue;
    }
    const std::optional<double> sigma = ParameterSigma(result, p);
    const char* unit = p.rotation ? " deg" : "";
    const double scale = p.rotation ? 180.0 / M_PI : 1.0;
    if (sigma)
      std::snprintf(line, sizeof line, "%-28s %16.9g %14.4g%s\n", p.name.c_str(), value * scale,
                    *sigma * scale, unit);
    else
      std::snprintf(line, sizeof line, "%-28s %16.9g %14s%s\n", p.name.c_str(), value * scale, "-",
                    unit);
    os << line;
  }
  return os.str();
}

}  // namespace ctcal
