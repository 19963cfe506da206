// `ctcal crossval A/result.yaml B/result.yaml [--json OUT.json]`: two calibrations of one rig from
// different data, compared parameter by parameter against their own sigmas (sensors/crossval.h,
// docs/cross_validation.md). Prints the z table, the groups' tests and the verdict; exit 0 either
// way (a disagreement is a finding, not a failed run).
#include <fstream>
#include <iostream>

#include "cli_common.h"
#include "commands.h"
#include "ctcal/sensors/crossval.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal::app {

int RunCrossval(int argc, char** argv) {
  namespace po = boost::program_options;
  CommandLine cli("crossval", "A/result.yaml B/result.yaml [--json OUT.json]",
                  "Compare two results of the same rig from different data: per parameter "
                  "z = (b - a) / sqrt(sigma_a^2 + sigma_b^2), a chi-square test per group "
                  "(intrinsics, rotation, translation, time offset of each sensor) and a verdict.");
  std::vector<std::string> paths;
  std::string json_path;
  cli.options().add_options()("results", po::value(&paths)->required(),
                              "the two result files (positional)")(
      "json", po::value(&json_path), "also write the comparison as JSON to this file");
  cli.positional().add("results", 2);
  if (const auto exit_code = cli.Parse(argc, argv))
    return *exit_code;
  if (paths.size() != 2)
    return cli.UsageError("give two result files, got " + std::to_string(paths.size()));

  CrossValidation cv;
  try {
    // Results written by ctcal: warnings (a missing T_B_S guess) do not concern a comparison.
    std::vector<std::string> ignored;
    std::vector<RigConfig> results;
    for (const std::string& p : paths)
      results.push_back(LoadRig(p, &ignored));
    cv = CrossValidate(results, paths);
  } catch (const std::exception& e) {
    return cli.InputError(e.what());
  }
  if (cv.summary.with_z == 0)
    return cli.InputError(paths[0] + ", " + paths[1] +
                          ": no estimated parameter has a sigma in both (results of "
                          "ctcal calibrate carry sigma:)");
  std::cout << FormatCrossValidation(cv);
  if (!json_path.empty()) {
    std::ofstream f(json_path);
    f << CrossValidationJson(cv);
    if (!f)
      return cli.RunFailed(json_path + ": cannot write the JSON file");
  }
  return kExitOk;
}

}  // namespace ctcal::app
