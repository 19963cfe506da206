#include "calibrate_report.h"

#include <chrono>
#include <cstdio>
#include <ctime>
#include <future>
#include <iostream>
#include <stdexcept>

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

namespace {

// The second half of the report step, from the data as written (`stored`, the rounded tables as
// the files hold them): the checks first, from what the report reads (result.yaml as written, the
// stored data), so that the exit code stands even when the rendering fails; then the rendering,
// `exact` (when valid: the writer of the exact tables, still running) waited for before the report
// counts as written. Throws when the report cannot be rendered.
void RenderFromStored(const std::string& out_dir, const report::ReportData& stored,
                      const report::StageTime& written, std::future<void>* exact,
                      const CalibrationLog& log, int threads, CalibrationVerdict* verdict) {
  try {
    std::vector<std::string> warnings;
    verdict->checks = report::EvaluateChecks(LoadRig(out_dir + "/result.yaml", &warnings), stored);
    verdict->evaluated = true;
  } catch (const std::exception& e) {
    verdict->error = e.what();
  }
  report::ReportOptions options;
  options.ctcal_version = std::string(CTCAL_VERSION) + " (" + CTCAL_GIT_DESCRIBE + ")";
  options.threads = threads;
  report::ReportOutput out = report::RenderReport(out_dir, stored, options);
  report::StageClock rest;
  if (exact != nullptr && exact->valid())
    exact->get();  // the writer's error, if any
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
  verdict->report_written = true;
}

// A failure of the report step: a warning, and the verdict's error when the checks were not
// evaluated.
void ReportFailed(const std::exception& e, const CalibrationLog& log, CalibrationVerdict* verdict) {
  if (!verdict->evaluated && verdict->error.empty())
    verdict->error = e.what();
  log(std::string("warning: the report was not written: ") + e.what());
}

}  // namespace

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
    RenderFromStored(out_dir, stored, clock.Lap("report data"), &exact, log, threads, &verdict);
  } catch (const std::exception& e) {
    ReportFailed(e, log, &verdict);
  }
  return verdict;
}

struct PendingCalibrationReport::Impl {
  std::string out_dir;
  CalibrationLog log;
  int threads = 0;
  std::future<report::ReportData> written;  // both halves of the data, the rounded returned
};

PendingCalibrationReport::PendingCalibrationReport(const std::string& out_dir,
                                                   report::ReportData data,
                                                   const report::RunInfo& run_info,
                                                   const CalibrationLog& log, int threads)
    : impl_(std::make_unique<Impl>()) {
  impl_->out_dir = out_dir;
  impl_->log = log;
  impl_->threads = threads;
  log("report: writing " + out_dir + "/report_data/ beside the cross-validation");
  data.run_info.insert(data.run_info.begin(), run_info.begin(), run_info.end());
  // One thread: the caller's work (the subsets' solves) has the others. The log is the caller's
  // thread's alone; the writer's error reaches Finish through the future.
  impl_->written = std::async(std::launch::async, [out_dir, data = std::move(data)]() mutable {
    report::ReportData stored = report::WriteRoundedReportData(out_dir, std::move(data), 1);
    report::WriteExactReportData(out_dir, stored, 1);
    return stored;
  });
}

PendingCalibrationReport::~PendingCalibrationReport() {
  if (impl_ != nullptr && impl_->written.valid())
    impl_->written.wait();
}

CalibrationVerdict PendingCalibrationReport::Finish() {
  CalibrationVerdict verdict;
  verdict.out_dir = impl_->out_dir;
  const CalibrationLog& log = impl_->log;
  report::StageClock clock;
  log("report: rendering report.html, report.pdf");
  try {
    if (!impl_->written.valid())
      throw std::logic_error("PendingCalibrationReport::Finish called twice");
    // The wait for the writer is the data's stage here (its CPU ran beside the caller's work).
    const report::ReportData stored = impl_->written.get();
    RenderFromStored(impl_->out_dir, stored, clock.Lap("report data"), nullptr, log, impl_->threads,
                     &verdict);
  } catch (const std::exception& e) {
    ReportFailed(e, log, &verdict);
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
