// Board detection along a video: each frame's tags predicted from the frames before and refined
// in place, libapriltag only where the prediction fails (docs/targets.md, "Tracking along a
// sequence").
#pragma once

#include <opencv2/core.hpp>

#include <Eigen/Core>

#include <array>
#include <vector>

#include "ctcal/targets/detector.h"

namespace ctcal {

struct TrackingStats {
  int frames = 0;
  int full_detections = 0;  // frames that ran the full detector (libapriltag)
};

// The frames of one camera in time order, one at a time. Each AprilGrid tag of the frame before
// is predicted at its corners extrapolated from the three frames before (constant acceleration
// in the image; velocity with two), refined there and kept only through the full detector's own
// checks (border distance, bit size, refinement jump, its own code word read at the refined
// corners); tags it loses or that come into view are found by the grid completion from their
// tracked neighbours, then the edge offset check, min_tags, the final refinement and the grid
// scatter run as in Detector::Detect. When tracking keeps fewer than min_tags or half of the frame
// before's tags, it tries once more from the frame before's corners moved by the image's shift
// (phase correlation). The full detector runs on the first frame, after a frame without the
// board, when that fails too, and every track_redetect_frames frames while a tag the board puts
// inside the image is missing (there without its full-resolution pass: the frame is tracked).
// Checkerboards and ChArUco boards, DetectorOptions::track off and DetectorOptions::refine off
// run the full detector on every frame. Not thread-safe; one tracker per sequence (the Detector may
// be shared).
class BoardTracker {
 public:
  explicit BoardTracker(const Detector& detector) : detector_(detector) {}

  // The next frame (any image Detector::Detect takes).
  DetectionResult Next(const cv::Mat& image);
  // Forgets the frames before: the next one is detected in full (a gap in the sequence).
  void Reset();

  const TrackingStats& stats() const { return stats_; }

 private:
  // The tags of the frames before, predicted (moved by `shift` from frame k-1 when given),
  // refined and checked in `gray`; then the completion, the edge check and min_tags. Not
  // final-refined yet.
  DetectionResult Track(const cv::Mat& gray, double noise_sigma,
                        const Eigen::Vector2d* shift) const;

  const Detector& detector_;
  // Corners of frames k-1, k-2, k-3 (empty: no board, or before the sequence's start).
  std::array<std::vector<DetectedCorner>, 3> history_;
  cv::Mat previous_gray_;  // frame k-1
  int previous_tags_ = 0;
  int since_full_ = 0;
  TrackingStats stats_;
};

}  // namespace ctcal
