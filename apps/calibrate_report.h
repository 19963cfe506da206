// The report step of `ctcal calibrate` (issue 10): writes OUT/report_data/ (report_data.h) and
// renders OUT/report.html and OUT/report.pdf. A failure to render is a warning: the calibration in
// OUT/result.yaml stands without its report. The report's checks give the command's exit code.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "ctcal/calibrator/spline_calibrator.h"
#include "ctcal/report/report.h"
#include "ctcal/report/report_data.h"

namespace ctcal::app {

// `calibrate`'s exit code when the result and its report are written but a check of the report
// failed (SPEC section 8; the others are cli_common.h's).
inline constexpr int kExitChecksFailed = 3;

// The configuration rows of run_info.csv: the command line, then the ctcal version (`git
// describe` of the source tree at build time) and the libraries' versions.
report::RunInfo CalibrateRunInfo(int argc, char** argv);

// The report's checks of one result folder (report.h EvaluateChecks, the same call that draws the
// first page): `evaluated` false when they could not be (result or report data unwritable).
struct CalibrationVerdict {
  std::string out_dir;
  bool report_written = false;
  bool evaluated = false;
  std::string error;  // why not, when !evaluated
  std::vector<report::Check> checks;
};

// Writes `data` (run_info appended to `run_info`) and renders the report on `threads` threads (0:
// the hardware's), logging the time of each stage; a report that cannot be rendered is a warning.
// The checks are evaluated from OUT/result.yaml and the data as written, also when the rendering
// fails.
CalibrationVerdict WriteCalibrationReport(const std::string& out_dir, report::ReportData data,
                                          const report::RunInfo& run_info,
                                          const CalibrationLog& log, int threads = 0);

// WriteCalibrationReport in two halves, for a caller with more work before result.yaml is final
// (the cross-validation, which changes sigmas only): the report data, which hold the full
// calibration's residuals, trajectory and formal correlation and nothing the cross-validation
// changes, are written to OUT/report_data/ on one thread of their own from construction; Finish
// waits for them, then evaluates the checks and renders the report as WriteCalibrationReport does.
// The destructor waits for the writer (a caller that returns early leaves no thread behind).
class PendingCalibrationReport {
 public:
  PendingCalibrationReport(const std::string& out_dir, report::ReportData data,
                           const report::RunInfo& run_info, const CalibrationLog& log,
                           int threads = 0);
  ~PendingCalibrationReport();
  PendingCalibrationReport(const PendingCalibrationReport&) = delete;
  PendingCalibrationReport& operator=(const PendingCalibrationReport&) = delete;

  // Once: OUT/result.yaml written.
  CalibrationVerdict Finish();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The exit code of `ctcal calibrate` from the verdicts of its result folders (SPEC section 8): 0
// when every check passed or warned; 3 when a check failed, each failed check on stderr and in
// the log ("check failed: ..."); 1 when the checks could not be evaluated.
int ExitCodeOfChecks(const std::vector<CalibrationVerdict>& verdicts, const CalibrationLog& log);

}  // namespace ctcal::app
