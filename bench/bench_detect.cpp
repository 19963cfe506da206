// Board detection and rendering speed, single thread (per core) and two threads: images per second
// for the AprilGrid detector at 752x480 and 1280x800 (rendered views of the 6x6 grid filling ~half
// the image, and EuRoC's real image), the checkerboard detector (opencv-doc's left01.jpg), and the
// renderer's frames per second; and a rendered 752x480 video tracked (BoardTracker) against the
// same frames detected one by one; and reading EuRoC's real 752x480 PNG and a rendered one as the
// simulator writes it (ReadImageFile against cv::imread). Numbers go to docs/performance.md,
// sections "Detection" and "Detection tracking", and issue 23's "process start".
#include <benchmark/benchmark.h>

#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <filesystem>
#include <vector>

#include "ctcal/targets/board_tracking.h"
#include "ctcal/targets/detector.h"
#include "ctcal/targets/image_file.h"
#include "ctcal/targets/renderer.h"

namespace ctcal {
namespace {

// A pinhole camera of the given size with a 90 degree horizontal field of view.
UnprojectFunction Pinhole(int width, int height) {
  const double f = 0.5 * width;
  return [=](const Eigen::Vector2d& uv, Eigen::Vector3d* ray) {
    *ray = Eigen::Vector3d((uv.x() - 0.5 * (width - 1)) / f, (uv.y() - 0.5 * (height - 1)) / f, 1);
    return true;
  };
}

// Looking down at the 6x6 grid's centre from 0.75 m with a small tilt.
Eigen::Isometry3d View() {
  Eigen::Isometry3d T_W_C = Eigen::Isometry3d::Identity();
  T_W_C.linear() = (Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()) *
                    Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY()) *
                    Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()))
                       .toRotationMatrix();
  T_W_C.translation() = Eigen::Vector3d(0.45, 0.33, 0.75);
  return T_W_C;
}

void DetectRendered(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  const Board board{TargetConfig{}};
  const cv::Mat image =
      BoardRenderer(board, width, height, Pinhole(width, height)).Render(View(), 1);
  const Detector detector(board);
  size_t corners = 0;
  for (auto _ : state) {
    const DetectionResult result = detector.Detect(image);
    corners = result.corners.size();
    benchmark::DoNotOptimize(corners);
  }
  state.counters["corners"] = static_cast<double>(corners);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(DetectRendered)->Args({752, 480})->Args({1280, 800})->Unit(benchmark::kMillisecond);
// Two images at a time, as `ctcal detect --threads 2` runs them (one libapriltag detector per
// concurrent call): images per second of the whole process (real time).
BENCHMARK(DetectRendered)
    ->Args({752, 480})
    ->Args({1280, 800})
    ->Threads(2)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// 60 frames at 20 Hz of a camera moving over the grid (0.1 m and 0.2 rad amplitudes, 3-10 px
// between frames), rendered once; decoding is not part of the figures.
const std::vector<cv::Mat>& Video() {
  static const std::vector<cv::Mat> frames = [] {
    const Board board{TargetConfig{}};
    const BoardRenderer renderer(board, 752, 480, Pinhole(752, 480));
    std::vector<cv::Mat> out;
    for (int k = 0; k < 60; ++k) {
      const double t = k / 20.0;
      Eigen::Isometry3d T_W_C = View();
      T_W_C.linear() = T_W_C.linear() *
                       Eigen::AngleAxisd(0.2 * std::sin(1.1 * t), Eigen::Vector3d::UnitZ()) *
                       Eigen::AngleAxisd(0.1 * std::sin(0.8 * t), Eigen::Vector3d::UnitY());
      T_W_C.translation() += Eigen::Vector3d(0.1 * std::sin(1.3 * t), 0.05 * std::cos(t), 0.0);
      out.push_back(renderer.Render(T_W_C, static_cast<uint64_t>(k)));
    }
    return out;
  }();
  return frames;
}

// Images per second of the 60-frame video, tracked from a full detection on its first frame
// (`state.range(0)` = 1) or every frame detected in full (0).
void DetectVideo(benchmark::State& state) {
  const std::vector<cv::Mat>& frames = Video();
  const Detector detector{Board(TargetConfig{})};
  size_t corners = 0;
  int full = 0;
  for (auto _ : state) {
    BoardTracker tracker(detector);
    corners = 0;
    for (const cv::Mat& image : frames)
      corners += (state.range(0) ? tracker.Next(image) : detector.Detect(image)).corners.size();
    full = state.range(0) ? tracker.stats().full_detections : static_cast<int>(frames.size());
    benchmark::DoNotOptimize(corners);
  }
  state.counters["corners_per_frame"] = static_cast<double>(corners) / frames.size();
  state.counters["full_detections"] = full;
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(frames.size()));
}
BENCHMARK(DetectVideo)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// The noise estimate every frame needs (EstimateNoiseSigma), alone.
void NoiseSigma(benchmark::State& state) {
  const cv::Mat& image = Video().front();
  double sigma = 0.0;
  for (auto _ : state) {
    sigma = EstimateNoiseSigma(image);
    benchmark::DoNotOptimize(sigma);
  }
  state.counters["sigma"] = sigma;
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(NoiseSigma)->Unit(benchmark::kMicrosecond);

void DetectFile(benchmark::State& state, const std::string& path, const TargetConfig& config) {
  if (!std::filesystem::exists(path)) {
    state.SkipWithError((path + " is absent").c_str());
    return;
  }
  const cv::Mat image = ReadImageFile(path);
  const Detector detector{Board(config)};
  size_t corners = 0;
  for (auto _ : state) {
    corners = detector.Detect(image).corners.size();
    benchmark::DoNotOptimize(corners);
  }
  state.counters["corners"] = static_cast<double>(corners);
  state.SetItemsProcessed(state.iterations());
}

// EuRoC's real image. bench/ has no CTCAL_SHARED_DATA_DIR: the shared data sit beside the
// worktree, which holds build/bench/bench_detect.
std::string EurocPng() {
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe");
  return (exe.parent_path() / ".." / ".." / ".." / "shared" / "data" / "aprilgrid" / "EuRoC.png")
      .lexically_normal()
      .string();
}

void DetectEurocReal(benchmark::State& state) {
  DetectFile(state, EurocPng(), TargetConfig{});
}
BENCHMARK(DetectEurocReal)->Unit(benchmark::kMillisecond);

// Reading a 752x480 8-bit PNG: ctcal's reader (its direct decoder, png_direct.h) against cv::imread
// (libpng). EuRoC's file holds its pixels in stored deflate blocks (no compression); the rendered
// one is zlib level 1 as WritePngFile and cv::imwrite write it, where the inflate is most of the
// time.
std::string RenderedPng() {
  static const std::string path = [] {
    const Board board{TargetConfig{}};
    const std::string p =
        (std::filesystem::temp_directory_path() / "ctcal_bench_rendered.png").string();
    WritePngFile(p, BoardRenderer(board, 752, 480, Pinhole(752, 480)).Render(View(), 1));
    return p;
  }();
  return path;
}
template <cv::Mat (*Read)(const std::string&), std::string (*Path)()>
void ReadPng(benchmark::State& state) {
  const std::string path = Path();
  if (!std::filesystem::exists(path)) {
    state.SkipWithError((path + " is absent").c_str());
    return;
  }
  for (auto _ : state) {
    const cv::Mat image = Read(path);
    benchmark::DoNotOptimize(image.data);
  }
  state.SetItemsProcessed(state.iterations());
}
cv::Mat CvImread(const std::string& path) {
  return cv::imread(path, cv::IMREAD_UNCHANGED);
}
BENCHMARK(ReadPng<ReadImageFile, EurocPng>)
    ->Name("ReadEurocPng/ReadImageFile")
    ->Unit(benchmark::kMillisecond);
BENCHMARK(ReadPng<CvImread, EurocPng>)
    ->Name("ReadEurocPng/cv::imread")
    ->Unit(benchmark::kMillisecond);
BENCHMARK(ReadPng<ReadImageFile, RenderedPng>)
    ->Name("ReadRenderedPng/ReadImageFile")
    ->Unit(benchmark::kMillisecond);
BENCHMARK(ReadPng<CvImread, RenderedPng>)
    ->Name("ReadRenderedPng/cv::imread")
    ->Unit(benchmark::kMillisecond);

void DetectCheckerboardReal(benchmark::State& state) {
  TargetConfig config;
  config.type = TargetType::kCheckerboard;
  config.target_rows = 6;
  config.target_cols = 9;
  config.row_spacing_m = 0.025;
  config.col_spacing_m = 0.025;
  DetectFile(state, "/usr/share/doc/opencv-doc/examples/data/left01.jpg", config);
}
BENCHMARK(DetectCheckerboardReal)->Unit(benchmark::kMillisecond);

void Render(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  const Board board{TargetConfig{}};
  const BoardRenderer renderer(board, width, height, Pinhole(width, height));
  uint64_t seed = 0;
  for (auto _ : state) {
    const cv::Mat image = renderer.Render(View(), ++seed);
    benchmark::DoNotOptimize(image.data);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(Render)->Args({752, 480})->Args({1280, 800})->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace ctcal

BENCHMARK_MAIN();
