#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "ctcal/calibrator/init/corner_detection.h"
#include "ctcal/calibrator/spline_calibrator.h"

namespace ctcal {

namespace {

namespace fs = std::filesystem;

constexpr const char* kStage = "corner detection";

// Why no image showed the board, from what the detector rejected.
std::string NoBoardHint(const std::map<RejectReason, std::size_t>& rejected) {
  if (rejected.count(RejectReason::kUnknownId) || rejected.count(RejectReason::kNotThisBoard))
    return "tag ids beyond the rig's target were seen: a larger board, or the wrong target?";
  if (rejected.count(RejectReason::kBadBorder))
    return "tags with another border width were seen: check the target's blackTagBorder";
  if (rejected.count(RejectReason::kTooFewTags))
    return "views with too few tags: the board too small, too far or cut off?";
  return "check the rig's target";
}

}  // namespace

std::vector<CornerObservation> CornersFromDetections(const std::vector<ImageEntry>& images,
                                                     const std::vector<DetectionResult>& results,
                                                     CameraDetectionSummary* summary) {
  CameraDetectionSummary& s = *summary;
  s.images = images.size();
  s.unreadable = s.with_board = s.corners = s.full_detections = 0;
  s.rejected.clear();
  s.first_error.clear();
  std::vector<CornerObservation> corners;
  for (std::size_t i = 0; i < results.size(); ++i) {
    const DetectionResult& r = results[i];
    if (!r.error.empty()) {
      if (s.unreadable++ == 0)
        s.first_error = r.error;  // names the file
      continue;
    }
    s.full_detections += r.full_detection ? 1 : 0;
    for (const TagRejection& rejection : r.rejected)
      ++s.rejected[rejection.reason];
    if (!r.board_found)
      continue;
    ++s.with_board;
    for (const DetectedCorner& c : r.corners)
      corners.push_back({images[i].t_ns, c.id, c.uv.x(), c.uv.y(), c.sigma});
  }
  s.corners = corners.size();
  return corners;
}

std::string UnreadableImagesWarning(const CameraDetectionSummary& summary) {
  if (summary.unreadable == 0 || summary.unreadable == summary.images)
    return "";
  if (summary.unreadable == 1)
    return "warning: " + summary.camera + ": " + summary.first_error;
  return "warning: " + summary.camera + ": " + std::to_string(summary.unreadable) + " of " +
         std::to_string(summary.images) +
         " images could not be read (first: " + summary.first_error + ")";
}

void FinishCameraDetection(CameraDetectionSummary* summary, const InitLog& log) {
  CameraDetectionSummary& s = *summary;
  const std::string& camera = s.camera;
  if (s.unreadable == s.images)
    throw InitError(kStage, camera, "no image could be read (first: " + s.first_error + ")");
  if (s.with_board == 0)
    throw InitError(kStage, camera,
                    "the board is in none of its " + std::to_string(s.images) + " images (" +
                        NoBoardHint(s.rejected) + ")");

  char line[400];
  std::snprintf(line, sizeof line,
                "%s: %s %zu images, %zu with the board, %.1f corners per view, %zu unreadable, "
                "%zu tracked, %.1f s",
                kStage, camera.c_str(), s.images, s.with_board,
                static_cast<double>(s.corners) / static_cast<double>(s.with_board), s.unreadable,
                s.images - s.unreadable - s.full_detections, s.seconds);
  s.summary = line;
  const std::string warning = UnreadableImagesWarning(s);
  if (log) {
    log(s.summary);
    if (!warning.empty())
      log(warning);
  }
}

std::vector<CornerObservation> DetectCameraCorners(
    const SensorConfig& sensor, const Detector& detector, const std::string& image_dir,
    const std::vector<ImageEntry>& images, CameraDetectionSummary* summary, const InitLog& log) {
  const std::string& camera = sensor.name;
  CameraDetectionSummary s;
  s.camera = camera;
  s.images = images.size();
  if (images.empty())
    throw InitError(kStage, camera,
                    "data.csv lists no image and there is no corners.csv: nothing to calibrate "
                    "the camera from");
  std::vector<std::string> paths;
  paths.reserve(images.size());
  for (const ImageEntry& image : images)
    paths.push_back((fs::path(image_dir) / image.filename).string());

  // Detection is the longest step before the solve on a large recording: a line per tenth.
  const auto start = std::chrono::steady_clock::now();
  const std::size_t step = std::max<std::size_t>(1, images.size() / 10);
  const std::vector<DetectionResult> results =
      detector.DetectFiles(paths, [&](std::size_t done, std::size_t total) {
        if (log && done % step == 0 && done < total) {
          char line[160];
          std::snprintf(line, sizeof line, "%s: %s %zu of %zu images", kStage, camera.c_str(), done,
                        total);
          log(line);
        }
      });
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  // An image of another size is another camera's (or the rig's resolution is wrong): its corners
  // would be fitted with this camera's intrinsics.
  for (std::size_t i = 0; i < results.size(); ++i) {
    const DetectionResult& r = results[i];
    if (r.image_width != 0 && (r.image_width != sensor.width || r.image_height != sensor.height))
      throw InitError(kStage, camera,
                      paths[i] + " is " + std::to_string(r.image_width) + "x" +
                          std::to_string(r.image_height) + " pixels, the rig's resolution is " +
                          std::to_string(sensor.width) + "x" + std::to_string(sensor.height));
  }

  const std::vector<CornerObservation> corners = CornersFromDetections(images, results, &s);
  FinishCameraDetection(&s, log);
  if (summary)
    *summary = s;
  return corners;
}

std::vector<CameraDetectionSummary> DetectMissingCorners(const RigConfig& rig,
                                                         const std::string& data_dir,
                                                         const std::string& out_dir, int threads,
                                                         std::map<std::string, SensorData>* data,
                                                         const InitLog& log, bool track) {
  std::vector<CameraDetectionSummary> summaries;
  std::unique_ptr<Detector> detector;  // built once, for the first camera that needs it
  for (const SensorConfig& sensor : rig.sensors) {
    if (sensor.type != SensorType::kCamera)
      continue;
    const auto it = data->find(sensor.name);
    if (it == data->end() || it->second.has_corners)
      continue;
    SensorData& d = it->second;
    try {
      if (!detector) {
        DetectorOptions options;
        options.threads = threads;
        options.track = track;
        detector = std::make_unique<Detector>(Board(rig.target), options);
      }
      CameraDetectionSummary summary;
      d.corners = DetectCameraCorners(sensor, *detector,
                                      (fs::path(data_dir) / sensor.name / "data").string(),
                                      d.images, &summary, log);
      summaries.push_back(std::move(summary));
    } catch (const InitError& e) {
      throw CalibrationInputError(e.what());
    }
    d.has_corners = true;
    const std::string path = (fs::path(out_dir) / sensor.name / "corners.csv").string();
    WriteCornersCsv(path, d.corners);
    if (log)
      log(std::string(kStage) + ": wrote " + path);
  }
  return summaries;
}

}  // namespace ctcal
