// BoardTracker (board_tracking.h): AprilGrid tags followed from frame to frame.
#include "ctcal/targets/board_tracking.h"

#include <algorithm>
#include <set>

#include "detector_internal.h"

namespace ctcal {

using namespace internal;  // NOLINT(build/namespaces): detector_internal.h's passes

void BoardTracker::Reset() {
  previous_.clear();
  before_previous_.clear();
  previous_tags_ = 0;
  since_full_ = 0;
}

DetectionResult BoardTracker::Track(const cv::Mat& gray, double noise_sigma) const {
  const Board& board = detector_.board();
  const DetectorOptions& options = detector_.options();
  const TagCorners previous = TagsOfCorners(board, previous_);
  const TagCorners before = TagsOfCorners(board, before_previous_);
  DetectionResult result;
  // Ids a rule decided on: the completion must not bring them back (as in the full detector).
  std::set<int> decided;
  for (const auto& [id, uv] : previous) {
    // Constant velocity in the image: at 20 Hz a corner's motion changes little from one frame
    // to the next, and the capture window takes up what it does (docs/targets.md).
    std::array<Eigen::Vector2d, 4> predicted = uv;
    const auto it = before.find(id);
    if (it != before.end()) {
      for (size_t k = 0; k < 4; ++k)
        predicted[k] += uv[k] - it->second[k];
    }
    ++result.tags_detected;
    std::array<DetectedCorner, 4> refined;
    const std::optional<RejectReason> reason =
        AcceptTag(gray, noise_sigma, board, options, id, predicted, &refined);
    if (!reason) {
      result.corners.insert(result.corners.end(), refined.begin(), refined.end());
      ++result.tags_accepted;
    } else if (*reason == RejectReason::kNearBorder) {
      // A tag that left the image is not looked for again; a tag that was lost (the prediction
      // too far off) is, from its neighbours, by the completion.
      result.rejected.push_back({id, *reason});
      decided.insert(id);
    }
  }
  CompleteGrid(gray, noise_sigma, board, options, decided, &result);
  DropTagsOffTheirEdges(gray, board, options, &result);
  FinishTagView(options, &result);
  return result;
}

DetectionResult BoardTracker::Next(const cv::Mat& image) {
  ++stats_.frames;
  const DetectorOptions& options = detector_.options();
  if (detector_.board().type() != TargetType::kAprilGrid || !options.refine) {
    ++stats_.full_detections;
    return detector_.Detect(image);
  }
  DetectionResult result;
  cv::Mat gray;
  double noise_sigma = 0.0;
  if (!detector_.PrepareGray(image, &gray, &noise_sigma, &result)) {
    Reset();
    return result;
  }
  if (gray.size() != previous_size_)
    Reset();
  previous_size_ = gray.size();
  bool tracked = false;
  if (!previous_.empty()) {
    result = Track(gray, noise_sigma);
    tracked = result.tags_accepted >= std::max(options.min_tags, (previous_tags_ + 1) / 2);
  }
  // Tracking finds a tag coming into view only next to tracked ones (the completion); the full
  // detector looks everywhere, every so many frames while a tag the board puts inside the image
  // is still missing.
  const bool redetect =
      tracked && since_full_ + 1 >= options.track_redetect_frames &&
      result.tags_accepted < detector_.board().NumTags() &&
      MissingTagInView(detector_.board(), TagsOfCorners(detector_.board(), result.corners),
                       gray.size(), -options.min_border_distance_px);
  if (!tracked || redetect) {
    DetectionResult full = detector_.DetectAprilGrid(gray, noise_sigma);
    ++stats_.full_detections;
    since_full_ = 0;
    if (!tracked || full.tags_accepted >= result.tags_accepted)
      result = std::move(full);
  } else {
    ++since_full_;
  }
  detector_.FinishView(gray, noise_sigma, &result);
  before_previous_ = std::move(previous_);
  previous_ = result.corners;
  previous_tags_ = result.tags_accepted;
  if (previous_.empty())
    Reset();
  return result;
}

}  // namespace ctcal
