// `ctcal calibrate --data X.bag` end to end (issue 22 items 1, 2 and 6): `ctcal simulate --bag`
// renders the default rig and writes the same recording as a folder and as one ROS1 bag; the
// folder, ctcal's bag, python3-rosbag's bag of the folder (lz4 chunks) and a ROS2 sqlite3 bag of
// it give the identical corners (byte for byte) and the same calibration (every estimated value
// within 1e-6 of its sigma: the solve's two threads round differently from run to run, ~1e-12
// relative), and it meets the images bar. A bad bag is one line naming the topic, exit 2.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <limits>
#include <string>

#include "../calibrator/issue7_tolerances.h"
#include "cli_test_util.h"
#include "ctcal/sensors/rig_yaml.h"
#include "same_calibration.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;
using test::CliRun;
using test::RunCtcal;

const std::string kScript = std::string(CTCAL_SOURCE_DIR) + "/scripts/ros_bags.py";

bool PythonRosbag() {
  return std::system("/usr/bin/python3 -c 'import rosbag, genpy, cv2' >/dev/null 2>&1") == 0;
}

// 4 s of the `full` scenario, rendered, with its bag; simulated once per process.
fs::path Recording() {
  static fs::path d;
  if (!d.empty())
    return d;
  d = fs::path(::testing::TempDir()) / ("ctcal_bag_" + std::to_string(::getpid()));
  fs::remove_all(d);
  const CliRun r = RunCtcal(
      "simulate --scenario full --seed 31 --duration 4 --perturb coarse --bag "
      "--out " +
          d.string(),
      d.string() + "_simulate");
  EXPECT_EQ(r.code, 0) << r.err;
  return d;
}

fs::path OutOf(const std::string& name) {
  return Recording().string() + "_" + name;
}

RigConfig Calibrate(const std::string& data, const std::string& name) {
  const fs::path out = OutOf(name);
  fs::remove_all(out);
  const CliRun r = RunCtcal("calibrate --rig " + (Recording() / "rig.yaml").string() + " --data " +
                                data + " --out " + out.string() + " --threads 2",
                            out.string() + "_log");
  EXPECT_EQ(r.code, 0) << name << ": " << r.err;
  EXPECT_THAT(r.out, ::testing::HasSubstr("corner detection: cam0 80 images, 80 with the board"))
      << name;
  return LoadRig((out / "result.yaml").string());
}

// The same detections and the same estimates as the folder's run.
void ExpectSameCalibration(const std::string& name) {
  test::ExpectSameCalibration(OutOf(name), OutOf("folder"), {"cam0", "cam1"});
}

TEST(CalibrateBag, FolderAndBagsGiveTheIdenticalCalibration) {
  const fs::path data = Recording();
  ASSERT_TRUE(fs::exists(data / "recording.bag"));
  Calibrate(data.string(), "folder");
  const RigConfig bag = Calibrate((data / "recording.bag").string(), "bag");
  ExpectSameCalibration("bag");

  issue7::Issue7Tolerances tol;
  tol.time_offset_s = 0.3e-3;
  tol.max_sigmas = std::numeric_limits<double>::infinity();
  issue7::ExpectWithinTolerances(LoadRig((data / "truth.yaml").string()), bag,
                                 issue7::Cam1HighOrderDistortion, tol);

  if (!PythonRosbag())
    GTEST_SKIP() << "/usr/bin/python3 cannot import rosbag (Debian's python3-rosbag): the "
                    "independent writer's bags are not tested";
  // Not OutOf(name): Calibrate empties its OUT folder first, and a bag folder there was removed
  // before ctcal ran (it then found an empty folder: "imu0: no such folder").
  const std::string ros1 = data.string() + "_python.bag", ros2 = data.string() + "_ros2_bag";
  ASSERT_EQ(std::system(("/usr/bin/python3 " + kScript + " ros1 " + data.string() + " " + ros1 +
                         " --compression lz4")
                            .c_str()),
            0);
  ASSERT_EQ(
      std::system(("/usr/bin/python3 " + kScript + " ros2 " + data.string() + " " + ros2).c_str()),
      0);
  Calibrate(ros1, "python");
  ExpectSameCalibration("python");
  Calibrate(ros2, "ros2");
  ExpectSameCalibration("ros2");
}

TEST(CalibrateBag, MissingTopicIsOneLineExit2) {
  const fs::path data = Recording();
  const fs::path rig = data.string() + "_rig_missing.yaml";
  RigConfig r = LoadRig((data / "rig.yaml").string());
  for (SensorConfig& s : r.sensors) {
    if (s.name == "cam1")
      s.rostopic = "/camera_1/image";
  }
  SaveRig(r, rig.string());
  const fs::path out = data.string() + "_missing";
  const CliRun run = RunCtcal("calibrate --rig " + rig.string() + " --data " +
                                  (data / "recording.bag").string() + " --out " + out.string(),
                              out.string() + "_log");
  EXPECT_EQ(run.code, 2);
  EXPECT_EQ(test::Lines(run.err), 1) << run.err;
  EXPECT_THAT(run.err, ::testing::HasSubstr("topic '/camera_1/image' (sensor cam1) is not in the "
                                            "bag"));
}

}  // namespace
}  // namespace ctcal
