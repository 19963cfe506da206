#include "calibrate_report.h"

#include <chrono>
#include <cstdio>
#include <ctime>

#include "ctcal/calibrator/report_data_builder.h"
#include "ctcal/report/report.h"
#include "ctcal_git_describe.h"  // generated at build time (cmake/GitDescribe.cmake)

namespace ctcal::app {

report::RunInfo CalibrateRunInfo(int argc, char** argv) {
  report::RunInfo info;
  std::string command = "ctcal";
  for (int i = 0; i < argc; ++i)
    command += std::string(" ") + argv[i];
  info.emplace_back("command", command);
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  info.emplace_back("run.utc", stamp);
  info.emplace_back("version.ctcal", std::string(CTCAL_VERSION) + " (" + CTCAL_GIT_DESCRIBE + ")");
  for (const auto& row : LibraryVersions())
    info.push_back(row);
  return info;
}

bool WriteCalibrationReport(const std::string& out_dir, report::ReportData data,
                            const report::RunInfo& run_info, const CalibrationLog& log) {
  const auto t0 = std::chrono::steady_clock::now();
  log("report: writing " + out_dir + "/report_data/ and rendering report.html, report.pdf");
  try {
    data.run_info.insert(data.run_info.begin(), run_info.begin(), run_info.end());
    report::WriteReportData(out_dir, data);
    report::ReportOptions options;
    options.ctcal_version = std::string(CTCAL_VERSION) + " (" + CTCAL_GIT_DESCRIBE + ")";
    const report::ReportOutput out = report::RenderReport(out_dir, options);
    int fails = 0, warns = 0;
    for (const report::Check& c : out.checks) {
      fails += c.status == report::Status::kFail;
      warns += c.status == report::Status::kWarn;
    }
    char line[256];
    std::snprintf(line, sizeof line,
                  "report: %d pages, %zu figures, checks %d failed / %d warnings, %.1f s",
                  out.pdf_pages, out.figure_ids.size(), fails, warns,
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    log(line);
    return true;
  } catch (const std::exception& e) {
    log(std::string("warning: the report was not written: ") + e.what());
    return false;
  }
}

}  // namespace ctcal::app
