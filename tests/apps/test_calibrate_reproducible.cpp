// `ctcal calibrate` twice on the same short simulated recording, in two processes (so with two
// different address-space layouts and heaps), for one and for several threads: the written result
// files must be the same bytes (a factory wants the same answer from the same recording). Only
// the solver's wall time (`solver: seconds`) may differ between runs.
#include <gtest/gtest.h>

#include <filesystem>
#include <sstream>
#include <string>

#include "../calibrator/simulated_recording.h"
#include "cli_test_util.h"

namespace ctcal {
namespace {

// The file without its wall-time lines (the only run-dependent value of result.yaml).
std::string WithoutWallTime(const std::string& text) {
  std::istringstream in(text);
  std::string line, out;
  while (std::getline(in, line)) {
    if (line.find("seconds:") == std::string::npos)
      out += line + "\n";
  }
  return out;
}

// The first line where two texts differ, for the failure message.
std::string FirstDifference(const std::string& a, const std::string& b) {
  std::istringstream ia(a), ib(b);
  std::string la, lb;
  for (int n = 1; std::getline(ia, la) && std::getline(ib, lb); ++n) {
    if (la != lb)
      return "line " + std::to_string(n) + ": '" + la + "' vs '" + lb + "'";
  }
  return "one file is longer";
}

// The cause it guards against: ceres::Problem::GetParameterBlocks lists the blocks by address, so
// the normal equations' columns were permuted from run to run (solver/parameter_order.h). With one
// thread a run's chance of a different heap layout is high but not certain: three runs.
TEST(CalibrateReproducible, RunsWriteTheSameBitsForAGivenThreadCount) {
  const std::string data =
      test::SimulateOnce("ctcal_reproducible_data", test::FullTable4Args(31, 6.0));
  for (const int threads : {1, 3}) {
    std::string first[3];
    const int runs = threads == 1 ? 3 : 2;
    for (int run = 0; run < runs; ++run) {
      const std::string dir = ::testing::TempDir() + "/ctcal_reproducible_t" +
                              std::to_string(threads) + "_" + std::to_string(run);
      std::filesystem::remove_all(dir);
      const test::CliRun r =
          test::RunCtcal("calibrate --rig " + data + "/rig.yaml --data " + data + " --out " + dir +
                             "/out --threads " + std::to_string(threads),
                         dir);
      ASSERT_EQ(r.code, 0) << r.err;
      const char* files[3] = {"result.yaml", "camchain-imucam.yaml", "imu.yaml"};
      for (int f = 0; f < 3; ++f) {
        const std::string text = test::Slurp(dir + "/out/" + files[f]);
        ASSERT_FALSE(text.empty()) << files[f];
        const std::string kept = f == 0 ? WithoutWallTime(text) : text;
        if (run == 0) {
          first[f] = kept;
          continue;
        }
        EXPECT_TRUE(kept == first[f]) << files[f] << " with --threads " << threads << " differs, "
                                      << FirstDifference(first[f], kept);
      }
    }
  }
}

}  // namespace
}  // namespace ctcal
