#include "ctcal/calibrator/cross_validation.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <sstream>

#include "ctcal/sensors/parameter_names.h"

namespace ctcal {

namespace {

std::string Fmt(const char* format, double a, double b = 0.0, double c = 0.0) {
  char line[256];
  std::snprintf(line, sizeof line, format, a, b, c);
  return line;
}

}  // namespace

SubsetSplit SplitIntoSubsets(const RigConfig& rig, const std::map<std::string, SensorData>& data,
                             const CrossValidationOptions& options, int min_views) {
  SubsetSplit split;
  const int k = options.subsets;
  // The blocks are laid on the cameras' stamps: the cameras of a rig are synchronised within
  // their time offsets (milliseconds), far below a block's seconds.
  std::int64_t t_lo = std::numeric_limits<std::int64_t>::max();
  std::int64_t t_hi = std::numeric_limits<std::int64_t>::min();
  for (const SensorConfig& s : rig.sensors) {
    const auto it = data.find(s.name);
    if (s.type != SensorType::kCamera || it == data.end() || it->second.corners.empty())
      continue;
    t_lo = std::min(t_lo, it->second.corners.front().t_ns);
    t_hi = std::max(t_hi, it->second.corners.back().t_ns);
  }
  if (t_lo >= t_hi) {
    split.why_not = "no camera sees the board";
    return split;
  }
  const double duration = 1e-9 * static_cast<double>(t_hi - t_lo);
  const auto block_ns = static_cast<std::int64_t>(options.block_seconds * 1e9);
  split.block_seconds = options.block_seconds;
  split.blocks = static_cast<int>((t_hi - t_lo) / block_ns) + 1;
  if (split.blocks < k * options.min_blocks_per_subset) {
    split.why_not = "the recording's " + Fmt("%.1f s", duration) + " of board views make " +
                    std::to_string(split.blocks) + " blocks of " +
                    Fmt("%.1f s", options.block_seconds) + ", need " +
                    std::to_string(k * options.min_blocks_per_subset) + " for " +
                    std::to_string(k) + " subsets";
    return split;
  }
  split.subsets.assign(static_cast<std::size_t>(k - 1), {});
  for (const auto& [name, d] : data) {
    const SensorConfig* s = rig.Find(name);
    for (auto& subset : split.subsets) {
      SensorData& out = subset[name];
      if (s == nullptr || s->type != SensorType::kCamera) {
        out = d;  // the inertial data whole
        continue;
      }
      out.has_corners = d.has_corners;
    }
    if (s == nullptr || s->type != SensorType::kCamera)
      continue;
    std::vector<std::set<std::int64_t>> frames(static_cast<std::size_t>(k));
    for (const CornerObservation& c : d.corners) {
      const auto subset = static_cast<std::size_t>(((c.t_ns - t_lo) / block_ns) % k);
      if (subset + 1 < static_cast<std::size_t>(k))
        split.subsets[subset][name].corners.push_back(c);
      frames[subset].insert(c.t_ns);
    }
    for (int j = 0; j < k; ++j) {
      // Twice the calibrator's minimum: not every frame with corners gives a board pose.
      if (static_cast<int>(frames[static_cast<std::size_t>(j)].size()) < 2 * min_views) {
        split.why_not = name + ": subset " + std::to_string(j + 1) + " of " + std::to_string(k) +
                        " has " + std::to_string(frames[static_cast<std::size_t>(j)].size()) +
                        " frames with corners, need " + std::to_string(2 * min_views);
        split.subsets.clear();
        return split;
      }
    }
  }
  return split;
}

CalibrationCrossValidation CrossValidateSubsets(const RigConfig& full, const SubsetSplit& split,
                                                const SplineCalibratorOptions& options,
                                                const CalibrationLog& log) {
  const auto t_start = std::chrono::steady_clock::now();
  CalibrationCrossValidation xv;
  xv.blocks = split.blocks;
  xv.block_seconds = split.block_seconds;
  if (split.subsets.empty()) {
    xv.why_not = split.why_not;
    return xv;
  }
  // The full calibration's values are the guess: a few steps from the subset's optimum, which
  // the solves' own stopping rule ends at (a cap on the iterations would leave a subset short
  // of it, and its distance to F would read as model error). The biases start at zero (the
  // rig holds none), as in F's solve.
  SplineCalibratorOptions sub = options;
  sub.coarse_init.policy = GuessPolicy::kOff;
  sub.report_data = false;
  sub.compute_covariance = true;
  // No priors in the subsets: F's prior is centred on the user's guess, a subset's would be
  // centred on F's values and pull it towards them. Counted as pseudo-data of F alone, the prior
  // keeps each subset's data a part of F's, as the nested comparison needs.
  RigConfig start = full;
  for (SensorConfig& s : start.sensors)
    s.prior_sigma.values.clear();
  std::vector<std::string> labels;
  for (std::size_t j = 0; j < split.subsets.size(); ++j) {
    const std::string label = "subset " + std::to_string(j + 1);
    // Only the subset's own summary reaches the log: its stages repeat the full calibration's.
    try {
      SplineCalibrationResult r =
          CalibrateSpline(start, split.subsets[j], sub, [](const std::string&) {});
      log("  " + label + ": " + std::to_string(r.iterations) + " iterations, " +
          Fmt("%.2f s, knot spacing %.4f s", r.total_seconds, r.knot_spacing_s));
      xv.subsets.push_back(std::move(r.result));
    } catch (const std::exception& e) {
      xv.why_not = label + " did not calibrate: " + e.what();
      xv.subsets.clear();
      return xv;
    }
    labels.push_back(label);
  }
  xv.versus_full = CrossValidateNested(full, xv.subsets, labels);
  xv.ran = true;
  xv.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return xv;
}

int ApplyModelError(const CrossValidation& cv, RigConfig* full) {
  std::map<std::string, double> ratio;
  for (const CrossValGroup& g : cv.groups)
    ratio[g.name] = g.model_ratio;
  int inflated = 0;
  for (const CrossValRow& row : cv.rows) {
    // Every parameter of a failing group, also one without a z of its own (its subset variance
    // below 1.2 times F's): the group's model error is mu_i = lambda s_ik^2 for each of them. Left
    // at its formal sigma, such a parameter was the worst of the EuRoC parts' comparison (cam1's
    // k2 at 8.3 reported sigmas).
    const double lambda = ratio[row.group];
    if (!(lambda > 0.0) || !std::isfinite(row.subset_variance) || !(row.subset_variance > 0.0))
      continue;
    const std::optional<ScalarParameter> p = FindParameter(*full, row.name);
    SensorConfig* s = p ? full->Find(p->sensor) : nullptr;
    if (s == nullptr)
      continue;
    const auto it = s->sigma.values.find(p->key);
    if (it == s->sigma.values.end())
      continue;
    double& sigma = it->second[static_cast<std::size_t>(std::max(0, p->index))];
    if (!std::isfinite(sigma))
      continue;
    if (s->sigma_formal.empty())
      s->sigma_formal = s->sigma;
    sigma = std::sqrt(sigma * sigma + lambda * row.subset_variance);
    ++inflated;
  }
  return inflated;
}

std::string FormatCalibrationCrossValidation(const CalibrationCrossValidation& xv) {
  std::ostringstream out;
  if (!xv.ran) {
    out << "cross-validation not run: " << xv.why_not << "\n";
    return out.str();
  }
  out << "cross-validation: " << xv.subsets.size() + 1 << " subsets of interleaved "
      << Fmt("%.1f s", xv.block_seconds) << " blocks (" << xv.blocks << " blocks), "
      << xv.subsets.size() << " calibrated and compared with the full calibration, "
      << Fmt("%.2f s", xv.seconds) << "\n";
  out << FormatCrossValidation(xv.versus_full);
  return out.str();
}

}  // namespace ctcal
