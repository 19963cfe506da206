// The `ctcal` command line (SPEC section 8): --help for every subcommand, one-line errors with
// exit code 2 for bad usage, and `ctcal compare` end to end.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <utility>

#include "cli_test_util.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;

using test::Lines;
using test::Slurp;
using Result = test::CliRun;

// Runs `ctcal <args>` with its output in a folder of its own test.
Result RunCtcal(const std::string& args) {
  return test::RunCtcal(args, ::testing::TempDir() + "/ctcal_cli_" + std::to_string(getpid()) +
                                  "_" +
                                  ::testing::UnitTest::GetInstance()->current_test_info()->name());
}

const char* const kCommands[] = {"simulate", "detect",     "calibrate", "compare",
                                 "report",   "montecarlo", "target",    "import-kalibr"};

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::is_regular_file(CTCAL_BINARY))
      GTEST_SKIP() << CTCAL_BINARY << " is not built";
  }
};

TEST_F(Cli, EverySubcommandPrintsHelpAndExitsZero) {
  for (const char* cmd : kCommands) {
    const Result r = RunCtcal(std::string(cmd) + " --help");
    EXPECT_EQ(r.code, 0) << cmd << ": " << r.err;
    EXPECT_EQ(r.out.rfind(std::string("usage: ctcal ") + cmd, 0), 0u) << cmd << ": " << r.out;
    EXPECT_TRUE(r.err.empty()) << cmd << ": " << r.err;
  }
  const Result top = RunCtcal("--help");
  EXPECT_EQ(top.code, 0);
  for (const char* cmd : kCommands)
    EXPECT_NE(top.out.find(cmd), std::string::npos) << cmd;
  const Result version = RunCtcal("--version");
  EXPECT_EQ(version.code, 0);
  EXPECT_EQ(version.out.rfind("ctcal ", 0), 0u);
}

TEST_F(Cli, BadUsageExitsTwoWithOneLineOnStderr) {
  for (const char* cmd : kCommands) {
    const Result r = RunCtcal(std::string(cmd) + " --no-such-option 3");
    EXPECT_EQ(r.code, 2) << cmd;
    EXPECT_EQ(Lines(r.err), 1) << cmd << ": " << r.err;
    EXPECT_EQ(r.err.rfind(std::string("ctcal ") + cmd + ": ", 0), 0u) << r.err;
  }
  const Result missing = RunCtcal("compare --truth a.yaml");
  EXPECT_EQ(missing.code, 2);
  EXPECT_EQ(Lines(missing.err), 1) << missing.err;
  EXPECT_NE(missing.err.find("'--result' is required"), std::string::npos) << missing.err;
  const Result unknown = RunCtcal("calibrat");
  EXPECT_EQ(unknown.code, 2);
  EXPECT_EQ(Lines(unknown.err), 1) << unknown.err;
  const Result none = RunCtcal("");
  EXPECT_EQ(none.code, 2);
  EXPECT_EQ(Lines(none.err), 1) << none.err;
}

// Option values no calibration can run with are refused before any file is read (the rig and
// data named here do not exist): one line naming the option. A bias knot spacing of 0 ended in
// SIGFPE after the initialisation, a negative knot spacing silently meant "automatic", and a
// negative iteration count read as a diverged solve.
TEST_F(Cli, CalibrateRefusesBadOptionValuesBeforeReadingData) {
  const std::string files = "calibrate --rig no_such_rig.yaml --data no_such_data --out out ";
  const std::pair<const char*, const char*> cases[] = {
      {"--bias-knot-spacing 0", "--bias-knot-spacing"},
      {"--bias-knot-spacing nan", "--bias-knot-spacing"},
      {"--knot-spacing -0.1", "--knot-spacing"},
      {"--knot-spacing 1e-6", "--knot-spacing"},
      {"--max-iterations -1", "--max-iterations"},
      {"--order 3", "order must be 4, 5 or 6"}};
  for (const auto& [option, says] : cases) {
    const Result r = RunCtcal(files + option);
    EXPECT_EQ(r.code, 2) << option;
    EXPECT_EQ(Lines(r.err), 1) << option << ": " << r.err;
    EXPECT_NE(r.err.find(says), std::string::npos) << option << ": " << r.err;
    EXPECT_EQ(r.err.find("no_such"), std::string::npos) << option << ": " << r.err;
  }
}

TEST_F(Cli, CompareReportsAMissingOrBadFileInOneLine) {
  const std::string example = std::string(CTCAL_SOURCE_DIR) + "/configs/example_rig.yaml";
  const Result r = RunCtcal("compare --truth /nonexistent/truth.yaml --result " + example);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(Lines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("/nonexistent/truth.yaml: cannot open file"), std::string::npos) << r.err;
  const std::string bad = std::string(CTCAL_SOURCE_DIR) + "/tests/data/bad/rig_unknown_key.yaml";
  const Result b = RunCtcal("compare --truth " + example + " --result " + bad);
  EXPECT_EQ(b.code, 2);
  EXPECT_EQ(Lines(b.err), 1) << b.err;
  EXPECT_NE(b.err.find("rig_unknown_key.yaml:15: sensors.cam0: unknown key 'focal'"),
            std::string::npos)
      << b.err;
}

TEST_F(Cli, CompareOfAFileWithItselfHasAllErrorsZero) {
  const std::string example = std::string(CTCAL_SOURCE_DIR) + "/configs/example_rig.yaml";
  const std::string json =
      ::testing::TempDir() + "/ctcal_cli_self_" + std::to_string(getpid()) + ".json";
  const Result r =
      RunCtcal("compare --truth " + example + " --result " + example + " --json " + json);
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string text = Slurp(json);
  // One row per estimated scalar of the example (imu0 24, imu1 22, gyro0 10, cam0 15).
  int rows = 0, zero_errors = 0;
  for (std::size_t at = text.find("{\"name\""); at != std::string::npos;
       at = text.find("{\"name\"", at + 1)) {
    const std::size_t end = text.find('}', at);
    const std::string row = text.substr(at, end - at);
    if (row.find("\"truth\"") == std::string::npos)
      continue;  // a rotation's angle or the worst row
    ++rows;
    zero_errors += row.find("\"error\": 0.0,") != std::string::npos;
  }
  EXPECT_EQ(rows, 24 + 22 + 10 + 15);
  EXPECT_EQ(zero_errors, rows);
  EXPECT_NE(r.out.find("cam0.intrinsics[2]"), std::string::npos);
  EXPECT_NE(r.out.find("summary: 71 estimated scalars"), std::string::npos) << r.out;
}

TEST_F(Cli, CompareJsonCarriesErrorsSigmasAndTheSummary) {
  std::vector<std::string> warnings;
  const std::string example = std::string(CTCAL_SOURCE_DIR) + "/configs/example_rig.yaml";
  RigConfig truth = LoadRig(example, &warnings);
  truth.gravity_W = Eigen::Vector3d(0.0, 0.0, -9.81);
  RigConfig result = truth;
  SensorConfig& cam = *result.Find("cam0");
  cam.intrinsics[1] += 0.25;
  cam.sigma.values["intrinsics"] = {0.5, 0.5, 0.5, 0.5};
  cam.sigma.values["time_offset"] = {std::numeric_limits<double>::infinity()};
  result.gravity_W = Eigen::Vector3d(0.0, 0.03, -9.81);
  result.sigma_gravity_W = Eigen::Vector3d(0.01, 0.01, 0.01);
  const std::string dir = ::testing::TempDir() + "/ctcal_cli_json_" + std::to_string(getpid());
  fs::create_directories(dir);
  SaveRig(truth, dir + "/ctcal_cli_truth.yaml");
  SaveRig(result, dir + "/ctcal_cli_result.yaml");
  const Result r = RunCtcal("compare --truth " + dir + "/ctcal_cli_truth.yaml --result " + dir +
                            "/ctcal_cli_result.yaml --json " + dir + "/ctcal_cli_cmp.json");
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string json = Slurp(dir + "/ctcal_cli_cmp.json");
  EXPECT_NE(json.find("{\"name\": \"cam0.intrinsics[1]\", \"truth\": 457.296, \"estimate\": "
                      "457.546, \"error\": 0.25"),
            std::string::npos)
      << json;
  EXPECT_NE(json.find("\"sigma\": 0.5, \"error_over_sigma\": 0.5"), std::string::npos) << json;
  EXPECT_NE(json.find("{\"name\": \"cam0.time_offset\", \"truth\": 0.0, \"estimate\": 0.0, "
                      "\"error\": 0.0, \"sigma\": null, \"error_over_sigma\": null, "
                      "\"undetermined\": true}"),
            std::string::npos)
      << json;
  // gravity_W[1]: 0.03 off at sigma 0.01 -> 3 sigma (within), the worst row.
  EXPECT_NE(json.find("\"name\": \"gravity_W[1]\", \"truth\": 0.0, \"estimate\": 0.03"),
            std::string::npos)
      << json;
  EXPECT_NE(json.find("\"worst\": {\"name\": \"gravity_W[1]\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"with_sigma\": 7, \"undetermined\": 1"), std::string::npos) << json;
  EXPECT_NE(json.find("\"fraction_within_3_sigma\": 1.0"), std::string::npos) << json;
  EXPECT_NE(r.out.find("undetermined"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace ctcal
