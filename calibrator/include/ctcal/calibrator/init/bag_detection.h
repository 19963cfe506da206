// The first initialisation stage for a ROS bag (SPEC section 6): the bag is read once, its inertial
// samples kept, and every camera image decoded and detected as it streams, a few at a time on
// worker threads (as the image folders' DetectMissingCorners detects them), so that a long
// recording's images are never all in memory: only the chunks of images waiting for or being
// tracked by a worker and the corners found are.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "ctcal/calibrator/init/corner_detection.h"
#include "ctcal/calibrator/init/init_log.h"
#include "ctcal/sensors/bag_dataset.h"
#include "ctcal/sensors/rig.h"

namespace ctcal {

// Reads every sensor of `rig` from the bag at `path` (LoadBagDataset) and detects the rig's target
// in every camera image, `threads` at a time (0: one per hardware thread). Every camera's corners
// are in the result (has_corners true) and, when `out_dir` is not empty, written to
// `out_dir`/<camera>/corners.csv. An image that does not decode counts as unreadable (a warning,
// as for an image file; an error when all are). Throws std::runtime_error for a bad bag
// (LoadBagDataset's errors) and CalibrationInputError (spline_calibrator.h) for a camera whose
// images are unusable (another resolution than the rig's, no board in any, none readable).
// `track`: each camera's images tracked as a video in chunks (DetectorOptions::track).
std::map<std::string, SensorData> LoadBagAndDetect(
    const RigConfig& rig, const std::string& path, const std::string& out_dir, int threads,
    Warnings* warnings, std::vector<CameraDetectionSummary>* summaries = nullptr,
    const InitLog& log = LogInitToStderr, bool track = true);

}  // namespace ctcal
