#include "ctcal/sensors/crossval.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>

#include "ctcal/sensors/json_format.h"
#include "ctcal/sensors/parameter_names.h"
#include "ctcal/spline/so3.h"

namespace ctcal {
namespace {

bool Usable(double s) {
  return std::isfinite(s) && s > 0.0;
}

// Nested: below this ratio of a subset's sigma^2 to F's, x_k - x_F would be mostly the two solves'
// distance to their optima (each stops within ~0.1 of its sigma: SplineCalibratorOptions::
// stop_cost_change) over a small s_k^2 - s_F^2.
constexpr double kNestedMinVarianceRatio = 1.2;

// Log(R_k * R_1^T) of a rotation parameter: the left perturbation from the first result.
Eigen::Vector3d RotationFromFirst(const RigConfig& first, const RigConfig& other,
                                  const ScalarParameter& p) {
  const Eigen::Matrix3d R_1 = ParameterRotation(first, p);
  const Eigen::Matrix3d R_k = ParameterRotation(other, p);
  if (R_k == R_1)
    return Eigen::Vector3d::Zero();
  return RotationError<double>(Eigen::Quaterniond(R_k).normalized(),
                               Eigen::Quaterniond(R_1).normalized());
}

// r_i and the table's z of one row of independent results (see the header).
void RowStatistics(CrossValRow* row) {
  const int k = static_cast<int>(row->values.size());
  double mean = 0.0, mean_var = 0.0;
  for (int j = 0; j < k; ++j) {
    mean += row->values[j] / k;
    mean_var += row->sigmas[j] * row->sigmas[j] / k;
  }
  double spread = 0.0;
  for (int j = 0; j < k; ++j)
    spread += (row->values[j] - mean) * (row->values[j] - mean) / (k - 1);
  row->difference = k == 2 ? row->values[1] - row->values[0] : std::sqrt(spread);
  row->subset_variance = mean_var;
  for (double s : row->sigmas) {
    if (!Usable(s))
      return;
  }
  row->ratio = spread / mean_var;
  row->z = k == 2 ? row->difference / std::sqrt(2.0 * mean_var) : std::sqrt(*row->ratio);
}

// The same for the nested comparison: values[0] is the full calibration F (see the header).
void NestedRowStatistics(CrossValRow* row) {
  const std::size_t m = row->values.size() - 1;
  const double var_f = row->sigmas[0] * row->sigmas[0];
  double ratio = 0.0, d2 = 0.0, var_sum = 0.0;
  bool usable = Usable(row->sigmas[0]);
  for (std::size_t k = 1; k <= m; ++k) {
    const double d = row->values[k] - row->values[0];
    const double var_k = row->sigmas[k] * row->sigmas[k];
    usable = usable && Usable(row->sigmas[k]) && var_k >= kNestedMinVarianceRatio * var_f;
    if (usable)
      ratio += d * d / (var_k - var_f) / static_cast<double>(m);
    d2 += d * d / static_cast<double>(m);
    var_sum += var_k / static_cast<double>(m);
  }
  row->difference = m == 1 ? row->values[1] - row->values[0] : std::sqrt(d2);
  row->subset_variance = var_sum;
  if (!usable)
    return;
  row->ratio = ratio;
  row->z = m == 1 ? row->difference / std::sqrt(row->sigmas[1] * row->sigmas[1] - var_f)
                  : std::sqrt(ratio);
}

void GroupTests(CrossValidation* cv) {
  std::map<std::string, std::size_t> index;
  for (const CrossValRow& row : cv->rows) {
    if (!index.count(row.group)) {
      index[row.group] = cv->groups.size();
      cv->groups.push_back({});
      cv->groups.back().name = row.group;
    }
    if (!row.ratio)
      continue;
    CrossValGroup& g = cv->groups[index[row.group]];
    ++g.count;
    g.statistic += cv->row_dof * *row.ratio;
  }
  // Bonferroni: each of the n tested groups at kCrossValFalseAlarm / n, so that a rig without
  // model error gets a false alarm in kCrossValFalseAlarm of its calibrations, not in n times
  // that (a false alarm in a 1-dof group inflates its sigma several times).
  int tested = 0;
  for (const CrossValGroup& g : cv->groups)
    tested += g.count > 0;
  for (CrossValGroup& g : cv->groups) {
    if (g.count == 0)
      continue;
    g.dof = cv->row_dof * g.count;
    g.threshold =
        boost::math::quantile(boost::math::chi_squared(g.dof), 1.0 - kCrossValFalseAlarm / tested);
    g.passed = g.statistic <= g.threshold;
    g.mean_ratio = g.statistic / g.dof;
    if (!g.passed)
      ++cv->summary.groups_failed;
  }
  // The rig's test, and the model error of every group once the rig or the group fails it: each
  // group then gets its own estimate lambda = mean r_i - 1 (unbiased for the model error's share
  // of its variance), whether or not its own few dof reached significance. Without model error
  // both tests pass in all but ~2 % of calibrations and the sigma stays formal.
  CrossValSummary& s = cv->summary;
  for (const CrossValGroup& g : cv->groups) {
    s.rig_statistic += g.statistic;
    s.rig_dof += g.dof;
  }
  if (s.rig_dof > 0) {
    s.rig_threshold =
        boost::math::quantile(boost::math::chi_squared(s.rig_dof), 1.0 - kCrossValFalseAlarm);
    s.rig_passed = s.rig_statistic <= s.rig_threshold;
  }
  for (CrossValGroup& g : cv->groups) {
    if (g.count > 0 && (!g.passed || !s.rig_passed))
      g.model_ratio = std::max(0.0, g.mean_ratio - 1.0);
  }
}

}  // namespace

std::string CrossValGroupName(const std::string& sensor, const std::string& key) {
  if (key == "R_B_S" || key == "t_B_S" || key == "time_offset")
    return sensor + "." + key;
  return sensor + ".intrinsics";
}

namespace {

CrossValidation Compare(const std::vector<RigConfig>& results,
                        const std::vector<std::string>& labels, bool nested) {
  if (results.size() < 2 || labels.size() != results.size())
    throw std::invalid_argument("cross-validation needs >= 2 results, each with a label");
  const RigConfig& first = results.front();
  for (std::size_t k = 1; k < results.size(); ++k) {
    if (results[k].base_imu != first.base_imu) {
      throw std::runtime_error(labels[k] + ": base '" + results[k].base_imu + "', but " +
                               labels[0] + " has base '" + first.base_imu +
                               "' (their T_B_S are in different frames)");
    }
  }
  CrossValidation cv;
  cv.num_results = static_cast<int>(results.size());
  cv.nested = nested;
  // K independent results: K - 1 dof; nested: one per subset.
  cv.row_dof = cv.num_results - 1;
  std::vector<Eigen::Vector3d> dtheta(results.size(), Eigen::Vector3d::Zero());
  for (const ScalarParameter& p : ScalarParameters(first, true)) {
    if (p.sensor.empty())
      continue;  // gravity_W: where the board lay, not a property of the rig
    CrossValRow row;
    row.name = p.name;
    row.sensor = p.sensor;
    row.group = CrossValGroupName(p.sensor, p.key);
    row.rotation = p.rotation;
    for (std::size_t k = 0; k < results.size(); ++k) {
      const std::optional<ScalarParameter> q = FindParameter(results[k], p.name);
      if (!q || results[k].Find(p.sensor)->type != first.Find(p.sensor)->type) {
        throw std::runtime_error(labels[k] + " has no parameter " + p.name + " like " + labels[0] +
                                 "'s (another rig or model)");
      }
      if (p.rotation && p.index == 0)
        dtheta[k] = RotationFromFirst(first, results[k], *q);
      row.values.push_back(p.rotation ? dtheta[k](p.index) : ParameterValue(results[k], *q));
      row.sigmas.push_back(
          ParameterSigma(results[k], *q).value_or(std::numeric_limits<double>::quiet_NaN()));
    }
    nested ? NestedRowStatistics(&row) : RowStatistics(&row);
    cv.rows.push_back(std::move(row));
  }
  GroupTests(&cv);

  CrossValSummary& s = cv.summary;
  s.count = static_cast<int>(cv.rows.size());
  double sum_ratio = 0.0;
  for (const CrossValRow& row : cv.rows) {
    if (!row.z)
      continue;
    ++s.with_z;
    sum_ratio += *row.ratio;
    if (std::abs(*row.z) < 3.0)
      ++s.within_3_sigma;
    if (!s.worst_z || std::abs(*row.z) > std::abs(*s.worst_z)) {
      s.worst_z = row.z;
      s.worst_name = row.name;
    }
  }
  if (s.with_z > 0) {
    s.fraction_within_3_sigma = static_cast<double>(s.within_3_sigma) / s.with_z;
    s.rms_z = std::sqrt(sum_ratio / s.with_z);
  }
  s.passed = s.groups_failed == 0 && s.rig_passed;
  return cv;
}

}  // namespace

CrossValidation CrossValidate(const std::vector<RigConfig>& results,
                              const std::vector<std::string>& labels) {
  return Compare(results, labels, false);
}

CrossValidation CrossValidateNested(const RigConfig& full, const std::vector<RigConfig>& subsets,
                                    const std::vector<std::string>& subset_labels) {
  std::vector<RigConfig> results = {full};
  results.insert(results.end(), subsets.begin(), subsets.end());
  std::vector<std::string> labels = {"the full calibration"};
  labels.insert(labels.end(), subset_labels.begin(), subset_labels.end());
  return Compare(results, labels, true);
}

std::string FormatCrossValidation(const CrossValidation& cv) {
  std::ostringstream out;
  char line[320];
  // Independent pair: a and b; K > 2: the spread; nested: the subsets against the full one.
  const bool pair = cv.num_results == 2 && !cv.nested;
  const char* difference = pair        ? "b - a"
                           : cv.nested ? (cv.num_results == 2 ? "subset - full" : "rms(sub - full)")
                                       : "spread (std)";
  std::snprintf(
      line, sizeof line, "%-28s %15s %15s %13s %13s %9s\n", "parameter", difference,
      cv.nested ? "value (full)" : "value (1st)", cv.nested ? "sigma (full)" : "sigma (1st)",
      cv.nested || !pair ? "sigma (subs)" : "sigma (2nd)", cv.num_results == 2 ? "z" : "sqrt(r)");
  out << line;
  for (const CrossValRow& r : cv.rows) {
    const double second = pair ? r.sigmas[1] : std::sqrt(r.subset_variance);
    std::string z = "-";
    if (r.z) {
      char b[32];
      std::snprintf(b, sizeof b, "%.2f", *r.z);
      z = b;
    }
    std::snprintf(line, sizeof line, "%-28s %15.6g %15.9g %13.4g %13.4g %9s\n", r.name.c_str(),
                  r.difference, r.values[0], r.sigmas[0], second, z.c_str());
    out << line;
  }
  out << "groups (chi-square test of the disagreement, 1 % false alarm over all groups):\n";
  for (const CrossValGroup& g : cv.groups) {
    if (g.count == 0) {
      out << "  " << g.name << ": no parameter with a sigma in every result\n";
      continue;
    }
    std::snprintf(line, sizeof line,
                  "  %-22s %3d dof  statistic %9.2f  limit %8.2f  %s  (mean ratio %.2f, model "
                  "error ratio %.2f)\n",
                  g.name.c_str(), g.dof, g.statistic, g.threshold, g.passed ? "pass" : "FAIL",
                  g.mean_ratio, g.model_ratio);
    out << line;
  }
  const CrossValSummary& s = cv.summary;
  out << "summary: " << cv.num_results << " results, " << s.count << " parameters, " << s.with_z
      << " with a sigma in every result";
  if (s.fraction_within_3_sigma) {
    std::snprintf(line, sizeof line, "; %.1f %% with |z| < 3, rms z %.2f, worst %s at %.2f",
                  100.0 * *s.fraction_within_3_sigma, *s.rms_z, s.worst_name->c_str(), *s.worst_z);
    out << line;
  }
  std::snprintf(line, sizeof line, "\nrig: %d dof  statistic %.2f  limit %.2f  %s", s.rig_dof,
                s.rig_statistic, s.rig_threshold, s.rig_passed ? "pass" : "FAIL");
  out << line;
  out << "\nverdict: "
      << (s.passed ? "consistent: the results agree within their sigmas"
          : s.groups_failed > 0
              ? std::to_string(s.groups_failed) +
                    " group(s) disagree beyond their sigmas (model error)"
              : "the rig as a whole disagrees beyond its sigmas (model error in every group)")
      << "\n";
  return out.str();
}

std::string CrossValidationJson(const CrossValidation& cv) {
  std::ostringstream out;
  const auto list = [&](const std::vector<double>& v) {
    out << "[";
    for (std::size_t i = 0; i < v.size(); ++i)
      out << (i ? ", " : "") << JsonNumber(v[i]);
    out << "]";
  };
  out << "{\n  \"results\": " << cv.num_results
      << ",\n  \"nested\": " << (cv.nested ? "true" : "false") << ",\n  \"parameters\": [";
  for (std::size_t i = 0; i < cv.rows.size(); ++i) {
    const CrossValRow& r = cv.rows[i];
    out << (i ? ",\n" : "\n") << "    {\"name\": " << JsonString(r.name)
        << ", \"group\": " << JsonString(r.group) << ", \"values\": ";
    list(r.values);
    out << ", \"sigmas\": ";
    list(r.sigmas);
    out << ", \"difference\": " << JsonNumber(r.difference) << ", \"z\": " << JsonNumber(r.z)
        << "}";
  }
  out << (cv.rows.empty() ? "],\n" : "\n  ],\n") << "  \"groups\": [";
  for (std::size_t i = 0; i < cv.groups.size(); ++i) {
    const CrossValGroup& g = cv.groups[i];
    out << (i ? ",\n" : "\n") << "    {\"name\": " << JsonString(g.name)
        << ", \"count\": " << g.count << ", \"dof\": " << g.dof
        << ", \"statistic\": " << JsonNumber(g.statistic)
        << ", \"threshold\": " << JsonNumber(g.threshold)
        << ", \"passed\": " << (g.passed ? "true" : "false")
        << ", \"model_error_ratio\": " << JsonNumber(g.model_ratio) << "}";
  }
  const CrossValSummary& s = cv.summary;
  out << (cv.groups.empty() ? "],\n" : "\n  ],\n") << "  \"summary\": {\"count\": " << s.count
      << ", \"with_z\": " << s.with_z << ", \"within_3_sigma\": " << s.within_3_sigma
      << ", \"fraction_within_3_sigma\": " << JsonNumber(s.fraction_within_3_sigma)
      << ", \"rms_z\": " << JsonNumber(s.rms_z) << ", \"worst\": ";
  if (s.worst_name)
    out << "{\"name\": " << JsonString(*s.worst_name) << ", \"z\": " << JsonNumber(s.worst_z)
        << "}";
  else
    out << "null";
  out << ", \"groups_failed\": " << s.groups_failed << ", \"rig\": {\"dof\": " << s.rig_dof
      << ", \"statistic\": " << JsonNumber(s.rig_statistic)
      << ", \"threshold\": " << JsonNumber(s.rig_threshold)
      << ", \"passed\": " << (s.rig_passed ? "true" : "false") << "}"
      << ", \"passed\": " << (s.passed ? "true" : "false") << "}\n}\n";
  return out.str();
}

}  // namespace ctcal
