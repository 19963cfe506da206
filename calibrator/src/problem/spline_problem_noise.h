// The continuous-time problem's noise estimation (SplineProblem, spline_problem.h): every noise
// group's residual statistics and hat-matrix trace (noise/variance_components.h), and the rounds
// of variance component estimation the pipeline runs after its final solve
// (docs/noise_estimation.md). Included through spline_problem_impl.h.
#pragma once

#include <unordered_set>

#include "../solver/parameter_order.h"
#include "spline_problem.h"

namespace ctcal {
namespace spline_internal {

template <int N, Se3Representation Rep>
std::vector<VarianceComponent> SplineProblem<N, Rep>::NoiseComponents(
    const RedundancyOptions& options, std::vector<CornerResiduals>* corners_out,
    std::vector<InertialResidualSums>* inertial_out) {
  std::vector<CornerResiduals> corners;
  std::vector<InertialResidualSums> inertial;
  CollectResiduals(&corners, &inertial);
  std::vector<VarianceComponent> out;
  for (const CornerResiduals& c : corners) {
    VarianceComponent v;
    v.name = c.camera;
    for (const Eigen::Vector2d& e : c.whitened)
      v.weighted += e.squaredNorm();
    v.count = 2.0 * static_cast<double>(c.whitened.size());
    out.push_back(v);
  }
  std::vector<int> first_group;  // per inertial sensor: its gyro group (accel: + 1)
  std::vector<bool> has_accel;
  for (std::size_t i = 0; i < inertial.size(); ++i) {
    const InertialResidualSums& in = inertial[i];
    first_group.push_back(static_cast<int>(out.size()));
    const double samples = static_cast<double>(in.samples);
    out.push_back(VarianceComponent{in.sensor + " gyro", in.gyro, 3.0 * samples, 0.0});
    has_accel.push_back(prep_.inertial[i].state->config.type == SensorType::kImu);
    if (has_accel.back())
      out.push_back(VarianceComponent{in.sensor + " accel", in.accel, 3.0 * samples, 0.0});
  }
  if (corners_out != nullptr)
    *corners_out = std::move(corners);
  if (inertial_out != nullptr)
    *inertial_out = std::move(inertial);

  // A compressed inertial factor mixes the gyro and accelerometer rows: the traces then come from
  // the same problem with one block per sample (the same normal equations).
  const bool rebuild = std::find(inertial_rows_per_sample_.begin(), inertial_rows_per_sample_.end(),
                                 false) != inertial_rows_per_sample_.end();
  const bool compress = options_.compress_inertial;
  if (rebuild) {
    options_.compress_inertial = false;
    Build(false);
  }
  ceres::Problem& P = *problem_;
  ceres::Problem::EvaluateOptions eval;
  eval.num_threads = std::max(1, options_.threads);
  const std::vector<double*> all_blocks = ParameterBlocksInResidualOrder(P);
  int columns = 0;
  for (double* b : all_blocks) {
    if (P.IsParameterBlockConstant(b))
      continue;
    eval.parameter_blocks.push_back(b);
    columns += P.ParameterBlockTangentSize(b);
  }
  // Residual blocks with their rows' groups: cameras, inertial samples (3 gyro rows, then 3
  // accelerometer rows for an IMU), then everything else (priors, bias random walks: no group).
  std::vector<ceres::ResidualBlockId> order;
  // Per block in `order`: its group, -1 for none, -2 - i for the samples of inertial sensor i.
  std::vector<int> group_of;
  for (std::size_t c = 0; c < camera_ids_.size(); ++c) {
    order.insert(order.end(), camera_ids_[c].begin(), camera_ids_[c].end());
    group_of.insert(group_of.end(), camera_ids_[c].size(), static_cast<int>(c));
  }
  for (std::size_t i = 0; i < inertial_ids_.size(); ++i) {
    const auto& ids = inertial_ids_[i].second;
    order.insert(order.end(), ids.begin(), ids.end());
    group_of.insert(group_of.end(), ids.size(), -2 - static_cast<int>(i));
  }
  {
    std::unordered_set<ceres::ResidualBlockId> grouped(order.begin(), order.end());
    std::vector<ceres::ResidualBlockId> all;
    P.GetResidualBlocks(&all);
    for (const ceres::ResidualBlockId id : all) {
      if (grouped.count(id) == 0) {
        order.push_back(id);
        group_of.push_back(-1);
      }
    }
  }
  HatTraces traces(columns, static_cast<int>(out.size()), options);
  // In chunks of ~2 M Jacobian values (as the covariance: the whole Jacobian of a long recording
  // would hold hundreds of MB).
  constexpr std::size_t kChunkValues = std::size_t{1} << 21;
  for (std::size_t first = 0, last = 0; first < order.size(); first = last) {
    std::size_t values = 0;
    std::vector<int> row_group;
    for (last = first; last < order.size() && (last == first || values < kChunkValues); ++last) {
      const ceres::CostFunction* f = P.GetCostFunctionForResidualBlock(order[last]);
      int cols = 0;
      for (const int size : f->parameter_block_sizes())
        cols += size;
      const int rows = f->num_residuals();
      values += static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows);
      const int g = group_of[last];
      for (int r = 0; r < rows; ++r) {
        if (g > -2) {
          row_group.push_back(g);
          continue;
        }
        const auto i = static_cast<std::size_t>(-2 - g);
        row_group.push_back(first_group[i] + (has_accel[i] && r % 6 >= 3 ? 1 : 0));
      }
    }
    eval.residual_blocks.assign(order.begin() + static_cast<std::ptrdiff_t>(first),
                                order.begin() + static_cast<std::ptrdiff_t>(last));
    ceres::CRSMatrix J;
    double cost = 0.0;
    if (!P.Evaluate(eval, &cost, nullptr, nullptr, &J) || !std::isfinite(cost))
      throw CalibrationFailure(
          "noise estimation: the problem cannot be evaluated at the solution (non-finite "
          "residuals or Jacobians)");
    traces.Add(J, row_group);
  }
  const std::vector<double> t = traces.Compute();
  for (std::size_t k = 0; k < out.size(); ++k)
    out[k].trace = t[k];
  if (rebuild) {
    options_.compress_inertial = compress;
    Build(false);
  }
  return out;
}

template <int N, Se3Representation Rep>
void SplineProblem<N, Rep>::RestoreCorners() {
  for (PreparedCamera& cam : prep_.cameras)
    std::fill(cam.removed.begin(), cam.removed.end(), false);
}

// A whitened corner residual of the right sigma has |e|^2 ~ chi-square(2), whose median is
// 2 ln 2; the median of |e|^2 over 2 ln 2 is the camera's variance factor, and up to half of the
// corners may be gross outliers without moving it (the mean would follow them).
template <int N, Se3Representation Rep>
std::vector<double> SplineProblem<N, Rep>::RobustCornerFactors() {
  std::vector<double> factor(prep_.cameras.size(), 1.0);
  ParallelFor(options_.threads, prep_.cameras.size(), [&](std::size_t c) {
    const PreparedCamera& cam = prep_.cameras[c];
    std::vector<double> sq;
    sq.reserve(cam.corners.size());
    Eigen::Vector2d e;
    for (std::size_t i = 0; i < cam.corners.size(); ++i) {
      if (EvaluateCorner(cam, i, &e))  // every corner, also those a gate removed
        sq.push_back(e.squaredNorm());
    }
    if (sq.empty())
      return;
    const auto mid = sq.begin() + static_cast<std::ptrdiff_t>(sq.size() / 2);
    std::nth_element(sq.begin(), mid, sq.end());
    factor[c] = *mid / (2.0 * std::log(2.0));
  });
  return factor;
}

// The stated noise of every sensor, kept before the estimation rescales the weights in place
// (the result's `noise:` stays the stated one, `noise_estimated:` gets the estimate).
struct StatedNoise {
  std::map<std::string, InertialNoise> inertial;
  std::map<std::string, double> corner_sigma;  // cameras: the median stated corner sigma
};

// The median sigma of a camera's corners left in the problem (px).
inline double MedianCornerSigma(const PreparedCamera& cam) {
  std::vector<double> s;
  s.reserve(cam.corners.size());
  for (std::size_t i = 0; i < cam.corners.size(); ++i) {
    if (!cam.removed[i])
      s.push_back(cam.corners[i].sigma_px);
  }
  if (s.empty())
    return 0.0;
  std::nth_element(s.begin(), s.begin() + static_cast<std::ptrdiff_t>(s.size() / 2), s.end());
  return s[s.size() / 2];
}

inline StatedNoise KeepStatedNoise(const Prepared& prep) {
  StatedNoise stated;
  for (const PreparedInertial& in : prep.inertial)
    stated.inertial[in.state->name()] = in.state->config.noise;
  for (const PreparedCamera& cam : prep.cameras)
    stated.corner_sigma[cam.state->name()] = MedianCornerSigma(cam);
  return stated;
}

// The new variances of a sensor's parts (frames of a camera, noise windows of an inertial
// sensor), relative to their current ones: each part's own e^T W e over its share of the
// sensor's redundancy, shrunk toward the sensor's factor by `nu` pseudo-residuals (nu <= 0: the
// sensor's factor everywhere).
inline std::vector<double> PartFactors(const VarianceComponent& v,
                                       const std::vector<double>& weighted,
                                       const std::vector<double>& count, double nu) {
  const double sensor = v.VarianceFactor();
  std::vector<double> factor(weighted.size(), sensor);
  if (nu <= 0.0 || !(v.count > 0.0))
    return factor;
  const double share = std::max(v.Redundancy(), 0.0) / v.count;
  for (std::size_t f = 0; f < factor.size(); ++f)
    factor[f] = ShrunkVariance(weighted[f], share * count[f], sensor, nu);
  return factor;
}

// An inertial part's (gyro or accelerometer) new noise density and window scales from its
// windows' factors: the windows' new absolute variances density^2 scale_w^2 factor_w, the density
// their sample-weighted mean, the scales relative to it. Returns the density's relative change.
inline double RescaleWindows(const std::vector<double>& factor,
                             const std::vector<std::int64_t>& samples, double* density,
                             std::vector<double>* scale) {
  scale->resize(factor.size(), 1.0);
  double sum = 0.0, n = 0.0;
  std::vector<double> variance(factor.size());
  for (std::size_t w = 0; w < factor.size(); ++w) {
    variance[w] = (*scale)[w] * (*scale)[w] * factor[w];
    sum += static_cast<double>(samples[w]) * variance[w];
    n += static_cast<double>(samples[w]);
  }
  const double mean = n > 0.0 ? sum / n : 1.0;
  for (std::size_t w = 0; w < factor.size(); ++w)
    (*scale)[w] = std::sqrt(variance[w] / mean);
  *density *= std::sqrt(mean);
  return std::abs(std::sqrt(mean) - 1.0);
}

// Rescales the weights by the components' variance factors: a camera's corner sigmas (per frame
// with options.frame_weight_prior > 0), an inertial sensor's white-noise densities (and its noise
// windows' scales with options.window_weight_prior > 0). Returns the largest relative change of
// a sensor-level sigma.
inline double ApplyVarianceFactors(const std::vector<VarianceComponent>& comps,
                                   const std::vector<CornerResiduals>& corners,
                                   const std::vector<InertialResidualSums>& inertial,
                                   const SplineCalibratorOptions& options, Prepared* prep) {
  double largest = 0.0;
  std::size_t k = 0;
  for (PreparedCamera& cam : prep->cameras) {
    const VarianceComponent& v = comps[k];
    const CornerResiduals& res = corners[k];
    ++k;
    std::vector<double> weighted(cam.frame_stamps.size(), 0.0), count(weighted.size(), 0.0);
    for (std::size_t i = 0; i < res.whitened.size(); ++i) {
      const auto f = static_cast<std::size_t>(res.frame[i]);
      weighted[f] += res.whitened[i].squaredNorm();
      count[f] += 2.0;
    }
    const std::vector<double> factor = PartFactors(v, weighted, count, options.frame_weight_prior);
    largest = std::max(largest, std::abs(std::sqrt(v.VarianceFactor()) - 1.0));
    for (HeldCorner& c : cam.corners)
      c.sigma_px *= std::sqrt(factor[static_cast<std::size_t>(c.frame)]);
  }
  for (std::size_t i = 0; i < prep->inertial.size(); ++i) {
    PreparedInertial& in = prep->inertial[i];
    const InertialResidualSums& sums = inertial[i];
    InertialNoise& n = in.state->config.noise;
    std::vector<double> count(sums.window_samples.size());
    for (std::size_t w = 0; w < count.size(); ++w)
      count[w] = 3.0 * static_cast<double>(sums.window_samples[w]);
    const double nu = options.window_weight_prior;
    largest = std::max(largest, RescaleWindows(PartFactors(comps[k++], sums.window_gyro, count, nu),
                                               sums.window_samples, &n.gyroscope_noise_density,
                                               &in.window_gyro_scale));
    if (in.state->config.type == SensorType::kImu)
      largest =
          std::max(largest, RescaleWindows(PartFactors(comps[k++], sums.window_accel, count, nu),
                                           sums.window_samples, &n.accelerometer_noise_density,
                                           &in.window_accel_scale));
  }
  return largest;
}

inline std::string FormatComponents(const std::vector<VarianceComponent>& comps) {
  std::string line;
  for (const VarianceComponent& v : comps) {
    char part[160];
    std::snprintf(part, sizeof part, "%s%s sigma x%.3f (redundancy %.0f of %.0f)",
                  line.empty() ? "" : ", ", v.name.c_str(), std::sqrt(v.VarianceFactor()),
                  v.Redundancy(), v.count);
    line += part;
  }
  return line;
}

// Every corner back and gated again at the current weights; the outlier counts are the new gate's.
// Returns whether the set of corners in the problem changed.
template <int N, Se3Representation Rep>
bool Regate(SplineProblem<N, Rep>* sp, Prepared* prep, const SplineCalibratorOptions& options,
            const CalibrationLog& log, SplineCalibrationResult* out) {
  std::vector<std::vector<bool>> before;
  for (const PreparedCamera& cam : prep->cameras)
    before.push_back(cam.removed);
  sp->RestoreCorners();
  std::vector<CameraOutliers> found;
  sp->RemoveOutliers(options.outlier_probability, &found);
  for (const CameraOutliers& f : found) {
    for (CameraOutliers& o : out->outliers) {
      if (o.camera != f.camera || o.removed == f.removed)
        continue;
      log("    " + f.camera + ": " + std::to_string(f.removed) + " outliers at the new weights (" +
          std::to_string(o.removed) + " before)");
      o.removed = f.removed;
    }
  }
  for (std::size_t c = 0; c < before.size(); ++c) {
    if (before[c] != prep->cameras[c].removed)
      return true;
  }
  return false;
}

// Variance component estimation after the final solve. A stated corner noise far below the data's
// made the stages' outlier gate remove good corners (3x too small: half of them), and the
// variance of what is left is too small (0.53x the truth, issue 19). So the estimation first puts
// every corner back, rescales each camera's sigmas by its robust factor (RobustCornerFactors) and
// gates and solves again; then up to options.noise_rounds rounds of statistics -> reweight ->
// every corner gated again at the new weights -> re-solve, until every sigma moves by < 0.5 %.
// `solve(title)` runs and logs one solve.
template <int N, Se3Representation Rep, class SolveFn>
void EstimateNoise(SplineProblem<N, Rep>* sp, Prepared* prep, const SolveFn& solve,
                   const SplineCalibratorOptions& options, const CalibrationLog& log,
                   SplineCalibrationResult* out) {
  log("  noise estimation (variance components; the stated noise the start)");
  const std::vector<double> robust = sp->RobustCornerFactors();
  // Only a scale far from 1 is applied (the problem is then rebuilt); the rounds refine the rest.
  const bool rescaled = std::any_of(robust.begin(), robust.end(),
                                    [](double f) { return std::abs(std::sqrt(f) - 1.0) > 0.2; });
  for (std::size_t c = 0; c < prep->cameras.size() && rescaled; ++c) {
    char line[160];
    std::snprintf(line, sizeof line,
                  "  %s: corner sigmas x%.3f (robust scale: median of all corners)",
                  prep->cameras[c].state->name().c_str(), std::sqrt(robust[c]));
    log(line);
    for (HeldCorner& h : prep->cameras[c].corners)
      h.sigma_px *= std::sqrt(robust[c]);
  }
  if (Regate(sp, prep, options, log, out) || rescaled) {
    sp->Build(false);
    solve("  re-solve at the cameras' robust noise scale");
  }
  for (int round = 1; round <= options.noise_rounds; ++round) {
    std::vector<CornerResiduals> corners;
    std::vector<InertialResidualSums> inertial;
    std::vector<VarianceComponent> comps =
        sp->NoiseComponents(options.redundancy, &corners, &inertial);
    out->noise_components = comps;
    log("  round " + std::to_string(round) + ": " + FormatComponents(comps));
    const double moved = ApplyVarianceFactors(comps, corners, inertial, options, prep);
    const bool parts = options.frame_weight_prior > 0.0 || options.window_weight_prior > 0.0;
    if (moved < 0.005 && !parts)
      break;
    out->noise_rounds = round;
    // The gate (a chi-square quantile of the whitened residuals) at the new weights, on every
    // corner: one removed at the weights before may be an inlier at these.
    Regate(sp, prep, options, log, out);
    sp->Build(false);
    solve("  re-solve with the estimated noise");
    if (moved < 0.005)
      break;
  }
}

// The result's `noise:` back to the stated noise, `noise_estimated:` the estimate; the log's
// "stated vs estimated" and one warning per sensor whose noise differs by more than 2x.
inline void ReportNoise(const StatedNoise& stated, const Prepared& prep, const CalibrationLog& log,
                        SplineCalibrationResult* out) {
  log("  noise stated vs estimated:");
  const auto compare = [&](const std::string& sensor, const char* what, double s, double e,
                           const char* unit) {
    char line[200];
    std::snprintf(line, sizeof line, "    %-6s %-22s %.4g -> %.4g %s (x%.2f)", sensor.c_str(), what,
                  s, e, unit, e / s);
    log(line);
    return e > 2.0 * s || e < 0.5 * s ? e / s : 1.0;
  };
  for (const PreparedCamera& cam : prep.cameras) {
    const std::string& name = cam.state->name();
    std::vector<double> sum(cam.frame_stamps.size(), 0.0), count(sum.size(), 0.0);
    for (const HeldCorner& c : cam.corners) {
      sum[static_cast<std::size_t>(c.frame)] += c.sigma_px * c.sigma_px;
      count[static_cast<std::size_t>(c.frame)] += 1.0;
    }
    auto& frames = out->frame_sigma_px[name];
    for (std::size_t f = 0; f < sum.size(); ++f) {
      if (count[f] > 0.0)
        frames.emplace_back(cam.frame_stamps[f], std::sqrt(sum[f] / count[f]));
    }
    const double s = stated.corner_sigma.at(name), e = MedianCornerSigma(cam);
    SensorConfig* c = out->result.Find(name);
    c->pixel_sigma_estimated = e;
    const double off = compare(name, "pixel sigma (median)", s, e, "px");
    if (off != 1.0) {
      char w[240];
      std::snprintf(w, sizeof w,
                    "warning: sensors.%s: the corners' noise is %.3g px, %.2fx the stated %.3g px "
                    "(noise.pixel_sigma or the corners' own sigma); the estimate weights the solve",
                    name.c_str(), e, off, s);
      log(std::string("  ") + w);
      out->warnings.push_back(w);
    }
  }
  for (const PreparedInertial& in : prep.inertial) {
    const std::string& name = in.state->name();
    const InertialNoise& s = stated.inertial.at(name);
    const InertialNoise& e = in.state->config.noise;
    SensorConfig* c = out->result.Find(name);
    c->noise = s;
    c->noise_estimated = e;
    double off = compare(name, "gyroscope_noise_density", s.gyroscope_noise_density,
                         e.gyroscope_noise_density, "rad/s/sqrt(Hz)");
    const char* key = "gyroscope_noise_density";
    if (in.state->config.type == SensorType::kImu) {
      const double a = compare(name, "accelerometer_noise_density", s.accelerometer_noise_density,
                               e.accelerometer_noise_density, "m/s^2/sqrt(Hz)");
      if (off == 1.0 || (a != 1.0 && std::abs(std::log(a)) > std::abs(std::log(off)))) {
        if (a != 1.0)
          key = "accelerometer_noise_density";
        off = a != 1.0 ? a : off;
      }
    }
    if (off != 1.0) {
      char w[240];
      std::snprintf(w, sizeof w,
                    "warning: sensors.%s: the data show noise.%s %.2fx the stated one; the "
                    "estimate weights the solve",
                    name.c_str(), key, off);
      log(std::string("  ") + w);
      out->warnings.push_back(w);
    }
  }
}

}  // namespace spline_internal
}  // namespace ctcal
