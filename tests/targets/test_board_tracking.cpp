// BoardTracker on rendered sequences of a pinhole-radtan 752x480 camera (EuRoC cam0) moving over
// the 6x6 AprilGrid: its corners against the true projections and against the full detector's,
// with slow, fast and jumping motion, the board leaving the image, views in which every junction
// stays in place but the ids move (the board shifted by one tag, turned by 90 degrees), and
// DetectFiles' chunks on 1 and 2 threads.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <vector>

#include "ctcal/sensors/camera_model.h"
#include "ctcal/targets/board_tracking.h"
#include "ctcal/targets/detector.h"
#include "ctcal/targets/renderer.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;

const CameraModel& EurocCam0() {
  static const CameraModel camera = CameraModel::Create(
      "pinhole", {458.654, 457.296, 367.215, 248.375}, "radtan",
      {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05}, Eigen::Vector2i(752, 480));
  return camera;
}

// The camera at `p_W` looking down at the board (z_W = 0) with tilts `a` (about its y axis) and
// `b` (about its optical axis).
Eigen::Isometry3d Looking(const Eigen::Vector3d& p_W, double a, double b) {
  Eigen::Isometry3d T_W_C = Eigen::Isometry3d::Identity();
  T_W_C.linear() = (Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()) *
                    Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()) *
                    Eigen::AngleAxisd(b, Eigen::Vector3d::UnitZ()))
                       .toRotationMatrix();
  T_W_C.translation() = p_W;
  return T_W_C;
}

// A smooth path over the board at 20 frames/s; `speed` scales every frequency.
Eigen::Isometry3d Smooth(int frame, double speed) {
  const double t = speed * frame / 20.0;
  return Looking({0.33 + 0.12 * std::sin(1.3 * t), 0.33 + 0.08 * std::sin(0.9 * t + 1.0),
                  0.8 + 0.1 * std::sin(0.7 * t)},
                 0.15 * std::sin(1.1 * t), 0.3 + 0.2 * std::sin(0.8 * t));
}

struct Sequence {
  std::vector<Eigen::Isometry3d> poses;
  std::vector<cv::Mat> images;
};

Sequence Render(const Board& board, int frames, const std::function<Eigen::Isometry3d(int)>& pose) {
  const BoardRenderer renderer(board, 752, 480,
                               [](const Eigen::Vector2d& uv, Eigen::Vector3d* ray) {
                                 return EurocCam0().Unproject(uv, ray);
                               });
  Sequence s;
  for (int k = 0; k < frames; ++k) {
    s.poses.push_back(pose(k));
    s.images.push_back(renderer.Render(s.poses.back(), 100 + static_cast<uint64_t>(k)));
  }
  return s;
}

// Errors of a sequence's corners against the true projections (px).
struct Errors {
  int corners = 0;
  double rms = 0.0;
  double max = 0.0;
};

Errors Compare(const Board& board, const Sequence& s, const std::vector<DetectionResult>& results) {
  Errors e;
  double sum2 = 0.0;
  for (size_t k = 0; k < results.size(); ++k) {
    const Eigen::Isometry3d T_C_W = s.poses[k].inverse();
    for (const DetectedCorner& c : results[k].corners) {
      Eigen::Vector2d truth;
      EXPECT_TRUE(EurocCam0().Project(T_C_W * board.Corner(c.id), &truth));
      const double d = (c.uv - truth).norm();
      sum2 += d * d;
      e.max = std::max(e.max, d);
      ++e.corners;
    }
  }
  e.rms = e.corners > 0 ? std::sqrt(sum2 / e.corners) : 0.0;
  return e;
}

struct Runs {
  std::vector<DetectionResult> tracked, full;
  TrackingStats stats;
};

Runs DetectBoth(const Detector& detector, const Sequence& s) {
  Runs run;
  BoardTracker tracker(detector);
  for (const cv::Mat& image : s.images) {
    run.tracked.push_back(tracker.Next(image));
    run.full.push_back(detector.Detect(image));
  }
  run.stats = tracker.stats();
  return run;
}

// A wrong id puts a corner a junction (>= 2 bits, ~8 px here) from its truth; the full detector's
// corners on these views are within 0.4 px.
constexpr double kMaxErrorPx = 0.5;

void ExpectRightIds(const Board& board, const Sequence& s, const Runs& run, const char* name,
                    double max_rms = 0.06) {
  const Errors tracked = Compare(board, s, run.tracked);
  const Errors full = Compare(board, s, run.full);
  std::printf(
      "%s: tracked %d corners RMS %.4f max %.3f px, full %d corners RMS %.4f max %.3f px, "
      "%d of %d frames ran the full detector\n",
      name, tracked.corners, tracked.rms, tracked.max, full.corners, full.rms, full.max,
      run.stats.full_detections, run.stats.frames);
  EXPECT_LE(tracked.max, kMaxErrorPx) << name;
  EXPECT_LE(tracked.rms, max_rms) << name;
  EXPECT_LE(tracked.rms, full.rms + 0.002) << name;
  // Tracking loses no more than a few corners against the full detector.
  EXPECT_GE(tracked.corners, full.corners * 95 / 100) << name;
}

// The 6x6 grid's sequence of `frames` frames along `pose`, detected by both and checked.
Runs CheckSequence(const char* name, int frames, const std::function<Eigen::Isometry3d(int)>& pose,
                   double max_rms = 0.06) {
  const Board board{TargetConfig{}};
  const Sequence s = Render(board, frames, pose);
  const Runs run = DetectBoth(Detector(board), s);
  ExpectRightIds(board, s, run, name, max_rms);
  return run;
}

TEST(BoardTracking, SmoothMotionAsAccurateAsTheFullDetector) {
  const Runs run = CheckSequence("smooth", 40, [](int k) { return Smooth(k, 1.0); });
  // Tracking does the work: libapriltag on the first frame and a few more at most.
  EXPECT_LE(run.stats.full_detections, 2);
  for (const DetectionResult& r : run.tracked) {
    EXPECT_TRUE(r.board_found);
    EXPECT_GT(r.model_sigma_px, 0.0);
    for (const DetectedCorner& c : r.corners)
      EXPECT_GT(c.sigma, 0.0);
  }
}

TEST(BoardTracking, FastMotionFallsBackWithoutWrongCorners) {
  // Six times the speed: 20-60 px between frames, the velocity changing by tens of pixels.
  CheckSequence("fast", 30, [](int k) { return Smooth(k, 6.0); });
}

TEST(BoardTracking, JumpingViewsFallBackWithoutWrongCorners) {
  // Unrelated views: every prediction is far off.
  const Runs run = CheckSequence("jumping", 12, [](int k) { return Smooth(37 * k, 1.0); });
  EXPECT_GE(run.stats.full_detections, 10);
}

TEST(BoardTracking, BoardLeavingTheImage) {
  // Across the board and past its edge (~25 px per frame), then back.
  const Runs run = CheckSequence("leaving", 40, [](int k) {
    const double x = 0.33 + 0.9 * std::sin(M_PI * k / 39.0);
    return Looking({x, 0.3, 0.75}, 0.05, 0.2);
  });
  int partial = 0;
  for (const DetectionResult& r : run.tracked)
    partial += r.board_found && r.tags_accepted < 30 ? 1 : 0;
  EXPECT_GE(partial, 10);
}

// Every junction of the new view lies where one of the old view's lies, so each prediction
// refines onto a junction; only the code read at the refined corners tells that the tag there is
// another one.
TEST(BoardTracking, IdsMoveWhileTheJunctionsStay) {
  const Board board{TargetConfig{}};
  const double pitch = board.config().tag_size * (1.0 + board.config().tag_spacing);
  const Eigen::Isometry3d base = Looking({0.33, 0.33, 0.9}, 0.0, 0.0);
  // Turned by 90 degrees about the square board's centre: the grid maps onto itself.
  Eigen::Isometry3d turned = Eigen::Isometry3d::Identity();
  turned.translation() = Eigen::Vector3d(0.33, 0.33, 0.0);
  turned.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  turned = turned * Eigen::Translation3d(-0.33, -0.33, 0.0) * base;
  const std::vector<Eigen::Isometry3d> poses = {
      base, base, Eigen::Translation3d(pitch, 0.0, 0.0) * base, turned, turned, base};
  // Straight down at the whole board: the lens' strong rim distortion, for both detectors alike.
  const Runs run = CheckSequence(
      "ids moved", static_cast<int>(poses.size()),
      [&](int k) { return poses[static_cast<size_t>(k)]; }, 0.15);
  // The shift by one tag is the image's shift too: the retry from it tracks the tags at their new
  // places; the turn needs the full detector. Either way each id is where it is printed.
  EXPECT_GE(run.stats.full_detections, 3);
}

TEST(BoardTracking, StaticViewEqualsTheFullDetector) {
  const Board board{TargetConfig{}};
  const Detector detector(board);
  const Sequence one = Render(board, 1, [](int) { return Smooth(5, 1.0); });
  const DetectionResult full = detector.Detect(one.images[0]);
  ASSERT_TRUE(full.board_found);
  BoardTracker tracker(detector);
  for (int k = 0; k < 5; ++k) {
    const DetectionResult tracked = tracker.Next(one.images[0]);
    ASSERT_EQ(tracked.corners.size(), full.corners.size()) << "frame " << k;
    for (size_t i = 0; i < full.corners.size(); ++i) {
      EXPECT_EQ(tracked.corners[i].id, full.corners[i].id);
      // The refinement stops at steps of a thousandth of a pixel.
      EXPECT_LE((tracked.corners[i].uv - full.corners[i].uv).norm(), 0.005) << "frame " << k;
      EXPECT_NEAR(tracked.corners[i].sigma, full.corners[i].sigma, 0.002) << "frame " << k;
    }
    EXPECT_NEAR(tracked.model_sigma_px, full.model_sigma_px, 0.002);
  }
  EXPECT_EQ(tracker.stats().full_detections, 1);
}

TEST(BoardTracking, DetectFilesSameOnOneAndTwoThreads) {
  const Board board{TargetConfig{}};
  const Sequence s = Render(board, 25, [](int k) { return Smooth(k, 2.0); });
  const fs::path dir =
      fs::path(::testing::TempDir()) / ("ctcal_tracking_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::vector<std::string> paths;
  for (size_t k = 0; k < s.images.size(); ++k) {
    paths.push_back((dir / (std::to_string(k) + ".png")).string());
    ASSERT_TRUE(cv::imwrite(paths.back(), s.images[k]));
  }
  DetectorOptions options;
  options.track_chunk_frames = 7;  // four chunks, the last one short
  options.threads = 1;
  const std::vector<DetectionResult> a = Detector(board, options).DetectFiles(paths);
  options.threads = 2;
  const std::vector<DetectionResult> b = Detector(board, options).DetectFiles(paths);
  // Three workers on four chunks: one is left without a chunk early and reads files ahead of
  // the others' trackers.
  options.threads = 3;
  const std::vector<DetectionResult> c = Detector(board, options).DetectFiles(paths);
  // An unreadable file inside a chunk that is read ahead: the same error and tracker reset.
  { std::ofstream(paths[17], std::ios::trunc) << "not a PNG"; }
  options.threads = 1;
  const std::vector<DetectionResult> broken_a = Detector(board, options).DetectFiles(paths);
  options.threads = 3;
  const std::vector<DetectionResult> broken_c = Detector(board, options).DetectFiles(paths);
  options.track = false;
  ASSERT_TRUE(cv::imwrite(paths[17], s.images[17]));
  const std::vector<DetectionResult> untracked = Detector(board, options).DetectFiles(paths);
  fs::remove_all(dir);
  const auto expect_same = [](const std::vector<DetectionResult>& x,
                              const std::vector<DetectionResult>& y, const std::string& what) {
    ASSERT_EQ(x.size(), y.size()) << what;
    for (size_t k = 0; k < x.size(); ++k) {
      ASSERT_EQ(x[k].corners.size(), y[k].corners.size()) << what << " frame " << k;
      EXPECT_EQ(x[k].error, y[k].error) << what << " frame " << k;
      for (size_t i = 0; i < x[k].corners.size(); ++i) {
        EXPECT_EQ(x[k].corners[i].id, y[k].corners[i].id);
        EXPECT_EQ(x[k].corners[i].uv, y[k].corners[i].uv) << what << " frame " << k;
        EXPECT_EQ(x[k].corners[i].sigma, y[k].corners[i].sigma) << what << " frame " << k;
      }
    }
  };
  expect_same(a, b, "2 threads");
  expect_same(a, c, "3 threads");
  expect_same(broken_a, broken_c, "an unreadable file, 3 threads");
  for (size_t k = 0; k < a.size(); ++k)
    EXPECT_EQ(a[k].image_width, 752);
  EXPECT_NE(broken_c[17].error.find(paths[17]), std::string::npos) << broken_c[17].error;
  EXPECT_TRUE(broken_c[17].corners.empty());
  EXPECT_TRUE(broken_c[18].board_found);  // the next frame starts the tracker again
  const Errors tracked = Compare(board, s, a);
  const Errors full = Compare(board, s, untracked);
  EXPECT_LE(tracked.rms, 0.06);
  EXPECT_LE(tracked.max, kMaxErrorPx);
  EXPECT_GE(tracked.corners, full.corners * 95 / 100);
}

}  // namespace
}  // namespace ctcal
