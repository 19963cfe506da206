// `ctcal simulate` end to end: the files of SPEC sections 6-7 read back by the sensors' strict
// readers, byte-identical reruns, and one clear error line for bad options.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

#include "../apps/cli_test_util.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig_yaml.h"
#include "ctcal/sim/default_rig.h"

namespace ctcal::sim {
namespace {

namespace fs = std::filesystem;

using test::Slurp;

test::CliRun RunCtcal(const std::string& args) {
  // One folder per process: ctest -j runs the tests of this file in parallel processes.
  return test::RunCtcal("simulate " + args,
                        ::testing::TempDir() + "/ctcal_sim_cli_" + std::to_string(::getpid()));
}

class SimulateCli : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(CTCAL_BINARY))
      GTEST_SKIP() << "the ctcal executable is not built: " << CTCAL_BINARY;
    root_ = fs::path(::testing::TempDir()) / ("ctcal_sim_" + std::to_string(::getpid()));
    fs::remove_all(root_);
  }
  void TearDown() override { fs::remove_all(root_); }
  std::string Dir(const std::string& name) const { return (root_ / name).string(); }

  fs::path root_;
};

// Every regular file under dir, relative path -> contents.
std::map<std::string, std::string> Files(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (e.is_regular_file())
      files[fs::relative(e.path(), dir).string()] = Slurp(e.path());
  }
  return files;
}

TEST_F(SimulateCli, SameSeedSameBytesOtherSeedOtherData) {
  ASSERT_EQ(RunCtcal("--scenario full --seed 7 --duration 3 --out " + Dir("a")).code, 0);
  ASSERT_EQ(RunCtcal("--scenario full --seed 7 --duration 3 --out " + Dir("b")).code, 0);
  ASSERT_EQ(RunCtcal("--scenario full --seed 8 --duration 3 --out " + Dir("c")).code, 0);
  const auto a = Files(Dir("a")), b = Files(Dir("b")), c = Files(Dir("c"));
  EXPECT_EQ(a.size(), 14u);  // 5 sensors x 2 files, groundtruth, 3 yaml files
  EXPECT_EQ(a, b);
  for (const char* f : {"imu0/data.csv", "imu1/data.csv", "gyro0/data.csv", "cam0/corners.csv",
                        "rig.yaml", "imu0/biases.csv"})
    EXPECT_NE(a.at(f), c.at(f)) << f;
  // The truth does not depend on the seed except for the biases.
  EXPECT_EQ(a.at("truth.yaml"), c.at("truth.yaml"));
}

TEST_F(SimulateCli, WritesTheSpecLayoutThatTheReadersAccept) {
  const test::CliRun r =
      RunCtcal("--scenario yaw --seed 1 --duration 2 --perturb table4 --out " + Dir("d"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("cam0"), std::string::npos);  // progress on the terminal
  const RigConfig truth = LoadRig(Dir("d") + "/truth.yaml");
  ASSERT_TRUE(truth.gravity_W.has_value());
  EXPECT_EQ(*truth.gravity_W, Eigen::Vector3d(0.0, 0.0, -9.81));
  RigConfig expected = DefaultRig();
  expected.gravity_W = truth.gravity_W;
  EXPECT_EQ(truth, expected);
  const RigConfig guess = LoadRig(Dir("d") + "/rig.yaml");
  EXPECT_FALSE(guess.gravity_W.has_value());
  EXPECT_FALSE(guess.Find("cam1")->prior_sigma.empty());
  EXPECT_NE(guess.Find("imu1")->D_w, truth.Find("imu1")->D_w);
  EXPECT_EQ(LoadTargetConfig(Dir("d") + "/target.yaml").tag_cols, 6);

  Warnings warnings;
  const auto data = LoadDataset(Dir("d"), guess, &warnings);
  EXPECT_TRUE(warnings.empty());
  EXPECT_EQ(data.at("imu0").imu.size(), 501u);
  EXPECT_NEAR(static_cast<double>(data.at("imu1").imu.size()), 600.0, 1.0);
  EXPECT_NEAR(static_cast<double>(data.at("gyro0").gyro.size()), 400.0, 1.0);
  EXPECT_TRUE(data.at("cam0").has_corners);
  EXPECT_GT(data.at("cam0").corners.size(), 40u * 100);
  EXPECT_EQ(data.at("cam0").corners.front().sigma, std::optional<double>(1.0));
  const auto gt = ReadGroundTruthCsv(Dir("d") + "/groundtruth/data.csv");
  ASSERT_EQ(gt.size(), 501u);
  EXPECT_EQ(gt.front().t_ns, data.at("imu0").imu.front().t_ns);
  EXPECT_EQ(ReadBiasesCsv(Dir("d") + "/gyro0/biases.csv", false).size(),
            data.at("gyro0").gyro.size());
  EXPECT_EQ(ReadBiasesCsv(Dir("d") + "/imu1/biases.csv", true).size(), data.at("imu1").imu.size());
}

TEST_F(SimulateCli, SimulatesAUserRig) {
  RigConfig rig = DefaultRig();
  rig.Find("cam0")->line_delay = 2e-5;
  rig.sensors.erase(rig.sensors.begin() + 2);  // no gyro0
  fs::create_directories(root_);
  SaveRig(rig, Dir("user.yaml"));
  const test::CliRun r = RunCtcal("--scenario planar --seed 2 --duration 1 --rig " +
                                  Dir("user.yaml") + " --out " + Dir("e"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(fs::exists(Dir("e") + "/gyro0"));
  EXPECT_EQ(LoadRig(Dir("e") + "/truth.yaml").Find("cam0")->line_delay, 2e-5);
}

TEST_F(SimulateCli, ImagesReplaceTheCornersByRenderedFrames) {
  const test::CliRun r =
      RunCtcal("--scenario full --seed 3 --duration 0.2 --images --out " + Dir("i"));
  ASSERT_EQ(r.code, 0) << r.err;
  for (const std::string cam : {"cam0", "cam1"}) {
    EXPECT_FALSE(fs::exists(Dir("i") + "/" + cam + "/corners.csv"));
    const auto truth = ReadCornersCsv(Dir("i") + "/" + cam + "/corners_true.csv", 144);
    EXPECT_GT(truth.size(), 100u);
    EXPECT_FALSE(truth.front().sigma.has_value());
    // data.csv lists every rendered image, and each exists.
    const auto images = ReadImageCsv(Dir("i") + "/" + cam + "/data.csv", /*check_images=*/true);
    EXPECT_GE(images.size(), 4u);
  }
}

// Simulating into a folder of an earlier run that this run would leave half stale is one clear
// error: corners.csv beside new rendered images (calibrate would not detect), or rendered images
// beside new corners.csv (detect would use the old images).
TEST_F(SimulateCli, RefusesToLeaveAnEarlierRunsCameraFilesStale) {
  ASSERT_EQ(RunCtcal("--scenario full --seed 3 --duration 0.2 --images --out " + Dir("i")).code, 0);
  test::CliRun r = RunCtcal("--scenario full --seed 4 --duration 0.2 --out " + Dir("i"));
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_NE(r.err.find("cam0 holds an earlier --images run"), std::string::npos) << r.err;

  ASSERT_EQ(RunCtcal("--scenario full --seed 3 --duration 0.2 --out " + Dir("c")).code, 0);
  r = RunCtcal("--scenario full --seed 4 --duration 0.2 --images --out " + Dir("c"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("cam0/corners.csv is from an earlier run"), std::string::npos) << r.err;
  // The same kind of run again simply rewrites its files.
  EXPECT_EQ(RunCtcal("--scenario full --seed 5 --duration 0.2 --out " + Dir("c")).code, 0);
}

TEST_F(SimulateCli, BadOptionsGiveOneClearLine) {
  fs::create_directories(root_);
  std::ofstream(Dir("file")) << "x";
  const struct {
    std::string args;
    std::string says;
  } cases[] = {
      {"--scenario loop --seed 1 --out " + Dir("x"), "unknown scenario 'loop'"},
      {"--scenario full --seed 1 --duration -2 --out " + Dir("x"), "--duration"},
      {"--scenario full --seed 1 --duration abc --out " + Dir("x"), "duration"},
      {"--scenario full --seed 1 --out " + Dir("file") + "/sub", "output folder"},
      {"--scenario full --seed 1 --perturb wild --out " + Dir("x"), "perturbation 'wild'"},
      {"--scenario full --seed 1 --rig " + Dir("missing.yaml") + " --out " + Dir("x"),
       "missing.yaml"},
      {"--scenario full --out " + Dir("x"), "seed"},
      {"--scenario full --seed -1 --out " + Dir("x"), "--seed must be an integer"},
  };
  for (const auto& c : cases) {
    const test::CliRun r = RunCtcal(c.args);
    EXPECT_EQ(r.code, 2) << c.args;
    EXPECT_NE(r.err.find(c.says), std::string::npos) << c.args << "\n" << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(r.err.rfind("ctcal simulate: error: ", 0), 0u) << r.err;
  }
  EXPECT_EQ(RunCtcal("--help").code, 0);
}

}  // namespace
}  // namespace ctcal::sim
