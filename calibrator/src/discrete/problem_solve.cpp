// The discrete problem's solving (discrete_problem.h): a solve, the outlier gate, the rebuild
// check, the final residuals and covariance, and the report data.
#include "discrete_problem.h"

namespace ctcal {
namespace discrete_internal {

ceres::Solver::Summary DiscreteProblem::Solve() {
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

void DiscreteProblem::RemoveOutliers(double probability, std::vector<CameraOutliers>* report) {
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

int DiscreteProblem::CountRebuild() const {
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

std::string DiscreteProblem::NextRebuild() {
  std::string why = MaybeRechoose();
  if (why.empty()) {
    const int changed = CountRebuild();
    if (changed > 0)
      why = std::to_string(changed) +
            " residuals moved to other keyframes with the time offsets: rebuilt";
  }
  return why;
}

void DiscreteProblem::CountInterpolation(int* kinematic, int* geodesic) const {
  *kinematic = *geodesic = 0;
  for (const auto& cam : corner_slots_) {
    for (const auto& entry : cam)
      ++(entry.second.kinematic ? *kinematic : *geodesic);
  }
}

void DiscreteProblem::Finish(SplineCalibrationResult* out) {
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

report::ReportData DiscreteProblem::ReportData(const SplineCalibrationResult& out) {
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
    bias[a.in->state->name()] = KeyframeBiases(t, abg, aba, prep_.t0_ns, a.in->state->time_offset);
  }
  const auto slot = [this](double time) {
    const CornerSlot s = SlotOf(time);
    return KeyframeSlot{s.k, s.kinematic};
  };
  return spline_internal::SplineReportData(
      prep_, KeyframeTrajectory(kf_, &*state_.base().imu, state_.gravity(), prep_.t0_ns, slot), out,
      std::move(bias));
}

}  // namespace discrete_internal
}  // namespace ctcal
