#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "ctcal/calibrator/discrete/crosscheck.h"
#include "ctcal/sensors/parameter_names.h"
#include "ctcal/spline/so3.h"

namespace ctcal {

CrossCheck MakeCrossCheck(const RigConfig& spline, const RigConfig& discrete) {
  CrossCheck out;
  Eigen::Vector3d dtheta = Eigen::Vector3d::Zero();
  for (const ScalarParameter& p : ScalarParameters(spline, true)) {
    const std::optional<ScalarParameter> q = FindParameter(discrete, p.name);
    if (!q)
      throw std::runtime_error("cross-check: the discrete result has no parameter " + p.name);
    CrossCheckRow row;
    row.parameter = p.name;
    row.rotation = p.rotation;
    const std::optional<double> ss = ParameterSigma(spline, p);
    const std::optional<double> sd = ParameterSigma(discrete, *q);
    row.sigma_spline = ss.value_or(std::numeric_limits<double>::infinity());
    row.sigma_discrete = sd.value_or(std::numeric_limits<double>::infinity());
    if (p.rotation) {
      // The rotation between the two estimates (left perturbation, as the sigmas), per component.
      if (p.index == 0) {
        const Eigen::Quaterniond R_s(ParameterRotation(spline, p));
        const Eigen::Quaterniond R_d(ParameterRotation(discrete, *q));
        dtheta = RotationError<double>(R_d.normalized(), R_s.normalized());
      }
      row.spline = 0.0;
      row.discrete = dtheta(p.index);
      row.difference = dtheta(p.index);
    } else {
      row.spline = ParameterValue(spline, p);
      row.discrete = ParameterValue(discrete, *q);
      row.difference = row.discrete - row.spline;
    }
    const double smaller = std::min(row.sigma_spline, row.sigma_discrete);
    row.ratio = std::abs(row.difference) / smaller;
    row.flagged = std::isfinite(smaller) && row.ratio > 1.0;
    if (row.flagged)
      out.flagged.push_back(row.parameter);
    out.rows.push_back(row);
  }
  return out;
}

void SaveCrossCheck(const CrossCheck& check, const std::string& path) {
  YAML::Emitter e;
  e.SetDoublePrecision(12);
  e << YAML::BeginMap;
  e << YAML::Key << "flagged" << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (const std::string& n : check.flagged)
    e << n;
  e << YAML::EndSeq;
  e << YAML::Key << "rows" << YAML::Value << YAML::BeginSeq;
  for (const CrossCheckRow& r : check.rows) {
    e << YAML::Flow << YAML::BeginMap;
    e << YAML::Key << "parameter" << YAML::Value << r.parameter;
    e << YAML::Key << "spline" << YAML::Value << r.spline;
    e << YAML::Key << "sigma_spline" << YAML::Value << r.sigma_spline;
    e << YAML::Key << "discrete" << YAML::Value << r.discrete;
    e << YAML::Key << "sigma_discrete" << YAML::Value << r.sigma_discrete;
    e << YAML::Key << "difference" << YAML::Value << r.difference;
    e << YAML::Key << "ratio" << YAML::Value << r.ratio;
    e << YAML::EndMap;
  }
  e << YAML::EndSeq << YAML::EndMap;
  std::ofstream f(path);
  f << e.c_str() << '\n';
  if (!f)
    throw std::runtime_error(path + ": cannot write the cross-check");
}

std::string FormatCrossCheck(const CrossCheck& check) {
  std::ostringstream os;
  char line[256];
  std::snprintf(line, sizeof line, "%-28s %14s %11s %14s %11s %11s %7s\n", "parameter", "spline",
                "sigma", "discrete", "sigma", "difference", "ratio");
  os << line;
  for (const CrossCheckRow& r : check.rows) {
    const bool rot = r.rotation;
    const double s = rot ? 180.0 / M_PI : 1.0;
    std::snprintf(line, sizeof line, "%-28s %14.7g %11.4g %14.7g %11.4g %11.3g %7.2f%s%s\n",
                  r.parameter.c_str(), r.spline * s, r.sigma_spline * s, r.discrete * s,
                  r.sigma_discrete * s, r.difference * s, r.ratio, rot ? " deg" : "",
                  r.flagged ? "  <-- flagged" : "");
    os << line;
  }
  os << check.flagged.size() << " of " << check.rows.size()
     << " parameters differ by more than the smaller sigma";
  for (const std::string& n : check.flagged)
    os << (n == check.flagged.front() ? ": " : ", ") << n;
  os << '\n';
  return os.str();
}

}  // namespace ctcal
