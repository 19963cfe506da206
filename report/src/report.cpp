// The report: builds the figures of every section once (plot.h), then writes them into the HTML
// (base64 PNG) and the PDF (vector pages). Sections follow issue 10's order: the ten-second
// summary, parameters, Kalibr matrices, poses, per inertial sensor, per camera, normalised
// residual histograms, correlation, observability, cross-check, configuration.
#include "ctcal/report/report.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "ctcal/report/distortion_field.h"
#include "ctcal/report/plot.h"
#include "ctcal/report/stage_time.h"
#include "ctcal/report/verdict.h"
#include "ctcal/sensors/kalibr_files.h"
#include "ctcal/sensors/parameter_names.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal::report {
namespace {

namespace fs = std::filesystem;
constexpr double kPageW = 842.0, kPageH = 595.0;  // A4 landscape, pt
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kPngScale = 1.25;
// The first page's grid: checks on top, parameters (left) and Kalibr lines (right) below.
constexpr int kSummaryRows = 24, kSummaryCols = 20,
              kSummaryParamCols = 13;  // PNG pixels per pt: the HTML's figures, --png-dir

std::string Escape(const std::string& s) {
  std::string o;
  for (const char c : s) {
    switch (c) {
      case '&':
        o += "&amp;";
        break;
      case '<':
        o += "&lt;";
        break;
      case '>':
        o += "&gt;";
        break;
      case '"':
        o += "&quot;";
        break;
      default:
        o += c;
    }
  }
  return o;
}

std::string Base64(const std::string& in) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const unsigned v = (static_cast<unsigned char>(in[i]) << 16) |
                       (static_cast<unsigned char>(in[i + 1]) << 8) |
                       static_cast<unsigned char>(in[i + 2]);
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += k[(v >> 6) & 63];
    out += k[v & 63];
  }
  if (i < in.size()) {
    unsigned v = static_cast<unsigned char>(in[i]) << 16;
    if (i + 1 < in.size())
      v |= static_cast<unsigned char>(in[i + 1]) << 8;
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += i + 1 < in.size() ? k[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

Color StatusColor(Status s) {
  switch (s) {
    case Status::kPass:
      return kPass;
    case Status::kWarn:
      return kWarn;
    case Status::kFail:
      return kFail;
    default:
      return Color{0.55, 0.55, 0.55};
  }
}

std::string CssColor(const Color& c) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "#%02x%02x%02x", static_cast<int>(c.r * 255),
                static_cast<int>(c.g * 255), static_cast<int>(c.b * 255));
  return buf;
}

double Rms(const std::vector<double>& v) {
  double s = 0;
  int n = 0;
  for (const double x : v) {
    if (std::isfinite(x)) {
      s += x * x;
      ++n;
    }
  }
  return n ? std::sqrt(s / n) : kNaN;
}

// Units of a parameter key (SPEC section 7).
std::string Units(const ScalarParameter& p, const RigConfig& rig) {
  if (p.sensor.empty())
    return "m/s^2";
  if (p.rotation)
    return "rad";
  if (p.key == "t_B_S")
    return "m";
  if (p.key == "time_offset")
    return "s";
  if (p.key == "line_delay")
    return "s/row";
  if (p.key == "Tg")
    return "(rad/s)/(m/s^2)";
  if (p.key == "intrinsics") {
    const SensorConfig* s = rig.Find(p.sensor);
    if (s && s->camera_model == "pinhole")
      return "px";
    return "px or -";
  }
  return "-";
}

// "v +- s" with the sigma to 2 significant digits and the value to the same decimals, a common
// power of ten factored out for very small or large numbers: "458.652 +- 0.021",
// "(1.23 +- 0.45)e-04". Without a sigma: the value to 6 digits; sigma .inf: "+- inf".
std::string ValueSigma(double v, const std::optional<double>& sigma) {
  if (!std::isfinite(v))
    return FormatNumber(v);
  if (!sigma || !(*sigma > 0.0))
    return FormatNumber(v, 6);
  if (!std::isfinite(*sigma))
    return FormatNumber(v, 6) + " +- inf";
  const double mag = std::max(std::abs(v), *sigma);
  int e = 0;
  if (mag < 1e-3 || mag >= 1e5)
    e = static_cast<int>(std::floor(std::log10(mag)));
  const double scale = std::pow(10.0, -e);
  const int decimals =
      std::clamp(1 - static_cast<int>(std::floor(std::log10(*sigma * scale))), 0, 9);
  char buf[96];
  if (e == 0)
    std::snprintf(buf, sizeof buf, "%.*f +- %.*f", decimals, v, decimals, *sigma);
  else
    std::snprintf(buf, sizeof buf, "(%.*f +- %.*f)e%+03d", decimals, v * scale, decimals,
                  *sigma * scale, e);
  return buf;
}

// ------------------------------------------------------------------------------ the document

// One section: HTML body parts and PDF figures in order.
// The image plane of a W x H camera as axes: pixel centres at integers (SPEC section 2), so the
// image spans [-0.5, W - 0.5] x [-0.5, H - 0.5]; v grows downwards and pixels are square.
void ImageAxes(double W, double H, XYPlot* p) {
  p->x_label = "u [px]";
  p->y_label = "v [px]";
  p->equal_aspect = true;
  p->y_down = true;
  p->x_min = -0.5;
  p->x_max = W - 0.5;
  p->y_min = -0.5;
  p->y_max = H - 0.5;
}

void ImageAxes(double W, double H, HeatMap* hm) {
  hm->x_lo = -0.5;
  hm->x_hi = W - 0.5;
  hm->y_lo = -0.5;
  hm->y_hi = H - 0.5;
  hm->x_label = "u [px]";
  hm->y_label = "v [px]";
}

struct Section {
  Section(std::string id_, std::string heading_)
      : id(std::move(id_)), heading(std::move(heading_)) {}
  std::string id, heading;
  std::string html;                              // text, tables (figures are added by id)
  std::vector<std::shared_ptr<Figure>> figures;  // drawn into HTML and PDF
  std::string omitted;                           // non-empty: the section has no data
};

class Builder {
 public:
  Builder(const RigConfig& rig, const ReportData& data, const ReportOptions& opt,
          const std::string& out_dir)
      : rig_(rig), data_(data), opt_(opt), out_dir_(out_dir) {
    std::int64_t t0 = INT64_MAX;
    for (const auto& [s, c] : data.corners)
      if (!c.empty())
        t0 = std::min(t0, c.front().t_ns);
    for (const auto& [s, g] : data.gyro)
      if (!g.empty())
        t0 = std::min(t0, g.front().t_ns);
    if (!data.trajectory.empty())
      t0 = std::min(t0, data.trajectory.front().t_ns);
    t0_ = t0 == INT64_MAX ? 0 : t0;
  }

  double Sec(std::int64_t t_ns) const { return 1e-9 * static_cast<double>(t_ns - t0_); }

  std::vector<Section> Build(const std::vector<Check>& checks, const std::string& crosscheck) {
    std::vector<Section> out;
    out.push_back(Summary(checks));
    out.push_back(Parameters());
    out.push_back(KalibrSection());
    out.push_back(TrajectorySection());
    for (const SensorConfig& s : rig_.sensors) {
      if (s.IsInertial())
        out.push_back(InertialSection(s));
    }
    for (const SensorConfig& s : rig_.sensors) {
      if (!s.IsInertial())
        out.push_back(CameraSection(s));
    }
    out.push_back(Histograms());
    out.push_back(CorrelationSection());
    out.push_back(ObservabilitySection());
    out.push_back(CrosscheckSection(crosscheck));
    out.push_back(ConfigSection());
    return out;
  }

 private:
  static std::shared_ptr<Figure> NewFigure(const std::string& id, const std::string& title,
                                           int rows, int cols) {
    auto f = std::make_shared<Figure>(rows, cols, kPageW, kPageH);
    f->id = id;
    f->title = title;
    return f;
  }

  static std::string HtmlTable(const std::vector<std::vector<std::string>>& rows,
                               const std::string& cls = "") {
    std::ostringstream h;
    h << "<table" << (cls.empty() ? "" : " class=\"" + cls + "\"") << ">";
    for (size_t r = 0; r < rows.size(); ++r) {
      h << "<tr>";
      for (const auto& c : rows[r])
        h << (r == 0 ? "<th>" : "<td>") << Escape(c) << (r == 0 ? "</th>" : "</td>");
      h << "</tr>";
    }
    h << "</table>\n";
    return h.str();
  }

  // Table pages for the PDF, `per_page` rows each (the header repeats).
  static void TablePages(Section* sec, const std::string& id, const std::string& title,
                         const std::vector<std::vector<std::string>>& rows, int per_page,
                         bool monospace = false) {
    for (size_t start = 1, page = 0; start < rows.size(); start += per_page, ++page) {
      auto f = NewFigure(id + (page ? "-" + std::to_string(page + 1) : ""), title, 1, 1);
      auto& t = f->Add<Table>();
      t.AddRow(rows[0]);
      for (size_t r = start; r < std::min(rows.size(), start + per_page); ++r) {
        t.AddRow(rows[r]);
        for (auto& cell : t.rows.back())
          cell.monospace = monospace;
      }
      sec->figures.push_back(f);
    }
  }

  // The first page (issue 10), what a factory engineer reads in ten seconds: the verdict and
  // every check, every calibrated quantity with its 1-sigma in engineering units, and the Kalibr
  // transformations and time shifts ready to paste.
  Section Summary(const std::vector<Check>& checks) {
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
      h << "<tr><td class=\"status\" style=\"background:" << CssColor(StatusColor(c.status))
        << "\">" << ToString(c.status) << "</td><td>" << Escape(c.name) << "</td><td>"
        << Escape(c.sensor) << "</td><td>" << Escape(c.value) << "</td><td>" << Escape(c.criterion)
        << "</td></tr>";
      t.AddRow({ToString(c.status), c.name, c.sensor, c.value, c.criterion});
      t.rows.back()[0].has_fill = true;
      t.rows.back()[0].fill = StatusColor(c.status);
    }
    h << "</table>\n";
    // The checks take the rows they need (9 pt rows of 1.65 em, a little for the frame).
    const double cell_h = (kPageH - 36.0) / kSummaryRows;
    const int check_rows =
        std::clamp(static_cast<int>(std::ceil((1.65 * 9.0 * (checks.size() + 1) + 8.0) / cell_h)),
                   3, kSummaryRows / 2);
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
        << "<a href=\"#sec-parameters\">the parameter table</a>)</h3>"
        << HtmlTable(params, "params");
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

  // One row per calibrated quantity (sensor and key): its components as value +- sigma, in the
  // units an engineer checks them in: rotations (components of Log R) in deg, lever arms in mm,
  // time offsets in ms, line delays in us per row.
  std::vector<std::vector<std::string>> ParameterSummaryRows() const {
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
  std::vector<std::string> KalibrPasteLines() const {
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

  Section Parameters() {
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

  Section KalibrSection() {
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

  Section TrajectorySection() {
    Section sec("sec-trajectory", "Estimated poses in 3-D");
    if (data_.trajectory.empty()) {
      sec.omitted = rig_.IsCameraOnly()
                        ? "a camera-only rig has one board pose per frame, no trajectory"
                        : "no trajectory (report_data/trajectory.csv absent)";
      return sec;
    }
    auto f = NewFigure("fig-trajectory", "Base IMU trajectory T_W_B", 1, 2);
    for (const bool oblique : {true, false}) {
      auto& v = f->Add<Trajectory3D>();
      // Top-down: azimuth -90 deg puts world x to the right and y up on the page.
      v.azimuth_deg = oblique ? -60.0 : -90.0;
      v.elevation_deg = oblique ? 25.0 : 90.0;
      v.title = oblique ? "oblique view" : "top-down view (x right, y up)";
      for (const auto& p : data_.trajectory) {
        v.p_W.push_back(p.p_W_B);
        v.R_W.push_back(p.q_W_B.normalized().toRotationMatrix());
        v.t.push_back(Sec(p.t_ns));
      }
      v.triad_every = std::max<int>(1, static_cast<int>(data_.trajectory.size() / 40));
    }
    sec.figures.push_back(f);
    return sec;
  }

  // Predicted vs measured, their error with the +-3 sigma white-noise bound, per axis.
  void InertialFigures(Section* sec, const SensorConfig& s, const std::vector<InertialSample>& d,
                       const std::string& part, const std::string& unit, double sigma) {
    const char* axes = "xyz";
    auto f = NewFigure("fig-" + s.name + "-" + part,
                       s.name + ": " + part + " predicted vs measured [" + unit + "]", 3, 1);
    auto e = NewFigure("fig-" + s.name + "-" + part + "-error",
                       s.name + ": " + part + " error (measured - predicted) with +-3 sigma noise",
                       3, 1);
    std::vector<double> t;
    for (const auto& r : d)
      t.push_back(Sec(r.t_ns));
    for (int a = 0; a < 3; ++a) {
      std::vector<double> m, p, err;
      for (const auto& r : d) {
        m.push_back(r.meas[a]);
        p.push_back(r.pred[a]);
        err.push_back(r.meas[a] - r.pred[a]);
      }
      auto& pl = f->Add<XYPlot>();
      pl.title = std::string(1, axes[a]) + " axis";
      pl.y_label = unit;
      if (a == 2)
        pl.x_label = "time [s]";
      pl.Line(t, m, "measured", PaletteColor(0), 1.0);
      pl.Line(t, p, "predicted", PaletteColor(1), 1.0);
      auto& pe = e->Add<XYPlot>();
      pe.title = std::string(1, axes[a]) + " axis";
      pe.y_label = unit;
      if (a == 2)
        pe.x_label = "time [s]";
      if (std::isfinite(sigma) && sigma > 0 && !t.empty()) {
        pe.Band({t.front(), t.back()}, {-3 * sigma, -3 * sigma}, {3 * sigma, 3 * sigma},
                "+-3 sigma noise", PaletteColor(2));
      }
      pe.Line(t, err, "error", PaletteColor(3), 0.8);
    }
    sec->figures.push_back(f);
    sec->figures.push_back(e);
  }

  Section InertialSection(const SensorConfig& s) {
    Section sec("sec-imu-" + s.name, "Inertial sensor " + s.name + " (" + ToString(s.type) + ")");
    const auto g = data_.gyro.find(s.name);
    const auto a = data_.accel.find(s.name);
    const auto b = data_.bias.find(s.name);
    if (g == data_.gyro.end() && a == data_.accel.end() && b == data_.bias.end()) {
      sec.omitted = "no inertial data for " + s.name + " in report_data/";
      return sec;
    }
    // Sample intervals: a dropped sample or a jittery clock is visible at once.
    const auto& stamps = g != data_.gyro.end() ? g->second : a->second;
    if (g != data_.gyro.end() || a != data_.accel.end()) {
      auto f = NewFigure("fig-" + s.name + "-intervals", s.name + ": sample intervals", 1, 2);
      std::vector<double> t, dt;
      for (size_t i = 1; i < stamps.size(); ++i) {
        t.push_back(Sec(stamps[i].t_ns));
        dt.push_back(1e3 * 1e-9 * static_cast<double>(stamps[i].t_ns - stamps[i - 1].t_ns));
      }
      auto& p = f->Add<XYPlot>();
      p.title = "interval over time";
      p.x_label = "time [s]";
      p.y_label = "dt [ms]";
      p.Scatter(t, dt, "", PaletteColor(0), 1.2);
      if (s.noise.update_rate > 0)
        p.HLine(1e3 / s.noise.update_rate, "1 / update_rate", PaletteColor(3));
      auto& h = f->Add<XYPlot>();
      h.title = "interval histogram";
      h.x_label = "dt [ms]";
      h.y_label = "density";
      double lo = INFINITY, hi = -INFINITY;
      for (const double x : dt) {
        lo = std::min(lo, x);
        hi = std::max(hi, x);
      }
      if (hi > lo)
        h.Histogram(dt, 40, lo, hi, "", PaletteColor(0));
      else if (!dt.empty())
        h.Histogram(dt, 1, lo - 0.5, lo + 0.5, "", PaletteColor(0));
      sec.figures.push_back(f);
    }
    if (g != data_.gyro.end())
      InertialFigures(&sec, s, g->second, "gyro", "rad/s", s.noise.GyroSampleSigma());
    if (a != data_.accel.end())
      InertialFigures(&sec, s, a->second, "accel", "m/s^2", s.noise.AccelSampleSigma());
    if (b != data_.bias.end()) {
      const bool both = !b->second.gyro.empty() && !b->second.accel.empty();
      auto f =
          NewFigure("fig-" + s.name + "-bias",
                    s.name + ": bias estimates with +-3 sigma random-walk envelopes from the start",
                    both ? 2 : 1, 3);
      for (const auto* part : {&b->second.gyro, &b->second.accel}) {
        if (part->empty())
          continue;
        const bool gyro = part == &b->second.gyro;
        for (int ax = 0; ax < 3; ++ax) {
          // The random-walk envelope opens from the bias at the track's start
          // (report_data.h): where the stated random walk lets the true bias wander.
          std::vector<double> t, v, lo, hi;
          const double b0 = part->front().b[ax];
          for (const auto& r : *part) {
            t.push_back(Sec(r.t_ns));
            v.push_back(r.b[ax]);
            lo.push_back(b0 - 3 * r.sigma[ax]);
            hi.push_back(b0 + 3 * r.sigma[ax]);
          }
          auto& p = f->Add<XYPlot>();
          p.title = std::string(gyro ? "gyro " : "accel ") + "xyz"[ax];
          p.x_label = "time [s]";
          p.y_label = gyro ? "rad/s" : "m/s^2";
          p.legend = ax == 0;
          p.Band(t, lo, hi, "+-3 sigma random walk", PaletteColor(gyro ? 0 : 1));
          p.Line(t, v, "bias", PaletteColor(gyro ? 0 : 1), 1.5);
        }
      }
      sec.figures.push_back(f);
    }
    return sec;
  }

  // Distortion field (distortion_field.h): arrows from the reference lens's pixel to the model's
  // pixel of the same ray, and the displacement's magnitude over the image.
  void DistortionFigure(Section* sec, const SensorConfig& s) const {
    DistortionField d;
    try {
      d = ComputeDistortionField(s);
    } catch (const std::exception& e) {
      sec->html += "<p class=\"note\">distortion field not drawn: " + Escape(e.what()) + "</p>\n";
      return;
    }
    if (d.model_uv.empty()) {
      sec->html += "<p class=\"note\">no distortion field: " + s.camera_model + " with " +
                   s.distortion_model + " distortion is the ideal pinhole.</p>\n";
      return;
    }
    const double W = s.width, H = s.height;
    // Arrows scaled so that the longest spans a grid cell; the scale is in the title.
    const double scale = d.max_magnitude > 0 ? (W / 16.0) / d.max_magnitude : 1.0;
    std::vector<double> x0, y0, dx, dy;
    for (std::size_t i = 0; i < d.model_uv.size(); ++i) {
      x0.push_back(d.reference_uv[i].x());
      y0.push_back(d.reference_uv[i].y());
      dx.push_back(scale * (d.model_uv[i].x() - d.reference_uv[i].x()));
      dy.push_back(scale * (d.model_uv[i].y() - d.reference_uv[i].y()));
    }
    auto f = NewFigure("fig-" + s.name + "-distortion",
                       s.name + ": distortion field vs " + d.reference + ", max " +
                           FormatNumber(d.max_magnitude, 3) + " px",
                       1, 2);
    auto& p = f->Add<XYPlot>();
    p.title = "reference -> model pixel, arrows x" + FormatNumber(scale, 3);
    ImageAxes(W, H, &p);
    p.Arrows(x0, y0, dx, dy, PaletteColor(0));
    auto& hm = f->Add<HeatMap>();
    hm.title = "|displacement| (grey: outside the model's field of view)";
    hm.values = d.magnitude;
    ImageAxes(W, H, &hm);
    hm.value_label = "px";
    sec->html += "<p class=\"note\">Distortion field: the reference is " + Escape(d.reference) +
                 ", focal " + FormatNumber(d.focal.x(), 5) + " / " + FormatNumber(d.focal.y(), 5) +
                 " px, principal point " + FormatNumber(d.principal_point.x(), 5) + ", " +
                 FormatNumber(d.principal_point.y(), 5) + " px.</p>\n";
    if (p.HasData())
      sec->figures.push_back(f);
  }

  Section CameraSection(const SensorConfig& s) {
    Section sec("sec-camera-" + s.name,
                "Camera " + s.name + " (" + s.camera_model + ", " + s.distortion_model + ")");
    const auto it = data_.corners.find(s.name);
    if (it == data_.corners.end()) {
      sec.omitted = "no corner residuals for " + s.name + " in report_data/";
      return sec;
    }
    const auto& c = it->second;
    std::vector<double> du, dv, frame, u, v, ou, ov;
    std::map<int, std::pair<double, std::pair<double, int>>> per_frame;  // t, (sum sq, n)
    for (const auto& r : c) {
      if (r.outlier) {
        ou.push_back(r.u);
        ov.push_back(r.v);
        continue;
      }
      du.push_back(r.du);
      dv.push_back(r.dv);
      frame.push_back(r.frame);
      u.push_back(r.u);
      v.push_back(r.v);
      auto& pf = per_frame[r.frame];
      pf.first = Sec(r.t_ns);
      pf.second.first += r.du * r.du + r.dv * r.dv;
      pf.second.second += 1;
    }
    const double W = s.width > 0 ? s.width : 1, H = s.height > 0 ? s.height : 1;
    {
      auto f = NewFigure("fig-" + s.name + "-residuals", s.name + ": reprojection errors", 1, 2);
      auto& p = f->Add<XYPlot>();
      p.title = "errors coloured by image index (inliers)";
      p.x_label = "du [px]";
      p.y_label = "dv [px]";
      p.value_label = "image index";
      p.equal_aspect = true;
      p.ScatterByValue(du, dv, frame, 1.6);
      auto& t = f->Add<XYPlot>();
      t.title = "per-image RMS over time (per coordinate)";
      t.x_label = "time [s]";
      t.y_label = "RMS [px]";
      std::vector<double> ft, fr;
      for (const auto& [k, pf] : per_frame) {
        ft.push_back(pf.first);
        fr.push_back(std::sqrt(pf.second.first / (2.0 * std::max(pf.second.second, 1))));
      }
      t.Line(ft, fr, "", PaletteColor(0), 1.0);
      t.Scatter(ft, fr, "", PaletteColor(0), 1.8);
      // What a frame's RMS scatters about when the stated noise holds.
      if (s.pixel_sigma > 0)
        t.HLine(s.pixel_sigma, "pixel_sigma", PaletteColor(3));
      sec.figures.push_back(f);
    }
    {
      auto f = NewFigure("fig-" + s.name + "-image", s.name + ": over the image", 1, 2);
      auto& cov = f->Add<XYPlot>();
      cov.title = "coverage (" + std::to_string(ou.size()) + " outliers removed, red)";
      ImageAxes(W, H, &cov);
      cov.value_label = "image index";
      cov.ScatterByValue(u, v, frame, 1.2);
      if (!ou.empty())
        cov.Scatter(ou, ov, "outliers", kFail, 2.5);
      // Mean error magnitude per cell.
      const int nx = 16, ny = std::max(1, static_cast<int>(std::round(16 * H / W)));
      Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(ny, nx), n = sum;
      for (size_t i = 0; i < u.size(); ++i) {
        const int cx = std::clamp(static_cast<int>((u[i] + 0.5) / W * nx), 0, nx - 1);
        const int cy = std::clamp(static_cast<int>((v[i] + 0.5) / H * ny), 0, ny - 1);
        sum(cy, cx) += std::hypot(du[i], dv[i]);
        n(cy, cx) += 1;
      }
      auto& hm = f->Add<HeatMap>();
      hm.title = "mean |error| per cell (grey: no corners)";
      hm.values = (n.array() > 0).select(sum.array() / n.array(), kNaN);
      ImageAxes(W, H, &hm);
      hm.value_label = "px";
      sec.figures.push_back(f);
    }
    DistortionFigure(&sec, s);
    std::ostringstream h;
    h << "<p>" << c.size() << " corners in " << per_frame.size() << " images, " << ou.size()
      << " outliers; inlier RMS " << FormatNumber(Rms(du), 3) << " / " << FormatNumber(Rms(dv), 3)
      << " px (u / v).</p>\n";
    sec.html = h.str() + sec.html;
    return sec;
  }

  Section Histograms() {
    Section sec("sec-histograms", "Normalised residuals against N(0,1)");
    struct H {
      std::string name;
      std::vector<double> values;
    };
    std::vector<H> hs;
    for (const SensorConfig& s : rig_.sensors) {
      if (const auto it = data_.corners.find(s.name); it != data_.corners.end()) {
        H h;
        h.name = s.name + " (u, v)";
        // Per-coordinate whitened values: `whitened` is |(du, dv)| / sigma.
        for (const auto& r : it->second) {
          const double n = std::hypot(r.du, r.dv);
          if (r.outlier || !(n > 0))
            continue;
          h.values.push_back(r.du * r.whitened / n);
          h.values.push_back(r.dv * r.whitened / n);
        }
        hs.push_back(h);
      }
      for (const auto& [part, map, sigma] :
           {std::tuple{"gyro", &data_.gyro, s.noise.GyroSampleSigma()},
            std::tuple{"accel", &data_.accel, s.noise.AccelSampleSigma()}}) {
        const auto it = map->find(s.name);
        if (it == map->end() || !(sigma > 0))
          continue;
        H h;
        h.name = s.name + " " + part;
        for (const auto& r : it->second)
          for (int a = 0; a < 3; ++a)
            h.values.push_back((r.meas[a] - r.pred[a]) / sigma);
        hs.push_back(h);
      }
    }
    if (hs.empty()) {
      sec.omitted = "no residual data";
      return sec;
    }
    const int per_page = 6;
    for (size_t i = 0; i < hs.size(); i += per_page) {
      auto f =
          NewFigure("fig-histograms" + (i ? "-" + std::to_string(i / per_page + 1) : ""),
                    "Whitened residuals vs N(0,1) (should match when the noise model holds)", 2, 3);
      for (size_t k = i; k < std::min(hs.size(), i + per_page); ++k) {
        auto& p = f->Add<XYPlot>();
        p.title = hs[k].name + ", RMS " + FormatNumber(Rms(hs[k].values), 3);
        p.x_label = "whitened residual";
        p.y_label = "density";
        p.legend = k == i;
        p.Histogram(hs[k].values, 48, -6, 6, "data", PaletteColor(0));
        p.NormalDensity(-6, 6, PaletteColor(3));
      }
      sec.figures.push_back(f);
    }
    return sec;
  }

  Section CorrelationSection() {
    Section sec("sec-correlation", "Correlation of the calibration parameters");
    if (data_.correlation.names.empty()) {
      sec.omitted = "no correlation matrix (report_data/correlation.csv absent)";
      return sec;
    }
    auto f = NewFigure("fig-correlation",
                       rig_.IsCameraOnly()
                           ? "Parameter correlation (board poses marginalised)"
                           : "Parameter correlation (trajectory and biases marginalised)",
                       1, 1);
    auto& m = f->Add<MatrixPlot>();
    m.values = data_.correlation.values;
    m.names = data_.correlation.names;
    sec.figures.push_back(f);
    // The strongest off-diagonal pairs, as text.
    std::vector<std::tuple<double, int, int>> pairs;
    const auto& c = data_.correlation.values;
    for (int r = 0; r < c.rows(); ++r)
      for (int k = r + 1; k < c.cols(); ++k)
        if (std::isfinite(c(r, k)))
          pairs.emplace_back(-std::abs(c(r, k)), r, k);
    std::sort(pairs.begin(), pairs.end());
    std::vector<std::vector<std::string>> rows = {{"parameter", "parameter", "correlation"}};
    for (size_t i = 0; i < std::min<size_t>(pairs.size(), 10); ++i) {
      const auto [neg, r, k] = pairs[i];
      rows.push_back(
          {data_.correlation.names[r], data_.correlation.names[k], FormatNumber(c(r, k), 3)});
    }
    sec.html = "<h3>Strongest correlations</h3>" + HtmlTable(rows);
    return sec;
  }

  Section ObservabilitySection() {
    Section sec("sec-observability", "Observability");
    const auto gyro = data_.gyro.find(rig_.base_imu);
    if (!rig_.observability && gyro == data_.gyro.end()) {
      sec.omitted = "no observability analysis in result.yaml and no base gyro data";
      return sec;
    }
    std::ostringstream h;
    if (rig_.observability) {
      const Observability& o = *rig_.observability;
      auto list = [&](const std::vector<std::string>& v) {
        std::string s;
        for (const auto& x : v)
          s += (s.empty() ? "" : ", ") + x;
        return s.empty() ? std::string("none") : s;
      };
      std::vector<std::vector<std::string>> rows = {{"verdict", "parameters"}};
      rows.push_back({"unobservable", list(o.unobservable)});
      rows.push_back({"weak", list(o.weak)});
      rows.push_back({"predicted unobservable (seed tables)", list(o.predicted_unobservable)});
      h << HtmlTable(rows);
      std::vector<std::vector<std::string>> mrows = {
          {"primitive", "sensor", "axis", "t0 [s]", "t1 [s]"}};
      for (const auto& m : o.motion) {
        mrows.push_back({m.primitive, m.sensor,
                         FormatNumber(m.axis.x(), 3) + ", " + FormatNumber(m.axis.y(), 3) + ", " +
                             FormatNumber(m.axis.z(), 3),
                         FormatNumber(m.t0, 4), FormatNumber(m.t1, 4)});
      }
      h << "<h3>Motion primitives found</h3>"
        << (o.motion.empty() ? "<p>none</p>" : HtmlTable(mrows));
      auto f = NewFigure("fig-observability", "Observability verdict", 2, 1);
      auto& t = f->Add<Table>();
      for (const auto& r : rows)
        t.AddRow(r);
      auto& tm = f->Add<Table>();
      tm.title = "motion primitives";
      for (const auto& r : mrows)
        tm.AddRow(r);
      if (!tm.HasData())
        tm.AddRow({"none", "", "", "", ""});
      sec.figures.push_back(f);
    } else {
      h << "<p class=\"note\">result.yaml has no observability analysis.</p>";
    }
    if (gyro != data_.gyro.end()) {
      // Excitation per axis: RMS angular rate over 1 s windows (and accel deviation from its
      // window mean), with the primitives' intervals shaded.
      auto f = NewFigure("fig-excitation", "Excitation per axis over time (1 s windows)", 2, 1);
      for (const auto* src :
           {&gyro->second,
            data_.accel.count(rig_.base_imu) ? &data_.accel.at(rig_.base_imu) : nullptr}) {
        if (!src)
          continue;
        const bool is_gyro = src == &gyro->second;
        auto& p = f->Add<XYPlot>();
        p.title = is_gyro ? "angular rate RMS" : "specific force deviation RMS";
        p.x_label = "time [s]";
        p.y_label = is_gyro ? "rad/s" : "m/s^2";
        std::vector<double> t;
        std::vector<std::vector<double>> axes(3);
        size_t i = 0;
        while (i < src->size()) {
          size_t j = i;
          Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum2 = sum;
          while (j < src->size() && (*src)[j].t_ns - (*src)[i].t_ns < 1000000000) {
            sum += (*src)[j].meas;
            sum2 += (*src)[j].meas.cwiseAbs2();
            ++j;
          }
          const double n = static_cast<double>(j - i);
          t.push_back(Sec((*src)[i].t_ns) + 0.5);
          for (int a = 0; a < 3; ++a) {
            const double ms = sum2[a] / n, mean = sum[a] / n;
            axes[a].push_back(std::sqrt(std::max(is_gyro ? ms : ms - mean * mean, 0.0)));
          }
          i = j;
        }
        if (rig_.observability) {
          for (const auto& m : rig_.observability->motion) {
            // Primitive intervals are in seconds on the base clock; the axis starts at t0_.
            const double lo = m.t0 - 1e-9 * static_cast<double>(t0_);
            const double hi = m.t1 - 1e-9 * static_cast<double>(t0_);
            p.Band({lo, hi}, {0.0, 0.0}, {1e9, 1e9}, "", Color{0.5, 0.5, 0.5});
          }
        }
        for (int a = 0; a < 3; ++a)
          p.Line(t, axes[a], std::string(1, "xyz"[a]), PaletteColor(a), 1.4);
        double top = 0;
        for (const auto& ax : axes)
          for (const double x : ax)
            top = std::max(top, x);
        p.y_min = 0;
        p.y_max = top > 0 ? top * 1.1 : 1.0;
      }
      sec.figures.push_back(f);
    }
    sec.html = h.str();
    return sec;
  }

  Section CrosscheckSection(const std::string& path) {
    Section sec("sec-crosscheck", "Cross-check (spline vs discrete)");
    if (!fs::exists(path)) {
      sec.omitted = "no crosscheck.yaml (only written by calibrate --method both)";
      return sec;
    }
    YAML::Node root;
    try {
      root = YAML::LoadFile(path);
    } catch (const YAML::Exception& e) {
      throw std::runtime_error(path + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
    }
    // A sequence of maps (or a map holding one under `rows`) is a table; anything else is shown
    // as its YAML text.
    YAML::Node seq = root.IsMap() && root["rows"] ? root["rows"] : root;
    std::vector<std::vector<std::string>> rows;
    if (seq.IsSequence()) {
      std::vector<std::string> cols;
      for (const auto& r : seq) {
        if (!r.IsMap())
          continue;
        for (const auto& kv : r) {
          const auto k = kv.first.as<std::string>();
          if (std::find(cols.begin(), cols.end(), k) == cols.end())
            cols.push_back(k);
        }
      }
      rows.push_back(cols);
      for (const auto& r : seq) {
        if (!r.IsMap())
          continue;
        std::vector<std::string> row;
        for (const auto& k : cols) {
          const YAML::Node v = r[k];
          row.push_back(v && v.IsScalar() ? v.as<std::string>() : "");
        }
        rows.push_back(row);
      }
    }
    if (rows.size() > 1) {
      sec.html = HtmlTable(rows);
      TablePages(&sec, "fig-crosscheck", "Cross-check", rows, 26);
    } else {
      std::ostringstream y;
      y << root;
      sec.html = "<pre>" + Escape(y.str()) + "</pre>";
    }
    return sec;
  }

  Section ConfigSection() {
    Section sec("sec-config", "Configuration and versions");
    std::vector<std::vector<std::string>> rows = {{"key", "value"}};
    if (!opt_.ctcal_version.empty())
      rows.push_back({"report rendered by ctcal", opt_.ctcal_version});
    for (const auto& [k, v] : data_.run_info)
      rows.push_back({k, v});
    if (rig_.solver) {
      rows.push_back({"solver.method", rig_.solver->method});
      rows.push_back({"solver.iterations", std::to_string(rig_.solver->iterations)});
      rows.push_back({"solver.final_cost", FormatNumber(rig_.solver->final_cost, 6)});
      rows.push_back({"solver.seconds", FormatNumber(rig_.solver->seconds, 4)});
    }
    for (const auto& [name, r] : rig_.residuals) {
      auto add = [&](const char* what, const std::optional<double>& x) {
        if (x)
          rows.push_back({"residuals." + name + "." + what, FormatNumber(*x, 4)});
      };
      add("rms_px", r.rms_px);
      add("rms_gyro", r.rms_gyro);
      add("rms_accel", r.rms_accel);
      add("rms_whitened", r.rms_whitened);
    }
    sec.html = HtmlTable(rows);
    TablePages(&sec, "fig-config", "Configuration and versions", rows, 26);
    return sec;
  }

  const RigConfig& rig_;
  const ReportData& data_;
  const ReportOptions& opt_;
  std::string out_dir_;
  std::int64_t t0_ = 0;
};

const char* kCss = R"(
body{font-family:"DejaVu Sans",Helvetica,Arial,sans-serif;margin:0 auto;max-width:1100px;
padding:16px;color:#222}
h1{margin-bottom:4px}h2{border-bottom:2px solid #ddd;padding-bottom:4px;margin-top:36px}
table{border-collapse:collapse;margin:8px 0;font-size:13px}
td,th{border:1px solid #ddd;padding:3px 8px;text-align:left}th{background:#e8ecf2}
tr:nth-child(even) td{background:#fafafa}
td.status{color:#fff;font-weight:bold;text-align:center}
p.verdict{color:#fff;font-weight:bold;font-size:20px;padding:10px;border-radius:4px}
p.omitted,p.note{color:#666;font-style:italic}
pre{background:#f6f8fa;padding:8px;font-size:12px;overflow-x:auto}
table.params td:last-child{font-family:"DejaVu Sans Mono",monospace;font-size:12px}
img.fig{width:100%;border:1px solid #eee;margin:6px 0}
nav a{margin-right:10px}
)";

}  // namespace

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

namespace {

RigConfig LoadResult(const std::string& out_dir) {
  const std::string result_path = (fs::path(out_dir) / "result.yaml").string();
  if (!fs::exists(result_path))
    throw std::runtime_error(result_path + ": not found (is " + out_dir +
                             " a folder written by ctcal calibrate?)");
  std::vector<std::string> warnings;
  return LoadRig(result_path, &warnings);
}

ReportOutput Render(const std::string& out_dir, const RigConfig& rig, const ReportData& data,
                    const ReportOptions& options, StageClock* clock) {
  ReportOutput out;
  out.checks = EvaluateChecks(rig, data, options.thresholds);
  Builder builder(rig, data, options, out_dir);
  const std::vector<Section> sections =
      builder.Build(out.checks, (fs::path(out_dir) / "crosscheck.yaml").string());
  out.stages.push_back(clock->Lap("checks and figures' data"));

  if (!options.png_dir.empty())
    fs::create_directories(options.png_dir);

  // The figures drawn, in document order; which of them need a PNG (the HTML's figures other
  // than tables, every figure for --png-dir).
  struct Job {
    const Figure* figure = nullptr;
    bool html_image = false;
    bool png = false;
    std::string bytes;
    double pdf_cpu_s = 0.0, png_cpu_s = 0.0;
  };
  std::vector<Job> jobs;
  for (const Section& s : sections) {
    if (!s.omitted.empty())
      continue;
    for (const auto& f : s.figures) {
      if (!f->HasData())
        continue;  // never an empty figure
      Job j;
      j.figure = f.get();
      // Table-only figures duplicate the HTML tables: the PDF needs them, the HTML does not.
      j.html_image =
          options.html && !std::all_of(f->panels().begin(), f->panels().end(), [](const auto& p) {
            return dynamic_cast<const Table*>(p.get()) || dynamic_cast<const TextPanel*>(p.get());
          });
      j.png = j.html_image || !options.png_dir.empty();
      jobs.push_back(std::move(j));
    }
  }
  // PNGs are drawn and encoded by worker threads (each on its own cairo surface) while this
  // thread writes the PDF pages: on the demo the PNGs are most of the work.
  std::atomic<std::size_t> next{0};
  std::vector<std::string> errors(jobs.size());
  const auto worker = [&]() {
    for (std::size_t i = next++; i < jobs.size(); i = next++) {
      if (!jobs[i].png)
        continue;
      const double cpu0 = ThreadCpuSeconds();
      try {
        jobs[i].bytes = RenderPng(*jobs[i].figure, kPngScale);
      } catch (const std::exception& e) {
        errors[i] = jobs[i].figure->id + ": " + e.what();
      }
      jobs[i].png_cpu_s = ThreadCpuSeconds() - cpu0;
    }
  };
  // `threads` in all: the PDF writer (which then joins the PNG workers) and threads - 1 workers.
  const unsigned threads = std::clamp(options.threads > 0 ? static_cast<unsigned>(options.threads)
                                                          : std::thread::hardware_concurrency(),
                                      2u, 8u);
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; ++t)
    pool.emplace_back(worker);
  std::string pdf_error;
  if (options.pdf) {
    out.pdf_path = (fs::path(out_dir) / "report.pdf").string();
    try {
      PdfDocument pdf(out.pdf_path);
      for (Job& j : jobs) {
        const double cpu0 = ThreadCpuSeconds();
        pdf.AddPage(*j.figure);
        j.pdf_cpu_s = ThreadCpuSeconds() - cpu0;
      }
      out.pdf_pages = pdf.pages();
      pdf.Close();
    } catch (const std::exception& e) {
      pdf_error = e.what();
    }
  }
  worker();
  for (std::thread& t : pool)
    t.join();
  if (!pdf_error.empty())
    throw std::runtime_error(pdf_error);
  for (const std::string& e : errors) {
    if (!e.empty())
      throw std::runtime_error(e);
  }
  out.stages.push_back(clock->Lap("figures"));
  for (const Job& j : jobs)
    out.figure_times.push_back({j.figure->id, j.pdf_cpu_s, j.png_cpu_s});

  std::ostringstream html;
  if (options.html) {
    html << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
         << "<title>ctcal calibration report</title><style>" << kCss << "</style></head><body>\n"
         << "<h1>ctcal calibration report</h1><p>" << Escape(out_dir) << "</p>\n<nav>";
    for (const Section& s : sections)
      html << "<a href=\"#" << s.id << "\">" << Escape(s.heading) << "</a>";
    html << "</nav>\n";
  }
  std::size_t job = 0;
  for (const Section& s : sections) {
    out.section_ids.push_back(s.id);
    html << "<section id=\"" << s.id << "\"><h2>" << Escape(s.heading) << "</h2>\n";
    if (!s.omitted.empty()) {
      out.omitted.push_back(s.id + ": " + s.omitted);
      html << "<p class=\"omitted\">Omitted: " << Escape(s.omitted) << ".</p></section>\n";
      continue;
    }
    html << s.html;
    for (const auto& f : s.figures) {
      if (job >= jobs.size() || jobs[job].figure != f.get())
        continue;  // an empty figure, not drawn
      const Job& j = jobs[job++];
      out.figure_ids.push_back(f->id);
      if (!options.png_dir.empty()) {
        const std::string path = (fs::path(options.png_dir) / (f->id + ".png")).string();
        std::ofstream png(path, std::ios::binary);
        png.write(j.bytes.data(), static_cast<std::streamsize>(j.bytes.size()));
        if (!png)
          throw std::runtime_error(path + ": cannot write PNG");
      }
      if (j.html_image) {
        html << "<img class=\"fig\" id=\"" << f->id << "\" alt=\"" << Escape(f->title)
             << "\" src=\"data:image/png;base64," << Base64(j.bytes) << "\">\n";
      } else if (options.html) {
        html << "<div class=\"figtable\" id=\"" << f->id << "\"></div>\n";
      }
    }
    html << "</section>\n";
  }
  if (options.html) {
    html << "</body></html>\n";
    out.html_path = (fs::path(out_dir) / "report.html").string();
    std::ofstream f(out.html_path);
    f << html.str();
    f.flush();
    if (!f)
      throw std::runtime_error(out.html_path + ": cannot write");
  }
  out.stages.push_back(clock->Lap("html"));
  return out;
}

}  // namespace

ReportOutput RenderReport(const std::string& out_dir, const ReportOptions& options) {
  StageClock clock;
  const RigConfig rig = LoadResult(out_dir);
  std::vector<std::string> names;
  for (const auto& s : rig.sensors)
    names.push_back(s.name);
  const ReportData data = LoadReportData(out_dir, names);
  const StageTime read = clock.Lap("read");
  ReportOutput out = Render(out_dir, rig, data, options, &clock);
  out.stages.insert(out.stages.begin(), read);
  return out;
}

ReportOutput RenderReport(const std::string& out_dir, const ReportData& data,
                          const ReportOptions& options) {
  StageClock clock;
  const RigConfig rig = LoadResult(out_dir);
  const StageTime read = clock.Lap("read");
  ReportOutput out = Render(out_dir, rig, data, options, &clock);
  out.stages.insert(out.stages.begin(), read);
  return out;
}

}  // namespace ctcal::report
