// `ctcal report --out OUT` (SPEC section 8): re-renders OUT/report.html and OUT/report.pdf of a
// finished calibration folder with report/report.h (the same function calibrate calls); for a
// `calibrate --method both` folder, the reports of OUT/spline/ and OUT/discrete/.
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "cli_common.h"
#include "commands.h"
#include "ctcal/report/report.h"
#include "ctcal_git_describe.h"  // generated at build time (cmake/GitDescribe.cmake)

namespace ctcal::app {

int RunReport(int argc, char** argv) {
  namespace po = boost::program_options;
  CommandLine cli("report", "--out OUT [--png-dir DIR] [--times]",
                  "Re-render the calibration report (OUT/report.html and OUT/report.pdf) of a "
                  "folder written by ctcal calibrate (of OUT/spline/ and OUT/discrete/ for "
                  "--method both).");
  std::string out_dir, png_dir;
  bool times = false;
  cli.options().add_options()("out", po::value(&out_dir)->required(),
                              "calibration folder holding result.yaml and report_data/")(
      "png-dir", po::value(&png_dir),
      "also write every figure as <png-dir>/<figure id>.png (<png-dir>/<method>/<figure id>.png "
      "for a --method both folder)")(
      "times", po::bool_switch(&times),
      "print the CPU time of every figure's PDF page and PNG (the stages are always printed)");
  if (const auto exit_code = cli.Parse(argc, argv))
    return *exit_code;
  report::ReportOptions options;
  options.ctcal_version = std::string(CTCAL_VERSION) + " (" + CTCAL_GIT_DESCRIBE + ")";
  // `--method both` keeps no result at the top, one full result per method below it (issue 8).
  std::vector<std::string> folders;
  if (!std::filesystem::exists(out_dir + "/result.yaml")) {
    for (const char* method : {"/spline", "/discrete"}) {
      if (std::filesystem::exists(out_dir + method + "/result.yaml"))
        folders.push_back(out_dir + method);
    }
  }
  if (folders.empty())
    folders.push_back(out_dir);
  for (const std::string& folder : folders) {
    // Both methods' figures have the same ids: each method's go below its own name, as its
    // report does below OUT, or the second would overwrite the first.
    options.png_dir =
        png_dir.empty() || folder == out_dir
            ? png_dir
            : (std::filesystem::path(png_dir) / std::filesystem::path(folder).filename()).string();
    report::ReportOutput out;
    try {
      out = report::RenderReport(folder, options);
    } catch (const std::exception& e) {
      return cli.InputError(e.what());
    }
    int fails = 0;
    for (const auto& c : out.checks)
      fails += c.status == report::Status::kFail;
    std::printf("wrote %s and %s (%d pages, %zu figures, %zu sections omitted, %d checks failed)\n",
                out.html_path.c_str(), out.pdf_path.c_str(), out.pdf_pages, out.figure_ids.size(),
                out.omitted.size(), fails);
    std::printf("%s\n", FormatStageTimes(out.stages).c_str());
    if (times) {
      for (const report::FigureTime& f : out.figure_times)
        std::printf("  %-32s PDF %.3f s  PNG %.3f s (CPU)\n", f.id.c_str(), f.pdf_cpu_s,
                    f.png_cpu_s);
    }
  }
  return kExitOk;
}

}  // namespace ctcal::app
