// `ctcal crossval A B [--json]` on result files with known differences, its bad input, and the
// cross-validation of `ctcal calibrate` end to end: log lines, OUT/crossval/, the report section,
// sigma against sigma_formal.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <string>

#include "../calibrator/simulated_recording.h"
#include "../io/example_with_sigma.h"
#include "cli_test_util.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal {
namespace {

using test::Lines;
using test::RunCtcal;
using test::Slurp;

const std::string& kExample = test::kExampleRig;

// The first match of `pattern` in `text` (empty when none); `text` must outlive it.
std::smatch Match(const std::string& text, const char* pattern) {
  std::smatch m;
  std::regex_search(text, m, std::regex(pattern));
  return m;
}

std::string Dir(const std::string& name) {
  return (std::filesystem::path(::testing::TempDir()) / ("ctcal_crossval_" + name)).string();
}

// The example rig with sigma 1e-3 on every estimated quantity, written to `path`.
RigConfig WriteResult(const std::string& path, double fx_shift, double ty_shift) {
  RigConfig rig = test::ExampleWithSigma(1e-3);
  rig.Find("cam0")->intrinsics[0] += fx_shift;
  rig.Find("cam0")->T_B_S(1, 3) += ty_shift;
  SaveRig(rig, path);
  return rig;
}

TEST(CrossvalCommand, KnownDifferencesGiveTheirZAndVerdict) {
  const std::string dir = Dir("known");
  std::filesystem::create_directories(dir);
  WriteResult(dir + "/a.yaml", 0.0, 0.0);
  WriteResult(dir + "/b.yaml", 0.01, 2e-3);  // z = 7.07 (fails its group), z = 1.41
  const auto r = RunCtcal(
      "crossval " + dir + "/a.yaml " + dir + "/b.yaml --json " + dir + "/cv.json", dir + "/run");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("cam0.intrinsics[0]"), std::string::npos);
  EXPECT_NE(r.out.find("7.07"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("1.41"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("cam0.intrinsics"), std::string::npos);
  EXPECT_NE(r.out.find("verdict: 1 group(s) disagree"), std::string::npos) << r.out;
  const std::string json = Slurp(dir + "/cv.json");
  EXPECT_NE(json.find("\"name\": \"cam0.t_B_S[1]\""), std::string::npos);
  EXPECT_NE(json.find("\"groups_failed\": 1"), std::string::npos) << json;

  // The same file twice agrees.
  const auto same = RunCtcal("crossval " + dir + "/a.yaml " + dir + "/a.yaml", dir + "/same");
  ASSERT_EQ(same.code, 0) << same.err;
  EXPECT_NE(same.out.find("verdict: consistent"), std::string::npos) << same.out;
}

TEST(CrossvalCommand, BadInputIsOneLine) {
  const std::string dir = Dir("bad");
  std::filesystem::create_directories(dir);
  WriteResult(dir + "/a.yaml", 0.0, 0.0);
  for (const std::string& args :
       {std::string("crossval ") + dir + "/a.yaml",
        "crossval " + dir + "/a.yaml " + dir + "/no.yaml",
        "crossval " + dir + "/a.yaml " + dir + "/a.yaml " + dir + "/a.yaml",
        "crossval " + kExample + " " + kExample}) {
    const auto r = RunCtcal(args, dir + "/run");
    EXPECT_EQ(r.code, 2) << args;
    EXPECT_EQ(Lines(r.err), 1) << args << ": " << r.err;
  }
  const auto missing = RunCtcal("crossval " + dir + "/a.yaml " + dir + "/no.yaml", dir + "/run2");
  EXPECT_NE(missing.err.find("no.yaml"), std::string::npos) << missing.err;
}

TEST(CrossvalCommand, CalibrateCrossValidatesAndReportsIt) {
  const std::string data = test::SimulateOnce("ctcal_crossval_sim", test::FullTable4Args(3, 16));
  const std::string out = Dir("calibrate");
  const auto r = RunCtcal("calibrate --rig " + data + "/rig.yaml --data " + data + " --out " + out +
                              " --threads 2 --cross-validate --subset-block 2",
                          out + "/run");
  ASSERT_TRUE(r.code == 0 || r.code == 3) << r.err;
  const std::string log = Slurp(out + "/log.txt");
  EXPECT_NE(log.find("cross-validation: 2 subsets of interleaved 2.0 s blocks"), std::string::npos)
      << log;
  EXPECT_NE(log.find("verdict: "), std::string::npos);
  // The subset's trajectory on the full calibration's knots (the same model).
  const std::smatch full = Match(log, R"(trajectory: .* knot spacing ([0-9.]+) s)");
  const std::smatch subset = Match(log, R"(subset 1: .* knot spacing ([0-9.]+) s)");
  ASSERT_FALSE(full.empty() || subset.empty()) << log;
  EXPECT_EQ(full[1].str(), subset[1].str()) << log;
  ASSERT_TRUE(std::filesystem::exists(out + "/crossval/subset_1.yaml"));
  // K = 2: one subset calibrated, the rest is the full calibration's.
  EXPECT_FALSE(std::filesystem::exists(out + "/crossval/subset_2.yaml"));
  const std::string html = Slurp(out + "/report.html");
  EXPECT_NE(html.find("id=\"sec-crossval\""), std::string::npos);
  EXPECT_NE(html.find("fig-crossval"), std::string::npos);
  // The subsets' files compare again with the command.
  const auto cv =
      RunCtcal("crossval " + out + "/crossval/subset_1.yaml " + out + "/result.yaml", out + "/cv");
  EXPECT_EQ(cv.code, 0) << cv.err;

  // The report data, written beside the subsets' solves, are the full calibration's: the same
  // files as a run without cross-validation writes (run_info.csv holds the command line).
  const auto report_data = [&out] {
    std::map<std::string, std::string> files;
    for (const auto& f : std::filesystem::directory_iterator(out + "/report_data")) {
      if (f.path().filename() != "run_info.csv")
        files[f.path().filename().string()] = Slurp(f.path().string());
    }
    return files;
  };
  EXPECT_NE(log.find("report_data/ beside the cross-validation"), std::string::npos) << log;
  const std::map<std::string, std::string> beside = report_data();
  EXPECT_GE(beside.size(), 5u);

  // Off: one log line says so and no subsets are left from the run before.
  const auto off = RunCtcal("calibrate --rig " + data + "/rig.yaml --data " + data + " --out " +
                                out + " --threads 2 --no-cross-validate",
                            out + "/run_off");
  ASSERT_TRUE(off.code == 0 || off.code == 3) << off.err;
  EXPECT_NE(Slurp(out + "/log.txt").find("cross-validation off (--no-cross-validate)"),
            std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(out + "/crossval"));
  const std::map<std::string, std::string> alone = report_data();
  ASSERT_EQ(alone.size(), beside.size());
  for (const auto& [name, bytes] : beside)
    EXPECT_TRUE(alone.at(name) == bytes) << name << " differs";
  const auto k1 = RunCtcal("calibrate --rig " + data + "/rig.yaml --data " + data + " --out " +
                               out + " --cross-validate --subsets 1",
                           out + "/run_k1");
  EXPECT_EQ(k1.code, 2);
  EXPECT_EQ(Lines(k1.err), 1) << k1.err;
}

// OUT/report_data cannot be created (a file of that name): the calibration's result stands, the
// checks cannot be evaluated, exit 1 with one line naming the folder, whether the data are written
// beside the cross-validation (its writer's error reaches the report step) or after the result.
TEST(CrossvalCommand, UnwritableReportDataIsOneLineExit1) {
  const std::string data = test::SimulateOnce("ctcal_crossval_sim", test::FullTable4Args(3, 16));
  for (const std::string mode : {"--cross-validate --subset-block 2", "--no-cross-validate"}) {
    SCOPED_TRACE(mode);
    const std::string out = Dir("unwritable");
    std::filesystem::remove_all(out);
    std::filesystem::create_directories(out);
    std::ofstream(out + "/report_data") << "not a folder\n";
    const auto r = RunCtcal("calibrate --rig " + data + "/rig.yaml --data " + data + " --out " +
                                out + " --threads 2 " + mode,
                            out + "_run");
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_EQ(Lines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find(out + "/report_data: cannot create"), std::string::npos) << r.err;
    EXPECT_TRUE(std::filesystem::exists(out + "/result.yaml"));
  }
}

}  // namespace
}  // namespace ctcal
