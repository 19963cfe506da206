// `--images`: the rendered frames and the simulated corners agree. The board detector finds, in
// each rendered image, the corners the simulator projected (corners_true), at the same ids and
// pixels: the simulator, the renderer and the detector share SPEC's board frame, corner
// numbering, pixel convention and clocks.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <opencv2/imgcodecs.hpp>

#include "ctcal/sim/default_rig.h"
#include "ctcal/sim/image_writer.h"
#include "ctcal/sim/scenario.h"
#include "ctcal/sim/simulator.h"
#include "ctcal/targets/board.h"
#include "ctcal/targets/detector.h"

namespace ctcal::sim {
namespace {

namespace fs = std::filesystem;

TEST(Images, DetectedCornersMatchTheSimulatedOnes) {
  RigConfig rig = DefaultRig();
  rig.Find("cam1")->line_delay = 2e-5;  // one rolling-shutter camera
  const auto traj = MakeTrajectory(Scenario::kFull, SceneFor(rig.target));
  SimOptions options;
  options.duration = 0.25;
  options.seed = 5;
  const SimulatedDataset data = Simulate(rig, *traj, options);
  const fs::path dir =
      fs::path(::testing::TempDir()) / ("ctcal_sim_images_" + std::to_string(::getpid()));
  RenderImages(data, *traj, dir.string(), 5);

  const Detector detector{Board(rig.target)};
  for (const CameraData& cam : data.cameras) {
    std::map<std::pair<std::int64_t, int>, Eigen::Vector2d> simulated;
    for (const SimulatedCorner& c : cam.corners)
      simulated[{c.t_ns, c.corner_id}] = c.uv_true;
    std::vector<double> errors;
    std::size_t missing = 0;
    for (const std::int64_t ns : cam.frames_ns) {
      const fs::path file = dir / cam.sensor / "data" / (std::to_string(ns) + ".png");
      const cv::Mat image = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
      ASSERT_FALSE(image.empty()) << file;
      const DetectionResult result = detector.Detect(image);
      for (const DetectedCorner& d : result.corners) {
        const auto it = simulated.find({ns, d.id});
        if (it == simulated.end()) {
          ++missing;  // detected but not simulated as visible
          continue;
        }
        errors.push_back((it->second - d.uv).norm());
      }
    }
    ASSERT_FALSE(errors.empty()) << cam.sensor;
    std::sort(errors.begin(), errors.end());
    std::printf("%s: %zu of %zu simulated corners detected, error median %.3f px, 95%% %.3f px\n",
                cam.sensor.c_str(), errors.size(), cam.corners.size(), errors[errors.size() / 2],
                errors[errors.size() * 95 / 100]);
    // Most simulated corners are found, at the simulated pixel (the renderer adds blur and noise,
    // the detector refines to a fraction of a pixel).
    EXPECT_GT(errors.size(), cam.corners.size() / 2) << cam.sensor;
    EXPECT_LT(errors[errors.size() / 2], 0.15) << cam.sensor;
    EXPECT_LT(errors[errors.size() * 95 / 100], 0.5) << cam.sensor;
    EXPECT_LE(missing, errors.size() / 20) << cam.sensor;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace ctcal::sim
