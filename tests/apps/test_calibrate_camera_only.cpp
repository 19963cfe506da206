// `ctcal calibrate` on a camera-only rig (SPEC section 7) runs the camera calibration end to end on
// the real EuRoC stereo detections and writes Kalibr's camchain.yaml beside the result; asked for
// `--method both`, it says the method does not apply and writes the one camera-only result.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "ctcal/sensors/rig_yaml.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;

TEST(CalibrateCameraOnly, EurocStereoRunsEndToEndAndWritesCamchain) {
  const fs::path data = fs::path(CTCAL_SHARED_DATA_DIR) / "euroc_cam_april";
  if (!fs::exists(data / "reference.yaml")) {
    GTEST_SKIP() << "the shared EuRoC data is absent (" << data << ")";
  }
  const fs::path out = fs::path(::testing::TempDir()) / "ctcal_camonly_cli";
  fs::remove_all(out);
  const std::string cmd = std::string(CTCAL_BINARY) + " calibrate --rig " +
                          (data / "reference.yaml").string() + " --data " + data.string() +
                          " --out " + out.string() + " --method both > " + (out.string() + ".log") +
                          " 2>&1";
  const int status = std::system(cmd.c_str());
  std::ostringstream log;
  log << std::ifstream(out.string() + ".log").rdbuf();
  // EuRoC's published rig states 1 px for corners that fit to ~0.2 px (issue 19): the report's
  // whitened RMS checks fail, so `calibrate` exits 3 (SPEC section 8) until the noise is estimated
  // from the data; no other check may fail.
  ASSERT_TRUE(WIFEXITED(status));
  ASSERT_TRUE(WEXITSTATUS(status) == 0 || WEXITSTATUS(status) == 3) << "see " << out << ".log";
  std::istringstream lines(log.str());
  for (std::string line; std::getline(lines, line);)
    if (line.rfind("check failed:", 0) == 0) {
      EXPECT_NE(line.find("whitened RMS"), std::string::npos) << line;
    }
  EXPECT_NE(log.str().find("note: --method both does not apply to a rig without IMUs"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(out / "spline"));
  EXPECT_TRUE(fs::exists(out / "camchain.yaml"));
  EXPECT_FALSE(fs::exists(out / "camchain-imucam.yaml"));
  const RigConfig result = LoadRig((out / "result.yaml").string());
  ASSERT_TRUE(result.solver.has_value());
  EXPECT_EQ(result.solver->method, "camera_only");
  const SensorConfig* cam0 = result.Find("cam0");
  ASSERT_NE(cam0, nullptr);
  // Starting from the published calibration, the 30 nearly alike views keep the principal point
  // within a few px of it (the focal is weakly determined and may move ~20 px: see
  // docs/camera_only.md).
  EXPECT_NEAR(cam0->intrinsics[2], 367.2, 10.0);
  EXPECT_NEAR(cam0->intrinsics[3], 248.4, 10.0);
  ASSERT_NE(cam0->sigma.Find("intrinsics"), nullptr);
}

}  // namespace
}  // namespace ctcal
