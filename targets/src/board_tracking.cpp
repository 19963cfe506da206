// BoardTracker (board_tracking.h): AprilGrid tags followed from frame to frame.
#include "ctcal/targets/board_tracking.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>

#include "detector_internal.h"

namespace ctcal {

using namespace internal;  // NOLINT(build/namespaces): detector_internal.h's passes

namespace {

// How far the image moved from `before` to `after` as a whole (px): phase correlation at a
// quarter of the resolution, where a jolt of 40 px is 10 px and the board's tags are a few
// pixels of texture. Only a start for the refinement: the tag checks decide.
Eigen::Vector2d ImageShift(const cv::Mat& before, const cv::Mat& after) {
  constexpr double kScale = 0.25;
  cv::Mat a, b;
  cv::resize(before, a, cv::Size(), kScale, kScale, cv::INTER_AREA);
  cv::resize(after, b, cv::Size(), kScale, kScale, cv::INTER_AREA);
  a.convertTo(a, CV_32F);
  b.convertTo(b, CV_32F);
  cv::Mat window;
  cv::createHanningWindow(window, a.size(), CV_32F);
  const cv::Point2d shift = cv::phaseCorrelate(a, b, window);
  return Eigen::Vector2d(shift.x, shift.y) / kScale;
}

}  // namespace

void BoardTracker::Reset() {
  for (std::vector<DetectedCorner>& corners : history_)
    corners.clear();
  previous_gray_.release();
  previous_tags_ = 0;
  since_full_ = 0;
}

DetectionResult BoardTracker::Track(const cv::Mat& gray, double noise_sigma,
                                    const Eigen::Vector2d* shift) const {
  const Board& board = detector_.board();
  const DetectorOptions& options = detector_.options();
  std::array<TagCorners, 3> before;
  for (size_t j = 0; j < 3; ++j)
    before[j] = TagsOfCorners(board, history_[j]);
  DetectionResult result;
  result.full_detection = false;
  for (const auto& [id, uv] : before[0]) {
    // The motion of a corner in the image is smooth at 20 Hz: constant acceleration misses the
    // simulator's Kalibr-style motion (15 px between frames) by 2.2 px (median), constant
    // velocity by 4.5 px, which is more than the jump bound allows on its 5 px bits.
    std::array<Eigen::Vector2d, 4> predicted = uv;
    const auto one = before[1].find(id);
    const auto two = before[2].find(id);
    for (size_t k = 0; k < 4; ++k) {
      if (shift != nullptr)
        predicted[k] += *shift;
      else if (one != before[1].end() && two != before[2].end())
        predicted[k] = 3.0 * uv[k] - 3.0 * one->second[k] + two->second[k];
      else if (one != before[1].end())
        predicted[k] = 2.0 * uv[k] - one->second[k];
    }
    ++result.tags_detected;
    std::array<DetectedCorner, 4> refined;
    const std::optional<RejectReason> reason =
        AcceptTag(gray, noise_sigma, board, options, id, predicted, &refined);
    if (!reason) {
      result.corners.insert(result.corners.end(), refined.begin(), refined.end());
      ++result.tags_accepted;
    } else if (*reason == RejectReason::kNearBorder) {
      result.rejected.push_back({id, *reason});
    }
  }
  // Every tag not tracked is looked for from its tracked neighbours, with the completion's own
  // border, jump and code checks: tags the prediction lost, tags coming into view, and tags whose
  // prediction fell near the border but whose neighbours put them inside (excluding those, as
  // the full detector excludes its near-border quads, lost ~0.5 % of the corners for good).
  CompleteGrid(gray, noise_sigma, board, options, {}, &result);
  DropTagsOffTheirEdges(gray, board, options, &result);
  FinishTagView(options, &result);
  return result;
}

DetectionResult BoardTracker::Next(const cv::Mat& image) {
  ++stats_.frames;
  const DetectorOptions& options = detector_.options();
  if (!options.track || detector_.board().type() != TargetType::kAprilGrid || !options.refine) {
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
  if (gray.size() != previous_gray_.size())
    Reset();
  bool tracked = false;
  const auto enough = [&](const DetectionResult& r) {
    return r.tags_accepted >= std::max(options.min_tags, (previous_tags_ + 1) / 2);
  };
  if (!history_[0].empty()) {
    result = Track(gray, noise_sigma, nullptr);
    tracked = enough(result);
    if (!tracked) {
      // A jolt the motion model missed moves the whole view: the frame before's corners moved
      // by the image's shift are the start of one more try before libapriltag.
      const Eigen::Vector2d shift = ImageShift(previous_gray_, gray);
      DetectionResult again = Track(gray, noise_sigma, &shift);
      if (again.tags_accepted > result.tags_accepted)
        result = std::move(again);
      tracked = enough(result);
    }
  }
  // Tracking finds a tag coming into view only next to tracked ones (the completion); the full
  // detector looks everywhere, every so many frames while a tag the board puts inside the image
  // is still missing (its decimated passes: a tag that only the full resolution finds is one the
  // tracked frame's completion reaches from its neighbours).
  const bool redetect =
      tracked && since_full_ + 1 >= options.track_redetect_frames &&
      result.tags_accepted < detector_.board().NumTags() &&
      MissingTagInView(detector_.board(), TagsOfCorners(detector_.board(), result.corners),
                       gray.size(), -options.min_border_distance_px);
  if (!tracked || redetect) {
    DetectionResult full = detector_.DetectAprilGrid(gray, noise_sigma, tracked);
    ++stats_.full_detections;
    since_full_ = 0;
    if (!tracked || full.tags_accepted >= result.tags_accepted)
      result = std::move(full);
  } else {
    ++since_full_;
  }
  detector_.FinishView(gray, noise_sigma, &result);
  if (result.corners.empty()) {
    Reset();
    return result;
  }
  std::rotate(history_.rbegin(), history_.rbegin() + 1, history_.rend());
  history_[0] = result.corners;
  gray.copyTo(previous_gray_);  // a copy: the caller may reuse its image's buffer
  previous_tags_ = result.tags_accepted;
  return result;
}

}  // namespace ctcal
