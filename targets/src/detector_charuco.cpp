// The ChArUco detection through OpenCV's aruco module.
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>

#include "detector_internal.h"

namespace ctcal {

using namespace internal;  // NOLINT(build/namespaces): detector_internal.h's passes

// ChArUco through OpenCV's aruco module: markers (detectMarkers), then the chessboard corners
// between them (interpolateCornersCharuco: a local homography of the adjacent markers, then
// cornerSubPix), then our refinement for every corner (window and jump bound from the square's
// size in pixels, as for checkerboards) and Kalibr's rules: markers the board does not have
// (kUnknownId), corners near the image border, fewer than min_tags markers in the view.
DetectionResult Detector::DetectCharuco(const cv::Mat& gray, double noise_sigma) const {
  DetectionResult result;
  const TargetConfig& config = board_.config();
  const cv::Ptr<cv::aruco::Dictionary> dictionary =
      cv::aruco::getPredefinedDictionary(ArucoDictionaryId(config.dictionary));
  const cv::Ptr<cv::aruco::CharucoBoard> charuco = cv::aruco::CharucoBoard::create(
      config.squares_x, config.squares_y, static_cast<float>(config.square_length_m),
      static_cast<float>(config.marker_length_m), dictionary);
  std::vector<std::vector<cv::Point2f>> marker_corners, candidates;
  std::vector<int> marker_ids;
  const cv::Ptr<cv::aruco::DetectorParameters> parameters = cv::aruco::DetectorParameters::create();
  cv::aruco::detectMarkers(gray, dictionary, marker_corners, marker_ids, parameters, candidates);
  result.tags_detected = static_cast<int>(marker_ids.size());
  // Markers the board does not carry: another board in view, or the wrong file.
  std::set<int> on_board(charuco->ids.begin(), charuco->ids.end());
  std::map<int, int> count;
  for (int id : marker_ids)
    ++count[id];
  std::vector<std::vector<cv::Point2f>> kept_corners;
  std::vector<int> kept_ids;
  for (size_t i = 0; i < marker_ids.size(); ++i) {
    const int id = marker_ids[i];
    if (!on_board.count(id)) {
      result.rejected.push_back({id, RejectReason::kUnknownId});
    } else if (count[id] > 1) {
      result.rejected.push_back({id, RejectReason::kDuplicateId});
    } else {
      kept_corners.push_back(marker_corners[i]);
      kept_ids.push_back(id);
    }
  }
  result.tags_accepted = static_cast<int>(kept_ids.size());
  if (result.tags_accepted < options_.min_tags) {
    if (result.tags_accepted > 0)
      result.rejected.push_back({-1, RejectReason::kTooFewTags});
    return result;
  }
  std::vector<cv::Point2f> charuco_corners;
  std::vector<int> charuco_ids;
  cv::aruco::interpolateCornersCharuco(kept_corners, kept_ids, gray, charuco, charuco_corners,
                                       charuco_ids);
  // Scale: the markers' mean side in pixels, over the marker's share of a square.
  double marker_px = 0.0;
  for (const std::vector<cv::Point2f>& q : kept_corners) {
    for (size_t k = 0; k < 4; ++k)
      marker_px +=
          cv::norm(q[k] - q[(k + 1) % 4]) / (4.0 * static_cast<double>(kept_corners.size()));
  }
  const double square_px = marker_px * config.square_length_m / config.marker_length_m;
  // The markers' black borders start (squareLength - markerLength) / 2 from the corner's squares
  // (an eighth of a square on common boards): the window stays inside that margin.
  const double margin_sq =
      0.5 * (config.square_length_m - config.marker_length_m) / config.square_length_m;
  const int half_window = std::clamp(static_cast<int>(margin_sq * square_px), 2, 12);
  const int final_window =
      std::clamp(static_cast<int>(options_.square_window_fraction * square_px), 2, 12);
  const double max_jump = std::max(options_.max_refinement_jump_px, 0.2 * square_px);
  const double margin = options_.min_border_distance_px;
  for (size_t i = 0; i < charuco_ids.size(); ++i) {
    DetectedCorner corner;
    corner.id = charuco_ids[i];
    corner.uv = Eigen::Vector2d(charuco_corners[i].x, charuco_corners[i].y);
    corner.sigma = options_.default_sigma_px;
    if (corner.uv.x() < margin || corner.uv.y() < margin ||
        corner.uv.x() > gray.cols - 1 - margin || corner.uv.y() > gray.rows - 1 - margin) {
      result.rejected.push_back({corner.id, RejectReason::kNearBorder});
      continue;
    }
    if (options_.refine) {
      Eigen::Vector2d uv = corner.uv;
      double sigma = 0.0;
      if (!RefineCorner(gray, half_window, &uv, &sigma, noise_sigma) ||
          (uv - corner.uv).norm() > max_jump) {
        result.rejected.push_back({corner.id, RejectReason::kRefinementJump});
        continue;
      }
      corner.uv = uv;
      corner.sigma = sigma;  // noise only; Detect adds the view's model error
      if (final_window < half_window)
        RefineFinal(gray, noise_sigma, final_window, &corner);
    }
    result.corners.push_back(corner);
  }
  std::sort(result.corners.begin(), result.corners.end(),
            [](const DetectedCorner& a, const DetectedCorner& b) { return a.id < b.id; });
  result.board_found = !result.corners.empty();
  return result;
}

}  // namespace ctcal
