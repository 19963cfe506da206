// `ctcal calibrate` on a recording whose cameras are images only (issue 7: "Kalibr-style rendered
// images only, detection included"): `ctcal simulate --images` renders the default rig's board
// views and writes no corners.csv, the calibrator detects them itself (stage 'corner detection'),
// writes the corners it used into OUT and not into the dataset, and from the coarse guess meets
// the issue's bar: rotations 0.05 deg, translations 3 mm, time offsets 0.3 ms, focal 1 px.
// Unusable images stop in that stage with one line naming it and the camera.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "../calibrator/issue7_tolerances.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;

struct CliRun {
  int exit_code = -1;
  std::string out;  // stdout
  std::string err;  // stderr
};

std::string ReadText(const fs::path& path) {
  std::ifstream f(path);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

CliRun Ctcal(const std::string& args, const fs::path& log_stem) {
  const std::string cmd = std::string(CTCAL_BINARY) + " " + args + " > " + log_stem.string() +
                          ".out 2> " + log_stem.string() + ".err";
  CliRun r;
  const int status = std::system(cmd.c_str());
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = ReadText(log_stem.string() + ".out");
  r.err = ReadText(log_stem.string() + ".err");
  return r;
}

// `seconds` of the `full` scenario, the default rig (imu0, imu1, gyro0, cam0 pinhole-radtan,
// cam1 pinhole-equidistant, 20 Hz each), rendered, from the coarse guess; simulated once per
// process (ctest runs each test in a process of its own).
fs::path RenderedDataset(int seconds) {
  static std::map<int, fs::path> done;
  if (const auto it = done.find(seconds); it != done.end())
    return it->second;
  const fs::path d = fs::path(::testing::TempDir()) / ("ctcal_images_" + std::to_string(seconds) +
                                                       "s_" + std::to_string(::getpid()));
  fs::remove_all(d);
  const CliRun r =
      Ctcal("simulate --scenario full --seed 31 --duration " + std::to_string(seconds) +
                " --perturb coarse --images --out " + d.string(),
            d.string() + "_simulate");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return done[seconds] = d;
}

// Corners of a corners.csv by (stamp, id).
std::map<std::pair<std::int64_t, int>, Eigen::Vector2d> ById(
    const std::vector<CornerObservation>& corners) {
  std::map<std::pair<std::int64_t, int>, Eigen::Vector2d> out;
  for (const CornerObservation& c : corners)
    out[{c.t_ns, c.corner_id}] = Eigen::Vector2d(c.u, c.v);
  return out;
}

TEST(CalibrateImages, RenderedImagesOnlyMeetTheIssueBar) {
  const fs::path data = RenderedDataset(4);  // 160 images
  for (const char* cam : {"cam0", "cam1"}) {
    ASSERT_TRUE(fs::exists(data / cam / "data.csv")) << cam;
    ASSERT_FALSE(fs::exists(data / cam / "corners.csv")) << cam << ": nothing to detect";
  }
  const fs::path out = data.string() + "_out";
  fs::remove_all(out);
  const CliRun r = Ctcal("calibrate --rig " + (data / "rig.yaml").string() + " --data " +
                             data.string() + " --out " + out.string() + " --threads 2",
                         out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, ::testing::HasSubstr("corner detection: cam0 80 images, 80 with the board"));
  EXPECT_THAT(r.out, ::testing::HasSubstr("corner detection: cam1 80 images"));

  // The corners used are in OUT, the dataset is untouched, and they are the rendered board's
  // corners (the simulator's noise-free projections) to a tenth of a pixel.
  const RigConfig rig = LoadRig((data / "rig.yaml").string());
  const int num_corners = TargetCornerCount(rig.target);
  for (const char* cam : {"cam0", "cam1"}) {
    EXPECT_FALSE(fs::exists(data / cam / "corners.csv")) << cam;
    const std::vector<CornerObservation> used =
        ReadCornersCsv((out / cam / "corners.csv").string(), num_corners);
    const auto truth =
        ById(ReadCornersCsv((data / cam / "corners_true.csv").string(), num_corners));
    std::vector<double> errors;
    for (const auto& [key, uv] : ById(used)) {
      const auto it = truth.find(key);
      ASSERT_NE(it, truth.end()) << cam << ": corner " << key.second << " is not in view";
      errors.push_back((uv - it->second).norm());
    }
    ASSERT_GT(errors.size(), 0.8 * static_cast<double>(truth.size())) << cam;
    std::sort(errors.begin(), errors.end());
    const double median = errors[errors.size() / 2];
    const double p95 = errors[errors.size() * 95 / 100];
    std::printf("%s: %zu of %zu corners detected, error median %.3f px, 95 %% %.3f px\n", cam,
                errors.size(), truth.size(), median, p95);
    EXPECT_LT(median, 0.1) << cam;
  }

  // The issue's bar for images (0.3 ms instead of the corners' 0.5 ms). The sigmas rest on the
  // detector's per-corner sigma, which does not see the corner model's error (docs/targets.md),
  // so they are printed, not checked, here.
  issue7::Issue7Tolerances tol;
  tol.time_offset_s = 0.3e-3;
  tol.max_sigmas = std::numeric_limits<double>::infinity();
  const RigConfig truth = LoadRig((data / "truth.yaml").string());
  const RigConfig result = LoadRig((out / "result.yaml").string());
  issue7::ExpectWithinTolerances(truth, result, issue7::Cam1HighOrderDistortion, tol);
}

// Replaces every image of `camera` in a copy of the rendered dataset by `image` (or by a file
// that is no image when `image` is empty) and returns the copy.
fs::path DatasetWithImages(const std::string& tag, const std::string& camera,
                           const cv::Mat& image) {
  const fs::path src = RenderedDataset(1);  // 40 images
  const fs::path dst = src.string() + "_" + tag;
  fs::remove_all(dst);
  fs::copy(src, dst, fs::copy_options::recursive);
  for (const fs::directory_entry& e : fs::directory_iterator(dst / camera / "data")) {
    if (image.empty()) {
      std::ofstream(e.path()) << "not a png\n";
    } else {
      cv::imwrite(e.path().string(), image);
    }
  }
  return dst;
}

// Calibrates a copy made by DatasetWithImages and removes it.
CliRun CalibrateCopy(const fs::path& data) {
  const CliRun r = Ctcal("calibrate --rig " + (data / "rig.yaml").string() + " --data " +
                             data.string() + " --out " + data.string() + "_out",
                         data.string() + "_out");
  fs::remove_all(data);
  fs::remove_all(data.string() + "_out");
  return r;
}

// One stderr line, the input-error exit code, the stage and the camera named.
void ExpectOneLineError(const CliRun& r, const std::string& what) {
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr("stage 'corner detection', sensor 'cam0'"));
  EXPECT_THAT(r.err, ::testing::HasSubstr(what));
}

TEST(CalibrateImages, ImagesWithoutTheBoardNameStageAndCamera) {
  const cv::Mat grey(480, 752, CV_8UC1, cv::Scalar(128));
  ExpectOneLineError(CalibrateCopy(DatasetWithImages("blank", "cam0", grey)),
                     "the board is in none of its 20 images");
}

TEST(CalibrateImages, UnreadableImagesNameStageAndCamera) {
  ExpectOneLineError(CalibrateCopy(DatasetWithImages("unreadable", "cam0", cv::Mat())),
                     "no image could be read");
}

// data.csv without rows and no corners.csv: nothing to calibrate the camera from.
TEST(CalibrateImages, EmptyImageListNamesStageAndCamera) {
  const fs::path src = RenderedDataset(1);  // 40 images
  const fs::path dst = src.string() + "_empty";
  fs::remove_all(dst);
  fs::copy(src, dst, fs::copy_options::recursive);
  std::ofstream(dst / "cam0" / "data.csv") << "#timestamp [ns],filename\n";
  ExpectOneLineError(CalibrateCopy(dst), "data.csv lists no image");
}

}  // namespace
}  // namespace ctcal
