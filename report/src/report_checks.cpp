// The first page's checks (report.h): status names, coverage, the pass / warn / fail rules.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <string>
#include <vector>

#include "ctcal/report/report.h"
#include "ctcal/report/verdict.h"
#include "report_format.h"

namespace ctcal::report {
using namespace detail;  // NOLINT(build/namespaces): report_format.h's helpers

std::string ToString(Status s) {
  switch (s) {
    case Status::kPass:
      return "PASS";
    case Status::kWarn:
      return "WARN";
    case Status::kFail:
      return "FAIL";
    default:
      return "N/A";
  }
}

double Coverage(const std::vector<CornerResidual>& corners, int width, int height, int cells) {
  if (width <= 0 || height <= 0 || cells <= 0)
    return kNaN;
  std::vector<bool> hit(static_cast<size_t>(cells) * cells, false);
  for (const auto& c : corners) {
    if (c.outlier || !std::isfinite(c.u) || !std::isfinite(c.v))
      continue;
    const int x = static_cast<int>(std::floor((c.u + 0.5) / width * cells));
    const int y = static_cast<int>(std::floor((c.v + 0.5) / height * cells));
    if (x >= 0 && x < cells && y >= 0 && y < cells)
      hit[static_cast<size_t>(y) * cells + x] = true;
  }
  return static_cast<double>(std::count(hit.begin(), hit.end(), true)) / hit.size();
}

std::vector<Check> EvaluateChecks(const RigConfig& result, const ReportData& data,
                                  const CheckThresholds& th) {
  std::vector<Check> out;
  char crit[128];
  for (const SensorConfig& s : result.sensors) {
    const auto it = result.residuals.find(s.name);
    Check c;
    c.name = "whitened RMS";
    c.sensor = s.name;
    std::snprintf(crit, sizeof(crit), "~1: pass in [%.2f, %.2f], warn in [%.2f, %.2f]",
                  1 / th.whitened_pass, th.whitened_pass, 1 / th.whitened_warn, th.whitened_warn);
    c.criterion = crit;
    if (it == result.residuals.end() || !it->second.rms_whitened) {
      c.value = "not in result.yaml";
    } else {
      const double w = *it->second.rms_whitened;
      c.value = FormatNumber(w, 3);
      const double r = std::max(w, 1 / w);
      c.status = !std::isfinite(w) || !(w > 0) ? Status::kFail
                 : r <= th.whitened_pass       ? Status::kPass
                 : r <= th.whitened_warn       ? Status::kWarn
                                               : Status::kFail;
    }
    out.push_back(c);
  }
  for (const SensorConfig& s : result.sensors) {
    if (s.IsInertial())
      continue;
    const auto res = result.residuals.find(s.name);
    out.push_back(
        PixelRmsCheck(s, res == result.residuals.end() ? std::nullopt : res->second.rms_px));
    const auto it = data.corners.find(s.name);
    Check o;
    o.name = "outlier fraction";
    o.sensor = s.name;
    std::snprintf(crit, sizeof(crit), "pass <= %.0f%%, warn <= %.0f%%", 100 * th.outlier_pass,
                  100 * th.outlier_warn);
    o.criterion = crit;
    Check cov;
    cov.name = "coverage";
    cov.sensor = s.name;
    std::snprintf(
        crit, sizeof(crit), "image cells (%dx%d) with corners: pass >= %.0f%%, warn >= %.0f%%",
        th.coverage_cells, th.coverage_cells, 100 * th.coverage_pass, 100 * th.coverage_warn);
    cov.criterion = crit;
    if (it == data.corners.end() || it->second.empty()) {
      o.value = cov.value = "no corner data";
    } else {
      const auto& c = it->second;
      const double f = static_cast<double>(std::count_if(
                           c.begin(), c.end(), [](const CornerResidual& r) { return r.outlier; })) /
                       c.size();
      char buf[64];
      std::snprintf(buf, sizeof(buf), "%.2f%% of %zu", 100 * f, c.size());
      o.value = buf;
      o.status = f <= th.outlier_pass   ? Status::kPass
                 : f <= th.outlier_warn ? Status::kWarn
                                        : Status::kFail;
      const double k = Coverage(c, s.width, s.height, th.coverage_cells);
      std::snprintf(buf, sizeof(buf), "%.0f%%", 100 * k);
      cov.value = std::isfinite(k) ? buf : "no resolution";
      cov.status = !std::isfinite(k)       ? Status::kUnknown
                   : k >= th.coverage_pass ? Status::kPass
                   : k >= th.coverage_warn ? Status::kWarn
                                           : Status::kFail;
    }
    out.push_back(o);
    out.push_back(cov);
  }
  Check obs;
  obs.name = "observability";
  obs.criterion = "fail: an unobservable parameter; warn: a weak one";
  if (!result.observability) {
    obs.value = "not analysed";
  } else {
    const auto& o = *result.observability;
    // The names themselves, so that the first page says what to fix (up to three of each).
    const auto names = [](const std::vector<std::string>& v) {
      std::string s;
      for (std::size_t i = 0; i < v.size() && i < 3; ++i)
        s += (i ? ", " : " (") + v[i];
      return v.empty() ? s : s + (v.size() > 3 ? ", ...)" : ")");
    };
    obs.value = std::to_string(o.unobservable.size()) + " unobservable" + names(o.unobservable) +
                ", " + std::to_string(o.weak.size()) + " weak" + names(o.weak);
    obs.status = !o.unobservable.empty() ? Status::kFail
                 : !o.weak.empty()       ? Status::kWarn
                                         : Status::kPass;
  }
  out.push_back(obs);
  return out;
}

}  // namespace ctcal::report
