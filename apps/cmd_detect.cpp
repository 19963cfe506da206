// `ctcal detect --target TARGET.yaml --data DATA [--camera camN]` (SPEC section 8): detects the
// board in every image of DATA/camN/data.csv and writes DATA/camN/corners.csv (SPEC section 6,
// with the sigma column). Without --camera, every DATA/cam*/ folder with a data.csv.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <unistd.h>

#include "cli_common.h"
#include "commands.h"
#include "ctcal/calibrator/init/corner_detection.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/targets/detector.h"

namespace ctcal::app {
namespace {

namespace fs = std::filesystem;

// Detects one camera's images; returns an exit code.
int DetectCamera(const CommandLine& cli, const Detector& detector, const fs::path& camera_dir) {
  const std::string camera = camera_dir.filename().string();
  std::vector<ImageEntry> images;
  try {
    images = ReadImageCsv((camera_dir / "data.csv").string(), /*check_images=*/true);
  } catch (const std::exception& e) {
    return cli.InputError(e.what());
  }
  if (images.empty())
    return cli.InputError((camera_dir / "data.csv").string() + ": no images listed");
  std::vector<std::string> paths;
  paths.reserve(images.size());
  for (const ImageEntry& image : images)
    paths.push_back((camera_dir / "data" / image.filename).string());

  // A live counter on a terminal; in a log, a line per tenth of the images.
  const bool tty = isatty(fileno(stderr));
  const std::vector<DetectionResult> results =
      detector.DetectFiles(paths, [&](size_t done, size_t total) {
        if (tty && (done % 10 == 0 || done == total)) {
          std::fprintf(stderr, "\r%s: %zu/%zu images", camera.c_str(), done, total);
          if (done == total)
            std::fprintf(stderr, "\n");
        } else if (!tty && total >= 50 && done % (total / 10) == 0) {
          std::fprintf(stderr, "%s: %zu/%zu images\n", camera.c_str(), done, total);
        }
      });

  CameraDetectionSummary found;
  found.camera = camera;
  const std::vector<CornerObservation> corners = CornersFromDetections(images, results, &found);
  if (found.unreadable == results.size())
    return cli.InputError("no image of " + camera + " could be read (" + found.first_error + ")");

  std::printf("%s: %zu images, %zu with the board, %.1f corners per image with the board",
              camera.c_str(), results.size(), found.with_board,
              found.with_board > 0 ? static_cast<double>(corners.size()) / found.with_board : 0.0);
  if (found.unreadable > 0)
    std::printf(", %zu unreadable", found.unreadable);
  if (detector.options().track)
    std::printf(", %zu tracked", results.size() - found.unreadable - found.full_detections);
  std::printf("\n");
  const std::string warning = UnreadableImagesWarning(found);
  if (!warning.empty())
    std::fprintf(stderr, "%s\n", warning.c_str());
  // What a rejection counts: AprilGrid rules drop tags; checkerboard and ChArUco rules drop
  // corners, except ChArUco's marker rules (ids not on the board, duplicates).
  const TargetType type = detector.board().type();
  const auto noun = [type](RejectReason reason) {
    if (reason == RejectReason::kTooFewTags || reason == RejectReason::kNotThisBoard)
      return "views";
    if (type == TargetType::kAprilGrid)
      return "tags";
    if (type == TargetType::kCharuco &&
        (reason == RejectReason::kUnknownId || reason == RejectReason::kDuplicateId))
      return "markers";
    return "corners";
  };
  for (const auto& [reason, count] : found.rejected)
    std::printf("  rejected: %zu %s (%s)\n", count, noun(reason), ToString(reason));
  if (found.with_board == 0) {
    std::string hint = "check the target file";
    if (found.rejected.count(RejectReason::kUnknownId) ||
        found.rejected.count(RejectReason::kNotThisBoard))
      hint = "ids beyond this board were seen: a larger board, or the wrong target file?";
    else if (found.rejected.count(RejectReason::kBadBorder))
      hint = "tags with another border width were seen: check blackTagBorder";
    return cli.RunFailed("no board found in any image of " + camera + " (" + hint + ")");
  }
  const std::string out = (camera_dir / "corners.csv").string();
  try {
    WriteCornersCsv(out, corners);
  } catch (const std::exception& e) {
    return cli.RunFailed(e.what());
  }
  std::printf("  wrote %s (%zu corners)\n", out.c_str(), corners.size());
  return kExitOk;
}

}  // namespace

int RunDetect(int argc, char** argv) {
  namespace po = boost::program_options;
  CommandLine cli("detect", "--target TARGET.yaml --data DATA [--camera cam0]",
                  "Detect the board in every image of DATA/<camera>/data.csv and write "
                  "DATA/<camera>/corners.csv (timestamp,corner_id,u,v,sigma).");
  std::string target_path, data_dir, camera;
  int threads = 0;
  cli.options().add_options()("target", po::value(&target_path)->required(),
                              "target file (Kalibr's aprilgrid or checkerboard, or charuco)")(
      "data", po::value(&data_dir)->required(), "dataset folder (SPEC section 6)")(
      "camera", po::value(&camera),
      "camera folder name (default: every DATA/cam* folder with a data.csv)")(
      "threads", po::value(&threads)->default_value(0),
      "images detected in parallel (0: one per hardware thread)")(
      "no-track", po::bool_switch(),
      "detect the board in every image on its own instead of tracking it through the camera's "
      "images (docs/targets.md)");
  if (const auto exit_code = cli.Parse(argc, argv))
    return *exit_code;

  std::unique_ptr<Detector> detector;
  try {
    DetectorOptions options;
    options.threads = threads;
    options.track = !cli.vm()["no-track"].as<bool>();
    detector = std::make_unique<Detector>(Board(LoadTargetConfig(target_path)), options);
  } catch (const std::exception& e) {
    return cli.InputError(e.what());
  }
  if (!fs::is_directory(data_dir))
    return cli.InputError(data_dir + ": no such dataset folder");
  std::vector<fs::path> cameras;
  if (!camera.empty()) {
    if (!fs::exists(fs::path(data_dir) / camera / "data.csv"))
      return cli.InputError((fs::path(data_dir) / camera / "data.csv").string() + ": not found");
    cameras.push_back(fs::path(data_dir) / camera);
  } else {
    for (const fs::directory_entry& entry : fs::directory_iterator(data_dir)) {
      const std::string name = entry.path().filename().string();
      if (entry.is_directory() && name.rfind("cam", 0) == 0 &&
          fs::exists(entry.path() / "data.csv"))
        cameras.push_back(entry.path());
    }
    std::sort(cameras.begin(), cameras.end());
    if (cameras.empty())
      return cli.InputError(data_dir + ": no cam*/data.csv to detect (use --camera NAME)");
  }
  for (const fs::path& camera_dir : cameras) {
    if (const int code = DetectCamera(cli, *detector, camera_dir); code != kExitOk)
      return code;
  }
  return kExitOk;
}

}  // namespace ctcal::app
