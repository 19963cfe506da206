// Board detection along a video: each frame's tags predicted from the frames before and refined
// in place, libapriltag only where the prediction fails (docs/targets.md, "Tracking").
#pragma once

#include <opencv2/core.hpp>

#include <vector>

#include "ctcal/targets/detector.h"

namespace ctcal {

struct TrackingStats {
  int frames = 0;
  int full_detections = 0;  // frames that ran the full detector (libapriltag)
};

// The frames of one camera in time order, one at a time. Each AprilGrid tag of the frame before
// is predicted at its corners moved by their motion between the two frames before (constant
// velocity in the image), refined there and kept only through the full detector's own checks
// (border distance, bit size, refinement jump, its own code word read at the refined corners);
// tags it loses or that come into view are found by the grid completion from their tracked
// neighbours, then the edge offset check, min_tags, the final refinement and the grid scatter
// run as in Detector::Detect. The full detector runs on the first frame, after a frame without
// the board, when tracking keeps fewer than min_tags or half of the frame before's tags, and
// every track_redetect_frames frames while a tag the board puts inside the image is missing.
// Checkerboards and ChArUco boards, and DetectorOptions::refine off, run the full detector on
// every frame. Not thread-safe; one tracker per sequence (the Detector may be shared).
class BoardTracker {
 public:
  explicit BoardTracker(const Detector& detector) : detector_(detector) {}

  // The next frame (any image Detector::Detect takes).
  DetectionResult Next(const cv::Mat& image);
  // Forgets the frames before: the next one is detected in full (a gap in the sequence).
  void Reset();

  const TrackingStats& stats() const { return stats_; }

 private:
  // The tags of the frame before, predicted, refined and checked in `gray`; then the completion,
  // the edge check and min_tags. Not final-refined yet.
  DetectionResult Track(const cv::Mat& gray, double noise_sigma) const;

  const Detector& detector_;
  std::vector<DetectedCorner> previous_;         // frame k-1's corners (empty: no board)
  std::vector<DetectedCorner> before_previous_;  // frame k-2's
  cv::Size previous_size_;
  int previous_tags_ = 0;
  int since_full_ = 0;
  TrackingStats stats_;
};

}  // namespace ctcal
