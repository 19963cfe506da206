// `ctcal compare --projection`: two lens fits of one camera in different models, from a
// .cameramodel and a rig file; the numbers, the JSON and the map; bad input in one line.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "cli_test_util.h"
#include "ctcal/sensors/camera_model.h"
#include "ctcal/sensors/mrcal_model.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;
using test::RunCtcal;
using test::Slurp;

// A pinhole-radtan camera as a .cameramodel (mrcal's OPENCV4) against the same lens as mrcal's
// OPENCV8 in a rig file: no difference. The same rig with fx 0.2 % longer: the difference grows
// to the image corners and the map and JSON are written.
TEST(CompareProjection, SameLensInTwoModelsAndAKnownChange) {
  const std::string dir = (fs::path(::testing::TempDir()) / "ctcal_compare_projection").string();
  fs::create_directories(dir);
  const CameraModel radtan =
      CameraModel::Create("pinhole", {458.654, 457.296, 367.215, 248.375}, "radtan",
                          {-0.2834, 0.07396, 1.9e-4, 1.8e-5}, Eigen::Vector2i(752, 480));
  SaveMrcalCameraModel(dir + "/radtan.cameramodel", radtan);
  const auto rig = [&](double fx) {
    return "base_imu: cam0\n"
           "target: {target_type: aprilgrid, tagCols: 6, tagRows: 6, tagSize: 0.088, "
           "tagSpacing: 0.3}\n"
           "sensors:\n  cam0:\n    type: camera\n    camera_model: mrcal\n"
           "    lensmodel: LENSMODEL_OPENCV8\n    intrinsics: [" +
           std::to_string(fx) +
           ", 457.296, 367.215, 248.375, -0.2834, 0.07396, 1.9e-4, 1.8e-5, 0, 0, 0, 0]\n"
           "    resolution: [752, 480]\n";
  };
  std::ofstream(dir + "/same.yaml") << rig(458.654);
  std::ofstream(dir + "/longer.yaml") << rig(458.654 * 1.002);

  const test::CliRun same =
      RunCtcal("compare --projection --a " + dir + "/radtan.cameramodel --b " + dir +
                   "/same.yaml --json " + dir + "/same.json",
               dir + "/run_same");
  ASSERT_EQ(same.code, 0) << same.err;
  EXPECT_NE(same.out.find("pinhole radtan"), std::string::npos) << same.out;
  EXPECT_NE(same.out.find("mrcal LENSMODEL_OPENCV8"), std::string::npos) << same.out;
  const std::string json = Slurp(dir + "/same.json");
  const double max_same = std::stod(json.substr(json.find("\"max_px\": ") + 10));
  EXPECT_LT(max_same, 1e-6) << json;

  const test::CliRun longer = RunCtcal(
      "compare --projection --a " + dir + "/radtan.cameramodel --b " + dir +
          "/longer.yaml --b-camera cam0 --map " + dir + "/map.png --json " + dir + "/longer.json",
      dir + "/run_longer");
  ASSERT_EQ(longer.code, 0) << longer.err;
  const std::string json2 = Slurp(dir + "/longer.json");
  const double max_longer = std::stod(json2.substr(json2.find("\"max_px\": ") + 10));
  // 0.2 % of fx at the farthest grid column from cx (~360 px) is ~0.7 px; a fitted rotation
  // takes a part of it.
  EXPECT_GT(max_longer, 0.2) << json2;
  EXPECT_LT(max_longer, 1.0) << json2;
  EXPECT_GT(fs::file_size(dir + "/map.png"), 1000u);

  const test::CliRun bad = RunCtcal("compare --projection --a " + dir + "/radtan.cameramodel --b " +
                                        dir + "/same.yaml --b-camera cam7",
                                    dir + "/run_bad");
  EXPECT_EQ(bad.code, 2);
  EXPECT_EQ(test::Lines(bad.err), 1) << bad.err;
  EXPECT_NE(bad.err.find("no camera named 'cam7'"), std::string::npos) << bad.err;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace ctcal
