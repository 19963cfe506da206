// Stage 0 of the initialisation (init/corner_detection.h): a camera given as images only is
// detected with the rig's target, the corners land in the data and in OUT/<camera>/corners.csv
// (read back exactly, at the rendered board's corners), cameras with corners are left alone, and
// unusable images name the stage and the camera.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "ctcal/calibrator/init/corner_detection.h"
#include "ctcal/calibrator/spline_calibrator.h"
#include "ctcal/sensors/camera_model.h"
#include "ctcal/sim/default_rig.h"
#include "ctcal/targets/renderer.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;

// Camera at p_W looking at target_W, x roughly along +x_W, y down (SPEC section 1), rolled.
Eigen::Isometry3d LookAt(const Eigen::Vector3d& p_W, const Eigen::Vector3d& target_W, double roll) {
  const Eigen::Vector3d z = (target_W - p_W).normalized();
  const Eigen::Vector3d x = (Eigen::Vector3d::UnitX() - z * z.x()).normalized();
  Eigen::Matrix3d R_W_C;
  R_W_C << x, z.cross(x), z;
  Eigen::Isometry3d T_W_C = Eigen::Isometry3d::Identity();
  T_W_C.linear() = R_W_C * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_W_C.translation() = p_W;
  return T_W_C;
}

// The default rig's cam0 as a camera-only rig, its images rendered from three poses into
// DATA/cam0/data/ and listed in the SensorData; no corners.
struct Rendered {
  RigConfig rig;
  std::map<std::string, SensorData> data;
  fs::path dir;
  std::vector<Eigen::Isometry3d> T_W_C;
};

Rendered Render(const std::string& tag) {
  Rendered r;
  r.rig = sim::DefaultRig();
  r.rig.sensors = {*r.rig.Find("cam0")};
  r.rig.base_imu = "cam0";
  const SensorConfig& s = r.rig.sensors.front();
  const CameraModel camera = CameraModel::Create(s.camera_model, s.intrinsics, s.distortion_model,
                                                 s.distortion_coeffs, {s.width, s.height});
  const Board board(r.rig.target);
  const BoardRenderer renderer(
      board, s.width, s.height,
      [&](const Eigen::Vector2d& uv, Eigen::Vector3d* ray) { return camera.Unproject(uv, ray); });
  r.dir = fs::path(::testing::TempDir()) /
          ("ctcal_detect_stage_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(r.dir);
  fs::create_directories(r.dir / "cam0" / "data");
  SensorData& d = r.data["cam0"];
  const Eigen::Vector3d centre(0.33, 0.33, 0.0);
  r.T_W_C = {LookAt({0.30, 0.35, 0.75}, centre, 0.05), LookAt({0.45, 0.25, 0.70}, centre, -0.2),
             LookAt({0.20, 0.40, 0.80}, centre, 0.3)};
  for (std::size_t i = 0; i < r.T_W_C.size(); ++i) {
    const ImageEntry e{static_cast<std::int64_t>(1000000000 + 50000000 * i),
                       std::to_string(i) + ".png"};
    cv::imwrite((r.dir / "cam0" / "data" / e.filename).string(),
                renderer.Render(r.T_W_C[i], 11 + i));
    d.images.push_back(e);
  }
  return r;
}

TEST(InitCornerDetection, DetectsImagesOnlyCamerasAndWritesTheCornersIntoOut) {
  Rendered r = Render("ok");
  const fs::path out = r.dir.string() + "_out";
  fs::remove_all(out);
  std::vector<std::string> lines;
  const std::vector<CameraDetectionSummary> summaries =
      DetectMissingCorners(r.rig, r.dir.string(), out.string(), 2, &r.data,
                           [&](const std::string& line) { lines.push_back(line); });
  ASSERT_EQ(summaries.size(), 1u);
  EXPECT_EQ(summaries[0].camera, "cam0");
  EXPECT_EQ(summaries[0].images, 3u);
  EXPECT_EQ(summaries[0].with_board, 3u);
  EXPECT_EQ(summaries[0].unreadable, 0u);
  EXPECT_THAT(lines, ::testing::Contains(::testing::HasSubstr(
                         "corner detection: cam0 3 images, 3 with the board")));

  const SensorData& d = r.data.at("cam0");
  EXPECT_TRUE(d.has_corners);
  EXPECT_EQ(d.corners.size(), summaries[0].corners);
  // The rendered board's corners: every detection within 0.3 px of the projected truth.
  const SensorConfig& s = r.rig.sensors.front();
  const CameraModel camera = CameraModel::Create(s.camera_model, s.intrinsics, s.distortion_model,
                                                 s.distortion_coeffs, {s.width, s.height});
  const Board board(r.rig.target);
  double worst = 0.0;
  for (const CornerObservation& c : d.corners) {
    const std::size_t view = static_cast<std::size_t>((c.t_ns - 1000000000) / 50000000);
    Eigen::Vector2d uv;
    ASSERT_TRUE(camera.Project(r.T_W_C[view].inverse() * board.Corner(c.corner_id), &uv));
    worst = std::max(worst, (uv - Eigen::Vector2d(c.u, c.v)).norm());
    ASSERT_TRUE(c.sigma.has_value());
  }
  EXPECT_GT(d.corners.size(), 150u);
  EXPECT_LT(worst, 0.3);

  // OUT holds exactly the corners used; the dataset folder is untouched.
  EXPECT_FALSE(fs::exists(r.dir / "cam0" / "corners.csv"));
  const std::vector<CornerObservation> back =
      ReadCornersCsv((out / "cam0" / "corners.csv").string(), TargetCornerCount(r.rig.target));
  ASSERT_EQ(back.size(), d.corners.size());
  for (std::size_t i = 0; i < back.size(); ++i) {
    EXPECT_EQ(back[i].t_ns, d.corners[i].t_ns);
    EXPECT_EQ(back[i].corner_id, d.corners[i].corner_id);
    EXPECT_EQ(back[i].u, d.corners[i].u);
    EXPECT_EQ(back[i].v, d.corners[i].v);
    EXPECT_EQ(back[i].sigma, d.corners[i].sigma);
  }

  // A second call finds nothing to detect: cameras with corners are left alone.
  EXPECT_TRUE(DetectMissingCorners(r.rig, r.dir.string(), out.string(), 2, &r.data, {}).empty());
  fs::remove_all(r.dir);
  fs::remove_all(out);
}

// Unreadable images among good ones: one warning line naming the (first) file, the rest detected.
TEST(InitCornerDetection, UnreadableImagesAmongGoodOnesAreOneWarningNamingTheFile) {
  Rendered r = Render("one_unreadable");
  const fs::path out = r.dir.string() + "_out";
  const fs::path bad = r.dir / "cam0" / "data" / "broken.png";
  std::ofstream(bad) << "not a png";
  r.data["cam0"].images.push_back({2000000000, "broken.png"});
  std::vector<std::string> lines;
  const std::vector<CameraDetectionSummary> summaries =
      DetectMissingCorners(r.rig, r.dir.string(), out.string(), 2, &r.data,
                           [&](const std::string& line) { lines.push_back(line); });
  ASSERT_EQ(summaries.size(), 1u);
  EXPECT_EQ(summaries[0].with_board, 3u);
  EXPECT_EQ(summaries[0].unreadable, 1u);
  EXPECT_THAT(lines, ::testing::Contains("warning: cam0: cannot read image " + bad.string() +
                                         ": neither PNG nor JPEG (it starts with 6e 6f 74 20 61 "
                                         "20 70 6e); ctcal reads PNG and JPEG images"));
  fs::remove_all(r.dir);
  fs::remove_all(out);

  CameraDetectionSummary s;
  s.camera = "cam1";
  s.images = 10;
  s.first_error = "cannot read image a.png";
  EXPECT_EQ(UnreadableImagesWarning(s), "");
  s.unreadable = 3;
  EXPECT_EQ(UnreadableImagesWarning(s),
            "warning: cam1: 3 of 10 images could not be read (first: cannot read image a.png)");
  s.unreadable = 10;  // none readable: the stage's error, not a warning
  EXPECT_EQ(UnreadableImagesWarning(s), "");
}

std::string ErrorOf(Rendered& r) {
  try {
    DetectMissingCorners(r.rig, r.dir.string(), r.dir.string() + "_out", 2, &r.data, {});
  } catch (const CalibrationInputError& e) {
    return e.what();
  }
  return "";
}

TEST(InitCornerDetection, UnusableImagesNameTheStageAndTheCamera) {
  Rendered r = Render("bad");
  // The wrong target: the rig says 1-bit tag borders, the images show Kalibr's 2-bit ones (no
  // tag decodes, so no rejection narrows the hint down).
  Rendered other = r;
  other.rig.target.black_tag_border = 1;
  EXPECT_THAT(ErrorOf(other),
              ::testing::AllOf(::testing::HasSubstr("stage 'corner detection', sensor 'cam0'"),
                               ::testing::HasSubstr("the board is in none of its 3 images"),
                               ::testing::HasSubstr("check the rig's target")));

  Rendered empty = r;
  empty.data["cam0"].images.clear();
  EXPECT_THAT(ErrorOf(empty), ::testing::HasSubstr("data.csv lists no image"));

  for (const ImageEntry& e : r.data["cam0"].images)
    fs::resize_file(r.dir / "cam0" / "data" / e.filename, 10);
  EXPECT_THAT(ErrorOf(r), ::testing::HasSubstr("no image could be read"));
  fs::remove_all(r.dir);
}

}  // namespace
}  // namespace ctcal
