// Two runs of `ctcal calibrate` on the same recording in two containers (an image folder, a ROS1
// bag, a ROS2 bag) must give the same calibration: the same detections, byte for byte, and the
// same estimates. Shared by apps_calibrate_bag and apps_kalibr_path.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "cli_test_util.h"
#include "ctcal/sensors/parameter_names.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal::test {

// OUT/<camera>/corners.csv of `cameras` equal to REFERENCE's, and every scalar REFERENCE's
// result.yaml estimates within 1e-6 of its sigma in OUT's: the detections being identical, only
// the solve's threads may round differently from run to run (~1e-12 relative).
inline void ExpectSameCalibration(const std::filesystem::path& out,
                                  const std::filesystem::path& reference,
                                  const std::vector<std::string>& cameras) {
  for (const std::string& cam : cameras) {
    const std::string corners = Slurp((out / cam / "corners.csv").string());
    EXPECT_FALSE(corners.empty()) << out << " " << cam;
    EXPECT_EQ(corners, Slurp((reference / cam / "corners.csv").string())) << out << " " << cam;
  }
  const RigConfig result = LoadRig((out / "result.yaml").string());
  const RigConfig expected = LoadRig((reference / "result.yaml").string());
  for (const ScalarParameter& p : ScalarParameters(expected, true)) {
    const double sigma = ParameterSigma(expected, p).value_or(0.0);
    EXPECT_NEAR(ParameterValue(result, p), ParameterValue(expected, p), 1e-6 * sigma + 1e-15)
        << out << " " << p.name;
  }
}

}  // namespace ctcal::test
