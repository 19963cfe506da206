#include "calibrate_report.h"

#include <chrono>
#include <cstdio>
#include <ctime>
#include <future>
#include <iostream>

#include "cli_common.h"
#include "ctcal/calibrator/report_data_builder.h"
#include "ctcal/report/report.h"
#include "ctcal/report/stage_time.h"
#include "ctcal/report/verdict.h"
#include "ctcal/sensors/rig_yaml.h"
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

CalibrationVerdict WriteCalibrationReport(const std::string& out_dir, report::ReportData data,
                                          const report::RunInfo& run_info,
                                          const CalibrationLog& log, int threads) {
  CalibrationVerdict verdict;
  verdict.out_dir = out_dir;
  report::StageClock clock;
  log("report: writing " + out_dir + "/report_data/ and rendering report.html, report.pdf");
  try {
    data.run_info.insert(data.run_info.begin(), run_info.begin(), run_info.end());
    // The report is drawn from the data as written (rounded as the files hold them), not read
    // back: the same report as `ctcal report --out OUT` draws from the folder. The tables it
    // draws rounded are written first; the exact ones (inertial samples, trajectory, ...) on one
    // more thread while the report is drawn (their CPU is in the figures' stage). `exact` is
    // declared after `stored`, which it reads: its destructor waits for the writer on a throw.
    const report::ReportData stored =
        report::WriteRoundedReportData(out_dir, std::move(data), threads);
    std::future<void> exact = std::async(std::launch::async, [&out_dir, &stored] {
      report::WriteExactReportData(out_dir, stored, 1);
    });
    const report::StageTime written = clock.Lap("report data");
    // The checks first, from what the report reads (result.yaml as written, the stored data):
    // the exit code stands even when the rendering below fails.
    try {
      std::vector<std::string> warnings;
      verdict.checks = report::EvaluateChecks(LoadRig(out_dir + "/result.yaml", &warnings), stored);
      verdict.evaluated = true;
    } catch (const std::exception& e) {
      verdict.error = e.what();
    }
    report::ReportOptions options;
    options.ctcal_version = std::string(CTCAL_VERSION) + " (" + CTCAL_GIT_DESCRIBE + ")";
    options.threads = threads;
    report::ReportOutput out = report::RenderReport(out_dir, stored, options);
    report::StageClock rest;
    exact.get();  // the writer's error, if any
    out.stages.insert(out.stages.begin(), written);
    out.stages.push_back(rest.Lap("exact data's rest"));
    int fails = 0, warns = 0;
    for (const report::Check& c : out.checks) {
      fails += c.status == report::Status::kFail;
      warns += c.status == report::Status::kWarn;
    }
    double wall = 0.0;
    for (const report::StageTime& t : out.stages)
      wall += t.wall_s;
    char line[256];
    std::snprintf(line, sizeof line,
                  "report: %d pages, %zu figures, checks %d failed / %d warnings, %.1f s",
                  out.pdf_pages, out.figure_ids.size(), fails, warns, wall);
    log(line);
    log("  " + report::FormatStageTimes(out.stages));
    verdict.report_written = true;
  } catch (const std::exception& e) {
    if (!verdict.evaluated && verdict.error.empty())
      verdict.error = e.what();
    log(std::string("warning: the report was not written: ") + e.what());
  }
  return verdict;
}

int ExitCodeOfChecks(const std::vector<CalibrationVerdict>& verdicts, const CalibrationLog& log) {
  bool failed = false;
  for (const CalibrationVerdict& v : verdicts) {
    if (!v.evaluated) {
      const std::string line =
          "error: " + v.out_dir + ": the checks could not be evaluated: " + v.error;
      log(line);
      std::cerr << "ctcal calibrate: " << line << std::endl;
      return kExitFailed;
    }
    const std::string where = verdicts.size() > 1 ? " [" + v.out_dir + "]" : "";
    for (const std::string& line : report::FailedCheckLines(v.checks)) {
      log(line + where);
      std::cerr << line << where << std::endl;
      failed = true;
    }
  }
  return failed ? kExitChecksFailed : kExitOk;
}

}  // namespace ctcal::app
