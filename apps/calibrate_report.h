// The report step of `ctcal calibrate` (issue 10): writes OUT/report_data/ (report_data.h) and
// renders OUT/report.html and OUT/report.pdf. A failure here is a warning: the calibration in
// OUT/result.yaml stands without its report.
#pragma once

#include <string>

#include "ctcal/calibrator/spline_calibrator.h"
#include "ctcal/report/report_data.h"

namespace ctcal::app {

// The configuration rows of run_info.csv: the command line, then the ctcal version (`git
// describe` of the source tree at build time) and the libraries' versions.
report::RunInfo CalibrateRunInfo(int argc, char** argv);

// Writes `data` (run_info appended to `run_info`) and renders the report on `threads` threads (0:
// the hardware's), logging the time of each stage; every problem is logged as a warning. Returns
// whether both files were written.
bool WriteCalibrationReport(const std::string& out_dir, report::ReportData data,
                            const report::RunInfo& run_info, const CalibrationLog& log,
                            int threads = 0);

}  // namespace ctcal::app
