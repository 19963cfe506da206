// The report's document builder: one Section per page group in issue 10's order (the
// ten-second summary, parameters, Kalibr matrices, poses, per inertial sensor, per camera,
// normalised residual histograms, correlation, observability, cross-check, cross-validation,
// configuration).
// report_summary_pages.cpp, report_sensor_pages.cpp and report_analysis_pages.cpp build them;
// report.cpp draws them into the HTML and the PDF. Private to the report library.
#pragma once

#include <algorithm>
#include <cstdint>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "ctcal/report/plot.h"
#include "ctcal/report/report.h"
#include "report_format.h"

namespace ctcal::report::detail {

// One section: HTML body parts and PDF figures in order.
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
    out.push_back(CrossValidationSection());
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

  Section Summary(const std::vector<Check>& checks);
  std::vector<std::vector<std::string>> ParameterSummaryRows() const;
  std::vector<std::string> KalibrPasteLines() const;
  Section Parameters();
  Section KalibrSection();
  Section TrajectorySection();
  void InertialFigures(Section* sec, const SensorConfig& s, const std::vector<InertialSample>& d,
                       const std::string& part, const std::string& unit, double sigma);
  Section InertialSection(const SensorConfig& s);
  void DistortionFigure(Section* sec, const SensorConfig& s) const;
  // Lens-fit diagnosis (lens_fit.h): the mean residual vector per image cell, its chi-square
  // test, and the richer model to try when the pattern is significant.
  void LensFitFigure(Section* sec, const SensorConfig& s,
                     const std::vector<CornerResidual>& corners) const;
  Section CameraSection(const SensorConfig& s);
  void WhitenedFrameFigure(
      Section* sec, const std::string& camera,
      const std::map<int, std::pair<double, std::pair<double, int>>>& per_frame,
      const std::map<int, double>& whitened) const;
  // One row per stated noise quantity with the estimate beside it (header first; only a header
  // when the result has no estimate).
  std::vector<std::vector<std::string>> NoiseRows() const;
  Section Histograms();
  Section CorrelationSection();
  Section ObservabilitySection();
  Section CrosscheckSection(const std::string& path);
  Section CrossValidationSection();  // report_crossval_page.cpp
  Section ConfigSection();

  const RigConfig& rig_;
  const ReportData& data_;
  const ReportOptions& opt_;
  std::string out_dir_;
  std::int64_t t0_ = 0;
};

}  // namespace ctcal::report::detail
