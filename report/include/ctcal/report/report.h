// The calibration report of a finished calibration folder OUT (issue 10): OUT/report.html (one
// self-contained file, figures inlined as base64 PNG, no network) and OUT/report.pdf (cairo),
// drawn from OUT/result.yaml (SPEC section 7), the files of report_data.h and, when present,
// OUT/crosscheck.yaml. `ctcal report --out OUT` and `ctcal calibrate` call RenderReport.
//
// Every HTML section has a stable id (`sec-summary`, `sec-parameters`, `sec-kalibr`,
// `sec-trajectory`, `sec-imu-<sensor>`, `sec-camera-<camera>`, `sec-histograms`,
// `sec-correlation`, `sec-observability`, `sec-crosscheck`, `sec-config`) and every figure an
// id `fig-...` (ReportOutput::figure_ids). A section without data keeps its heading and says why
// in a `<p class="omitted">` note; no empty figure is ever drawn.
#pragma once

#include <string>
#include <vector>

#include "ctcal/report/report_data.h"
#include "ctcal/report/stage_time.h"
#include "ctcal/sensors/rig.h"

namespace ctcal::report {

enum class Status { kPass, kWarn, kFail, kUnknown };
std::string ToString(Status s);  // PASS, WARN, FAIL, N/A

// One line of the first page.
struct Check {
  std::string name;       // "whitened RMS", "outlier fraction", "coverage", "observability"
  std::string sensor;     // "" for rig-wide checks
  std::string value;      // what was measured, formatted
  std::string criterion;  // the pass / warn thresholds in words
  Status status = Status::kUnknown;
};

// Thresholds of the first page. Whitened residual RMS should be ~1: pass within
// [1/whitened_pass, whitened_pass], warn within [1/whitened_warn, whitened_warn]. Outlier
// fraction of a camera's corners: pass <= outlier_pass, warn <= outlier_warn. Coverage: the
// fraction of a coverage_cells x coverage_cells grid over the image that holds inlier corners:
// pass >= coverage_pass, warn >= coverage_warn. Observability: fail with an unobservable
// parameter, warn with a weak one.
struct CheckThresholds {
  double whitened_pass = 1.3, whitened_warn = 2.0;
  double outlier_pass = 0.02, outlier_warn = 0.05;
  int coverage_cells = 8;
  double coverage_pass = 0.6, coverage_warn = 0.35;
};

std::vector<Check> EvaluateChecks(const RigConfig& result, const ReportData& data,
                                  const CheckThresholds& thresholds = {});

// Fraction of the cells x cells grid over the image holding at least one inlier corner.
double Coverage(const std::vector<CornerResidual>& corners, int width, int height, int cells);

struct ReportOptions {
  std::string ctcal_version;  // the renderer's version, printed with the run's own versions
  bool html = true;
  bool pdf = true;
  std::string png_dir;  // when set, every figure is also written there as <id>.png (docs)
  int threads =
      0;  // the PDF writer and threads - 1 PNG workers (at least 1); 0: the hardware's (max 8)
  CheckThresholds thresholds;
};

// CPU seconds of one figure: its PDF page (on the PDF writer's thread) and its PNG (a worker's).
struct FigureTime {
  std::string id;
  double pdf_cpu_s = 0.0, png_cpu_s = 0.0;
};

struct ReportOutput {
  std::string html_path, pdf_path;
  int pdf_pages = 0;
  std::vector<std::string> section_ids;
  std::vector<std::string> figure_ids;
  std::vector<std::string> omitted;  // "sec-crosscheck: no OUT/crosscheck.yaml", ...
  std::vector<Check> checks;
  // Where the time went: read, checks and figures' data, figures (PDF and PNGs), html.
  std::vector<StageTime> stages;
  std::vector<FigureTime> figure_times;
};

// Reads OUT and writes the report. Throws std::runtime_error naming the file for unreadable
// input (result.yaml missing or invalid, a malformed report_data file) or an unwritable output.
ReportOutput RenderReport(const std::string& out_dir, const ReportOptions& options = {});
// The same from the report data in memory, as LoadReportData would read them from OUT (`ctcal
// calibrate` renders what it has just written, WriteReportData's return, without reading it
// back); OUT still supplies result.yaml and crosscheck.yaml.
ReportOutput RenderReport(const std::string& out_dir, const ReportData& data,
                          const ReportOptions& options = {});

// WriteReportData (report_data.h) in two halves, for a caller that renders while the second half
// is written (docs/performance.md step 7h). WriteRoundedReportData writes the tables the report
// draws rounded (corner residuals, bias tracks) and returns `data` with them as the files hold
// them; WriteExactReportData writes the others (inertial samples, trajectory, correlation, run
// info), whose values the files hold exactly, so RenderReport may draw from `data` meanwhile.
// Together they write the files WriteReportData writes.
ReportData WriteRoundedReportData(const std::string& out_dir, ReportData data, int threads = 0);
void WriteExactReportData(const std::string& out_dir, const ReportData& data, int threads = 0);

}  // namespace ctcal::report
