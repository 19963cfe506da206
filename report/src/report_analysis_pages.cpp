// The report's rig-wide analysis pages: normalised residual histograms, correlation,
// observability, the cross-check and the configuration.
#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>
#include <filesystem>

#include "report_builder.h"

namespace ctcal::report::detail {

namespace fs = std::filesystem;

Section Builder::Histograms() {
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

Section Builder::CorrelationSection() {
  Section sec("sec-correlation", "Correlation of the calibration parameters");
  if (data_.correlation.names.empty()) {
    sec.omitted = "no correlation matrix (report_data/correlation.csv absent)";
    return sec;
  }
  auto f =
      NewFigure("fig-correlation",
                rig_.IsCameraOnly() ? "Parameter correlation (board poses marginalised)"
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

Section Builder::ObservabilitySection() {
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

Section Builder::CrosscheckSection(const std::string& path) {
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

Section Builder::ConfigSection() {
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
  for (const auto& residual : rig_.residuals) {
    // Not a structured binding: C++17 lambdas cannot capture one (GCC allows it, clang refuses).
    const std::string& name = residual.first;
    const auto& r = residual.second;
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

}  // namespace ctcal::report::detail
