// The first initialisation stage (issue 7, "corners detected if only images are given"): a camera
// whose folder has data.csv and images but no corners.csv (SPEC section 6) is detected before
// anything else runs, with the rig's target (SPEC section 7) and the targets library's detector,
// images in parallel. The corners used are written into the calibration's output folder, never
// into the dataset, so that a run can be repeated and audited without touching its input.
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "ctcal/calibrator/init/init_log.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig.h"
#include "ctcal/targets/detector.h"

namespace ctcal {

// What detection found in one camera's images.
struct CameraDetectionSummary {
  std::string camera;
  std::size_t images = 0;      // listed in data.csv
  std::size_t unreadable = 0;  // could not be read or decoded
  std::size_t with_board = 0;  // a valid board observation
  std::size_t corners = 0;
  std::size_t full_detections = 0;  // images the full detector ran on (the others: tracked)
  std::map<RejectReason, std::size_t> rejected;  // tags (corners, views) dropped, by reason
  std::string first_error;                       // of the first unreadable image
  double seconds = 0.0;                          // wall time of the detection
  std::string summary;                           // one line, also logged
};

// The detector's results on one camera's images (results[i] of images[i]) as corners in SPEC
// section 6 rows: the image's stamp, the corner id, the pixel and the detector's sigma. Fills the
// counts of `summary` (images, unreadable and the first error, with_board, corners, rejected),
// leaving its camera, time and line alone. The one conversion of the detection stage and of
// `ctcal detect`.
std::vector<CornerObservation> CornersFromDetections(const std::vector<ImageEntry>& images,
                                                     const std::vector<DetectionResult>& results,
                                                     CameraDetectionSummary* summary);

// "warning: <camera>: <first error>" when one of several images could not be read, "warning:
// <camera>: N of M images could not be read (first: <first error>)" for several; empty when none
// or all were unreadable (all: an error, not a warning). The first error names the file.
std::string UnreadableImagesWarning(const CameraDetectionSummary& summary);

// The end of one camera's detection (its counts in `summary`, seconds set): throws InitError when
// no image could be read or none shows the board (with a hint from the rejections), else sets
// summary->summary and logs it and UnreadableImagesWarning's line.
void FinishCameraDetection(CameraDetectionSummary* summary, const InitLog& log);

// Detects the board in every image of one camera (`image_dir`/<filename> for each entry of
// `images`, the camera's data.csv) and returns the corners in SPEC section 6 rows: the image's
// stamp, the corner id, the pixel and the detector's sigma. Logs progress per tenth of the
// images, the summary line and UnreadableImagesWarning's line. Throws InitError (stage "corner
// detection", the camera) when data.csv lists no image, when no image can be read, when an image's
// size is not the camera's resolution, or when no image shows the board (with a hint from the
// rejections: a larger board or another border width than the target file says).
std::vector<CornerObservation> DetectCameraCorners(const SensorConfig& camera,
                                                   const Detector& detector,
                                                   const std::string& image_dir,
                                                   const std::vector<ImageEntry>& images,
                                                   CameraDetectionSummary* summary,
                                                   const InitLog& log = LogInitToStderr);

// For every camera of `rig` whose `data` has no corners.csv (SensorData::has_corners false):
// detects its images in `data_dir`/<camera>/data/ with the rig's target, `threads` images at a
// time (0: one per hardware thread), stores the corners in `data` (has_corners becomes true) and
// writes them to `out_dir`/<camera>/corners.csv. Cameras with corners are left alone; returns one
// summary per detected camera (none when every camera has corners). Throws CalibrationInputError
// (spline_calibrator.h) with InitError's message for a camera whose images are unusable, and
// std::runtime_error when a corners file cannot be written. `track`: each camera's images (in
// data.csv's order) tracked as a video (DetectorOptions::track) rather than detected one by one.
std::vector<CameraDetectionSummary> DetectMissingCorners(const RigConfig& rig,
                                                         const std::string& data_dir,
                                                         const std::string& out_dir, int threads,
                                                         std::map<std::string, SensorData>* data,
                                                         const InitLog& log = LogInitToStderr,
                                                         bool track = true);

}  // namespace ctcal
