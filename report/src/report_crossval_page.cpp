// The report's cross-validation section (docs/cross_validation.md): the subsets' results that
// `ctcal calibrate` keeps in OUT/crossval/subset_<k>.yaml, compared again here with the full
// calibration's formal sigma (sensors/crossval.h CrossValidateNested) so that `ctcal report`
// redraws it from the files alone: the verdict, z per parameter coloured by sensor, the groups'
// tests and the model error the reported sigma carries.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>

#include "ctcal/sensors/crossval.h"
#include "ctcal/sensors/rig_yaml.h"
#include "report_builder.h"

namespace ctcal::report::detail {

namespace fs = std::filesystem;

namespace {

// OUT/crossval/subset_1.yaml, subset_2.yaml, ... while they exist.
std::vector<std::string> SubsetPaths(const std::string& out_dir) {
  std::vector<std::string> paths;
  for (int k = 1;; ++k) {
    const fs::path p = fs::path(out_dir) / "crossval" / ("subset_" + std::to_string(k) + ".yaml");
    if (!fs::exists(p))
      return paths;
    paths.push_back(p.string());
  }
}

std::string Fixed(double x, const char* format = "%.2f") {
  char b[32];
  std::snprintf(b, sizeof b, format, x);
  return b;
}

}  // namespace

Section Builder::CrossValidationSection() {
  Section sec("sec-crossval", "Cross-validation between subsets of the recording");
  const std::vector<std::string> paths = SubsetPaths(out_dir_);
  if (paths.empty()) {
    sec.omitted =
        "no OUT/crossval/subset_*.yaml (calibrate --method spline writes them unless "
        "--no-cross-validate or the recording is too short; its log says which)";
    return sec;
  }
  std::vector<RigConfig> subsets;
  std::vector<std::string> warnings;
  for (const std::string& p : paths)
    subsets.push_back(LoadRig(p, &warnings));
  // The full calibration as the subsets were compared with it: its formal sigma.
  RigConfig formal = rig_;
  for (SensorConfig& sc : formal.sensors) {
    if (!sc.sigma_formal.empty())
      sc.sigma = sc.sigma_formal;
  }
  const CrossValidation cv = CrossValidateNested(formal, subsets, paths);
  const CrossValSummary& s = cv.summary;
  const bool pair = cv.num_results == 2;

  std::ostringstream h;
  h << "<p>" << cv.num_results << " subsets of interleaved blocks of the recording; subsets 1 .. "
    << paths.size() << " calibrated alone from the full calibration's values and compared with it. "
    << (pair ? "z = (x_subset - x_full) / sqrt(sigma_subset^2 - sigma_full^2), the z of "
               "subset 1 against subset 2 (the rest of the full calibration),"
             : "sqrt(r) = sqrt(mean over subsets of (x_k - x_full)^2 / (sigma_k^2 - "
               "sigma_full^2))")
    << " should be ~1; where a group's chi-square test (1 % false alarm over all groups) or the "
       "whole rig's fails, each group's model error (its mean ratio - 1) is added to the reported "
       "sigma (sigma_formal keeps the formal one).</p>\n";
  const std::string verdict =
      s.passed ? "PASS: the subsets agree within their sigmas"
      : s.groups_failed > 0
          ? "MODEL ERROR: " + std::to_string(s.groups_failed) +
                " group(s) disagree beyond their sigmas; the reported sigma includes it"
          : "MODEL ERROR: the rig as a whole disagrees beyond its sigmas; the reported sigma "
            "includes it";
  h << "<p><b>" << Escape(verdict) << "</b>";
  if (s.rms_z)
    h << " (" << Fixed(100.0 * *s.fraction_within_3_sigma, "%.0f") << " % with |z| < 3, rms z "
      << Fixed(*s.rms_z) << ", worst " << Escape(*s.worst_name) << " at " << Fixed(*s.worst_z)
      << ")";
  h << "</p>\n";

  std::vector<std::vector<std::string>> groups = {
      {"group", "dof", "statistic", "limit", "test", "model error ratio", "sigma / formal"}};
  for (const CrossValGroup& g : cv.groups) {
    if (g.count == 0)
      continue;
    // How much the reported sigma grew: the mean ratio over the group's rows in result.yaml.
    double ratio_sum = 0.0;
    int n = 0;
    for (const CrossValRow& row : cv.rows) {
      const std::optional<ScalarParameter> p = FindParameter(rig_, row.name);
      const SensorConfig* sc = p ? rig_.Find(p->sensor) : nullptr;
      if (row.group != g.name || !sc || sc->sigma_formal.empty())
        continue;
      const std::vector<double>* f0 = sc->sigma_formal.Find(p->key);
      const std::vector<double>* sigma = sc->sigma.Find(p->key);
      const auto i = static_cast<std::size_t>(std::max(0, p->index));
      if (f0 && sigma && i < f0->size() && (*f0)[i] > 0.0 && std::isfinite((*f0)[i])) {
        ratio_sum += (*sigma)[i] / (*f0)[i];
        ++n;
      }
    }
    groups.push_back({g.name, std::to_string(g.dof), Fixed(g.statistic), Fixed(g.threshold),
                      g.passed ? "pass" : "FAIL", Fixed(g.model_ratio),
                      n ? Fixed(ratio_sum / n) : "1.00"});
  }
  h << HtmlTable(groups);

  auto f = NewFigure("fig-crossval", "Cross-validation: " + verdict, 1, 1);
  auto& p = f->Add<XYPlot>();
  p.title = pair ? "z per parameter: subset 1 against the rest of the recording"
                 : "sqrt(r) per parameter: the subsets against the full calibration";
  p.x_label = "parameter (result.yaml order)";
  p.y_label = pair ? "z" : "sqrt(r)";
  std::map<std::string, int> sensor_index;
  std::map<std::string, std::pair<std::vector<double>, std::vector<double>>> points;
  for (std::size_t i = 0; i < cv.rows.size(); ++i) {
    const CrossValRow& row = cv.rows[i];
    if (!row.z)
      continue;
    sensor_index.emplace(row.sensor, static_cast<int>(sensor_index.size()));
    points[row.sensor].first.push_back(static_cast<double>(i));
    points[row.sensor].second.push_back(*row.z);
  }
  for (const auto& [sensor, xy] : points)
    p.Scatter(xy.first, xy.second, sensor, PaletteColor(sensor_index[sensor]), 3.0);
  p.HLine(3.0, "+-3", kFail);
  if (pair)
    p.HLine(-3.0, "", kFail);
  sec.figures.push_back(f);

  std::vector<std::vector<std::string>> rows = {
      {"parameter", "group", pair ? "subset - full" : "rms(subset - full)", "sigma_formal (full)",
       "sigma (subsets)", pair ? "z" : "sqrt(r)"}};
  for (const CrossValRow& row : cv.rows) {
    rows.push_back({row.name, row.group, FormatNumber(row.difference, 4),
                    FormatNumber(row.sigmas.front(), 3),
                    FormatNumber(std::sqrt(row.subset_variance), 3), row.z ? Fixed(*row.z) : "-"});
  }
  h << HtmlTable(rows);
  TablePages(&sec, "fig-crossval-table", "Cross-validation per parameter", rows, 26);
  sec.html = h.str();
  return sec;
}

}  // namespace ctcal::report::detail
