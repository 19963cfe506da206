// `ctcal compare --truth T.yaml --result R.yaml [--json OUT.json]` (SPEC section 8): wires the
// rig reader and sensors/compare.h; prints the table on stdout.
#include <fstream>
#include <iostream>
#include <string>

#include "cli_common.h"
#include "commands.h"
#include "ctcal/sensors/compare.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal::app {

int RunCompare(int argc, char** argv) {
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--projection")
      return RunCompareProjection(argc, argv);
  namespace po = boost::program_options;
  CommandLine cli("compare", "--truth TRUTH.yaml --result RESULT.yaml [--json OUT.json]",
                  "Compare a result file with the truth, one row per estimated scalar: truth, "
                  "estimate, error, sigma, error/sigma; rotations as Log(R_est * R_true^T). "
                  "Two lens fits of any models: ctcal compare --projection --help.");
  std::string truth_path, result_path, json_path;
  cli.options().add_options()("truth", po::value(&truth_path)->required(),
                              "truth file (SPEC section 7), e.g. DATA/truth.yaml")(
      "result", po::value(&result_path)->required(), "result file of ctcal calibrate")(
      "json", po::value(&json_path), "also write the comparison as JSON to this file");
  if (const auto exit_code = cli.Parse(argc, argv))
    return *exit_code;

  Comparison comparison;
  try {
    // Both files are complete (written by ctcal); warnings such as a missing T_B_S guess do not
    // concern a comparison.
    std::vector<std::string> ignored;
    const RigConfig truth = LoadRig(truth_path, &ignored);
    const RigConfig result = LoadRig(result_path, &ignored);
    comparison = CompareRigs(truth, result);
  } catch (const std::exception& e) {
    return cli.InputError(e.what());
  }
  std::cout << FormatComparison(comparison);
  if (!json_path.empty()) {
    std::ofstream f(json_path);
    f << ComparisonJson(comparison);
    if (!f)
      return cli.RunFailed(json_path + ": cannot write the JSON file");
  }
  return kExitOk;
}

}  // namespace ctcal::app
