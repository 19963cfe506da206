// The report's first pages: the ten-second summary (checks, parameters, Kalibr lines), the
// parameters' table and the Kalibr matrices.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "ctcal/sensors/kalibr_files.h"
#include "ctcal/sensors/parameter_names.h"
#include "ctcal/sensors/rig_yaml.h"

#include "report_builder.h"

namespace ctcal::report::detail {

// The first page's grid: checks on top, parameters (left) and Kalibr lines (right) below.
constexpr int kSummaryRows = 24, kSummaryCols = 20, kSummaryParamCols = 13;

// The first page (issue 10), what a factory engineer reads in ten seconds: the verdict and
// every check, every calibrated quantity with its 1-sigma in engineering units, and the Kalibr
// transformations and time shifts ready to paste.
Section Builder::Summary(const std::vector<Check>& checks) {
  Section sec("sec-summary", "Summary: pass / warn / fail");
  std::ostringstream h;
  int fails = 0, warns = 0;
  for (const Check& c : checks) {
    fails += c.status == Status::kFail;
    warns += c.status == Status::kWarn;
  }
  const Status overall = fails ? Status::kFail : warns ? Status::kWarn : Status::kPass;
  const std::string verdict = ToString(overall) + ": " + std::to_string(fails) + " failed, " +
                              std::to_string(warns) + " warnings, " +
                              std::to_string(checks.size()) + " checks";
  h << "<p class=\"verdict\" style=\"background:" << CssColor(StatusColor(overall)) << "\">"
    << verdict << "</p>\n<table class=\"checks\"><tr><th>status</th><th>check</th>"
    << "<th>sensor</th><th>value</th><th>criterion</th></tr>";
  auto fig = std::make_shared<Figure>(kSummaryRows, kSummaryCols, kPageW, kPageH);
  fig->id = "fig-summary";
  fig->title = "Calibration summary: " + verdict;
  auto& t = fig->Add<Table>();
  t.font_size = 9;
  t.min_font_size = 5.5;
  t.AddRow({"status", "check", "sensor", "value", "criterion"});
  for (const Check& c : checks) {
    h << "<tr><td class=\"status\" style=\"background:" << CssColor(StatusColor(c.status)) << "\">"
      << ToString(c.status) << "</td><td>" << Escape(c.name) << "</td><td>" << Escape(c.sensor)
      << "</td><td>" << Escape(c.value) << "</td><td>" << Escape(c.criterion) << "</td></tr>";
    t.AddRow({ToString(c.status), c.name, c.sensor, c.value, c.criterion});
    t.rows.back()[0].has_fill = true;
    t.rows.back()[0].fill = StatusColor(c.status);
  }
  h << "</table>\n";
  // The checks take the rows they need (9 pt rows of 1.65 em, a little for the frame).
  const double cell_h = (kPageH - 36.0) / kSummaryRows;
  const int check_rows =
      std::clamp(static_cast<int>(std::ceil((1.65 * 9.0 * (checks.size() + 1) + 8.0) / cell_h)), 3,
                 kSummaryRows / 2);
  fig->SetSpan(0, check_rows, kSummaryCols);

  const std::vector<std::vector<std::string>> params = ParameterSummaryRows();
  auto& pt = fig->Add<Table>();
  pt.title = "calibrated parameters (value +- 1 sigma)";
  pt.font_size = 8;
  pt.min_font_size = 5.5;
  for (const auto& r : params)
    pt.AddRow(r);
  fig->SetSpan(1, kSummaryRows - check_rows, kSummaryParamCols);
  if (params.size() > 1) {
    h << "<h3>Calibrated parameters (value &plusmn; 1 sigma; every scalar in "
      << "<a href=\"#sec-parameters\">the parameter table</a>)</h3>" << HtmlTable(params, "params");
  }

  const std::vector<std::vector<std::string>> noise = NoiseRows();
  if (noise.size() > 1) {
    h << "<h3>Noise: stated vs estimated from the data (the estimate weighs the solve; "
      << "ctcal's docs/noise_estimation.md)</h3>" << HtmlTable(noise);
  }

  const std::vector<std::string> kalibr = KalibrPasteLines();
  auto& kt = fig->Add<TextPanel>();
  kt.title = "Kalibr (camchain-imucam.yaml / imu.yaml)";
  kt.monospace = true;
  kt.font_size = 7.5;
  kt.min_font_size = 4.5;
  kt.lines = kalibr.empty() ? std::vector<std::string>{"(no Kalibr transformation)"} : kalibr;
  fig->SetSpan(2, kSummaryRows - check_rows, kSummaryCols - kSummaryParamCols);
  if (!kalibr.empty()) {
    std::string text;
    for (const auto& l : kalibr)
      text += l + "\n";
    h << "<h3>Kalibr transformations and time shifts, ready to paste (the whole files in "
      << "<a href=\"#sec-kalibr\">Kalibr files</a>)</h3><pre class=\"paste\">" << Escape(text)
      << "</pre>\n";
  }
  sec.html = h.str();
  sec.figures.push_back(fig);
  return sec;
}

std::vector<std::vector<std::string>> Builder::NoiseRows() const {
  std::vector<std::vector<std::string>> rows = {
      {"sensor", "quantity", "stated", "estimated", "estimated / stated"}};
  const auto add = [&](const std::string& sensor, const std::string& key, double stated,
                       double estimated) {
    rows.push_back({sensor, key, FormatNumber(stated, 4), FormatNumber(estimated, 4),
                    stated > 0.0 ? FormatNumber(estimated / stated, 3) : "-"});
  };
  for (const SensorConfig& s : rig_.sensors) {
    if (s.type == SensorType::kCamera) {
      if (s.pixel_sigma_estimated)
        add(s.name, "pixel_sigma [px]", s.pixel_sigma, *s.pixel_sigma_estimated);
      continue;
    }
    if (!s.noise_estimated)
      continue;
    add(s.name, "gyroscope_noise_density", s.noise.gyroscope_noise_density,
        s.noise_estimated->gyroscope_noise_density);
    if (s.type == SensorType::kImu)
      add(s.name, "accelerometer_noise_density", s.noise.accelerometer_noise_density,
          s.noise_estimated->accelerometer_noise_density);
  }
  return rows;
}

// One row per calibrated quantity (sensor and key): its components as value +- sigma, in the
// units an engineer checks them in: rotations (components of Log R) in deg, lever arms in mm,
// time offsets in ms, line delays in us per row.
std::vector<std::vector<std::string>> Builder::ParameterSummaryRows() const {
  struct Group {
    std::string sensor, key, units;
    std::vector<std::string> cells;
  };
  std::vector<Group> groups;
  for (const ScalarParameter& p : ScalarParameters(rig_, true)) {
    double v = kNaN;
    try {
      v = ParameterValue(rig_, p);
    } catch (const std::exception&) {  // e.g. gravity_W absent from an input-like file
    }
    const std::optional<double> sigma = ParameterSigma(rig_, p);
    double factor = 1.0;
    std::string units = Units(p, rig_);
    if (p.rotation) {
      factor = 180.0 / M_PI;
      units = "deg";
    } else if (p.key == "t_B_S") {
      factor = 1e3;
      units = "mm";
    } else if (p.key == "time_offset") {
      factor = 1e3;
      units = "ms";
    } else if (p.key == "line_delay") {
      factor = 1e6;
      units = "us/row";
    }
    if (groups.empty() || groups.back().sensor != p.sensor || groups.back().key != p.key)
      groups.push_back({p.sensor, p.key, units, {}});
    groups.back().cells.push_back(
        ValueSigma(factor * v, sigma ? std::optional<double>(factor * *sigma) : std::nullopt));
  }
  // At most 4 components a line (a 3x3 matrix: its rows), continuation lines unlabelled.
  std::vector<std::vector<std::string>> rows = {
      {"sensor", "quantity", "units", "value +- 1 sigma"}};
  for (const Group& g : groups) {
    const std::size_t per = g.cells.size() == 9 ? 3 : 4;
    for (std::size_t i = 0; i < g.cells.size(); i += per) {
      std::string line;
      for (std::size_t k = i; k < std::min(g.cells.size(), i + per); ++k)
        line += (k > i ? ",  " : "") + g.cells[k];
      rows.push_back({i                  ? ""
                      : g.sensor.empty() ? "rig"
                                         : g.sensor,
                      i ? "" : g.key, i ? "" : g.units, line});
    }
  }
  return rows;
}

// Kalibr's T_cam_imu and timeshift_cam_imu per camera, T_i_b and time_offset per auxiliary
// IMU, as YAML lines of the files EmitKalibrCamchain / EmitKalibrImu write (kalibr_files.h).
std::vector<std::string> Builder::KalibrPasteLines() const {
  std::vector<std::string> lines;
  const auto matrix = [&](const YAML::Node& m) {
    for (const auto& row : m) {
      std::string l = "    - [";
      for (std::size_t i = 0; i < row.size(); ++i) {
        char buf[32];
        std::snprintf(buf, sizeof buf, "%s%.9f", i ? ", " : "", row[i].as<double>());
        l += buf;
      }
      lines.push_back(l + "]");
    }
  };
  const auto scalar = [](const char* key, double x) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "  %s: %.9f", key, x);
    return std::string(buf);
  };
  try {
    if (rig_.IsCameraOnly())
      return lines;
    const YAML::Node cams = YAML::Load(EmitKalibrCamchain(rig_));
    for (const auto& kv : cams) {
      if (!kv.second["T_cam_imu"])
        continue;
      lines.push_back(kv.first.as<std::string>() + ":");
      lines.push_back("  T_cam_imu:");
      matrix(kv.second["T_cam_imu"]);
      if (kv.second["timeshift_cam_imu"])
        lines.push_back(scalar("timeshift_cam_imu", kv.second["timeshift_cam_imu"].as<double>()));
    }
    const YAML::Node imus = YAML::Load(EmitKalibrImu(rig_));
    bool first = true;
    for (const auto& kv : imus) {
      if (first || !kv.second["T_i_b"]) {  // the base IMU: identity, offset 0
        first = false;
        continue;
      }
      lines.push_back(kv.first.as<std::string>() + ":");
      lines.push_back("  T_i_b:");
      matrix(kv.second["T_i_b"]);
      if (kv.second["time_offset"])
        lines.push_back(scalar("time_offset", kv.second["time_offset"].as<double>()));
    }
  } catch (const std::exception& e) {
    return {std::string("(not available: ") + e.what() + ")"};
  }
  return lines;
}

Section Builder::Parameters() {
  Section sec("sec-parameters", "Calibrated parameters");
  std::vector<std::vector<std::string>> rows = {{"parameter", "value", "sigma", "units"}};
  for (const ScalarParameter& p : ScalarParameters(rig_, true)) {
    double v = kNaN;
    try {
      v = ParameterValue(rig_, p);
    } catch (const std::exception&) {  // e.g. gravity_W absent from an input-like file
    }
    const auto sigma = ParameterSigma(rig_, p);
    rows.push_back(
        {p.name, FormatNumber(v, 8), sigma ? FormatNumber(*sigma, 3) : "-", Units(p, rig_)});
  }
  if (rows.size() == 1) {
    sec.omitted = "the result estimates no parameter";
    return sec;
  }
  sec.html =
      "<p>Rotations are the components of Log(R) (rad); their sigma is that of the left "
      "perturbation R = Exp(dtheta) R_hat (SPEC section 7). sigma .inf: not determined by "
      "the data.</p>\n" +
      HtmlTable(rows, "params");
  TablePages(&sec, "fig-parameters", "Calibrated parameters", rows, 26);
  return sec;
}

Section Builder::KalibrSection() {
  Section sec("sec-kalibr", "Kalibr files (ready to paste)");
  std::string camchain, imu;
  try {
    camchain = EmitKalibrCamchain(rig_);
    if (!rig_.IsCameraOnly())
      imu = EmitKalibrImu(rig_);
  } catch (const std::exception& e) {
    sec.omitted = std::string("the result cannot be written as Kalibr files: ") + e.what();
    return sec;
  }
  const std::string cam_name = rig_.IsCameraOnly() ? "camchain.yaml" : "camchain-imucam.yaml";
  std::ostringstream h;
  h << "<h3>" << cam_name << "</h3><pre>" << Escape(camchain) << "</pre>\n";
  if (!imu.empty())
    h << "<h3>imu.yaml</h3><pre>" << Escape(imu) << "</pre>\n";
  sec.html = h.str();
  const std::vector<std::pair<std::string, std::string>> files = {{cam_name, camchain},
                                                                  {"imu.yaml", imu}};
  for (const auto& [name, text] : files) {
    if (text.empty())
      continue;
    std::vector<std::string> lines;
    std::istringstream s(text);
    for (std::string l; std::getline(s, l);)
      lines.push_back(l);
    const size_t per = 46;
    for (size_t i = 0; i < lines.size(); i += per) {
      auto f = NewFigure("fig-kalibr-" + std::string(name == cam_name ? "camchain" : "imu") +
                             (i ? "-" + std::to_string(i / per + 1) : ""),
                         "Kalibr " + std::string(name), 1, 1);
      auto& t = f->Add<TextPanel>();
      t.monospace = true;
      t.font_size = 8.5;
      t.lines.assign(lines.begin() + i, lines.begin() + std::min(lines.size(), i + per));
      sec.figures.push_back(f);
    }
  }
  return sec;
}

}  // namespace ctcal::report::detail
