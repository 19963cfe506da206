// The AprilGrid detection: libapriltag's tags, grid completion, the tag checks, the grid scatter.
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>

#include "detector_internal.h"

namespace ctcal {
namespace internal {

// Grid completion. libapriltag misses tags that a person sees at once: under fisheye distortion
// their edges bend and its straight-edge quads fail or miss the corners by several pixels (the
// refinement then jumps), and bridges to the corner squares hide some. The board knows where a
// missing tag must be: each of its corners is predicted by the homography of the nearest
// accepted neighbour tag (3 x 3 tag neighbourhood, four exact points: the more local, the less
// lens distortion the model misses) and refined in the image (jump <= 1 bit: inside the tag the
// next X-junction is two bits away, outside the corner square is three). The tag counts only if
// its border is black and its 36 data bits read as the code word printed for its id within 2
// bits (tag36h11's minimum distance is 11, so a wrong place or id does not pass). Recovered tags
// are neighbours in the next round.
// `excluded`: ids a rule already decided on (duplicates, near the border, another border).
void CompleteGrid(const cv::Mat& gray, double noise_sigma, const Board& board,
                  const DetectorOptions& options, const std::set<int>& excluded,
                  DetectionResult* result) {
  TagCorners found = TagsOfCorners(board, result->corners);
  if (found.empty())
    return;
  const int border = board.config().black_tag_border;
  const int cells = Board::kTagDataBits + 2 * border;
  const int rows = board.tag_rows(), cols = board.tag_cols();
  const double margin = options.min_border_distance_px;
  const auto inside = [&](const Eigen::Vector2d& uv) {
    return uv.x() >= margin && uv.y() >= margin && uv.x() <= gray.cols - 1 - margin &&
           uv.y() <= gray.rows - 1 - margin;
  };
  for (bool grown = true; grown;) {
    grown = false;
    for (int id = 0; id < board.NumTags(); ++id) {
      if (found.count(id) || excluded.count(id))
        continue;
      // Each corner from the homography of the nearest accepted neighbour (four exact points):
      // the more local the model, the less lens distortion it misses.
      const std::array<int, 4> ids = board.TagCornerIds(id);
      std::vector<cv::Point2f> predicted;
      for (int k : ids) {
        const Eigen::Vector2d p_W = board.Corner(k).head<2>();
        double nearest = std::numeric_limits<double>::infinity();
        const std::array<Eigen::Vector2d, 4>* neighbour_uv = nullptr;
        std::array<int, 4> neighbour_ids{};
        for (int dr = -1; dr <= 1; ++dr) {
          for (int dc = -1; dc <= 1; ++dc) {
            const int r = id / cols + dr, c = id % cols + dc;
            if (r < 0 || c < 0 || r >= rows || c >= cols || !found.count(r * cols + c))
              continue;
            const std::array<int, 4> n_ids = board.TagCornerIds(r * cols + c);
            const double d =
                (0.5 * (board.Corner(n_ids[0]) + board.Corner(n_ids[2])).head<2>() - p_W).norm();
            if (d < nearest) {
              nearest = d;
              neighbour_uv = &found.at(r * cols + c);
              neighbour_ids = n_ids;
            }
          }
        }
        if (neighbour_uv == nullptr)
          break;
        std::vector<cv::Point2f> board_xy, image_xy;
        for (size_t j = 0; j < 4; ++j) {
          const Eigen::Vector3d& q = board.Corner(neighbour_ids[j]);
          board_xy.emplace_back(static_cast<float>(q.x()), static_cast<float>(q.y()));
          image_xy.emplace_back(static_cast<float>((*neighbour_uv)[j].x()),
                                static_cast<float>((*neighbour_uv)[j].y()));
        }
        std::vector<cv::Point2f> one = {
            cv::Point2f(static_cast<float>(p_W.x()), static_cast<float>(p_W.y()))};
        cv::perspectiveTransform(one, one, cv::getPerspectiveTransform(board_xy, image_xy));
        predicted.push_back(one.front());
      }
      if (predicted.size() != 4)
        continue;
      // The shortest edge sets the scale: a foreshortened tag's bits are narrow across it.
      double edge = std::numeric_limits<double>::infinity();
      for (size_t k = 0; k < 4; ++k)
        edge = std::min(edge, static_cast<double>(cv::norm(predicted[k] - predicted[(k + 1) % 4])));
      const double bit_px = edge / cells;
      if (!(bit_px >= options.min_bit_px))
        continue;
      std::array<DetectedCorner, 4> refined;
      std::array<Eigen::Vector2d, 4> uv;
      // Refines the four corners from `starts` and reads the tag there.
      const auto refine_from = [&](const std::array<Eigen::Vector2d, 4>& starts) {
        bool ok = true;
        for (size_t k = 0; k < 4 && ok; ++k) {
          uv[k] = starts[k];
          double sigma = 0.0;
          ok = inside(starts[k]) &&
               RefineCorner(gray, TagCornerHalfWindow(border, bit_px, kCaptureWindowBorders),
                            &uv[k], &sigma, noise_sigma) &&
               (uv[k] - starts[k]).norm() <= bit_px && inside(uv[k]);
          refined[k].id = ids[k];
          refined[k].uv = uv[k];
          refined[k].sigma = sigma;  // noise only; Detect adds the view's model error
        }
        if (!ok)
          return false;
        // Compared with the one code word printed there (not searched among all 587): 3 wrong
        // bits of 36 pass by chance with probability 1e-7, and blur at a fisheye's rim costs
        // a bit or two more than libapriltag's own quads see.
        const int distance = TagCodeDistance(gray, uv, board, id);
        return distance >= 0 && distance <= 3;
      };
      std::array<Eigen::Vector2d, 4> starts;
      for (size_t k = 0; k < 4; ++k)
        starts[k] = Eigen::Vector2d(predicted[k].x, predicted[k].y);
      // Where the neighbour's homography extrapolates badly (the strongest distortion at a
      // fisheye's rim, where the spacing shrinks tag by tag: 5-7 px off on TUM-VI's top.png),
      // three accepted tags in a line before it extrapolate each corner with that shrinking:
      // equal steps on the board, so p = 3 p_1 - 3 p_2 + p_3 is exact for a quadratic.
      const auto from_line = [&](std::array<Eigen::Vector2d, 4>* out) {
        const int r = id / cols, c = id % cols;
        for (const auto& [dr, dc] : std::vector<std::pair<int, int>>{
                 {-1, 0}, {1, 0}, {0, -1}, {0, 1}, {-1, -1}, {-1, 1}, {1, -1}, {1, 1}}) {
          std::array<const std::array<Eigen::Vector2d, 4>*, 3> line{};
          bool complete = true;
          for (int step = 1; step <= 3 && complete; ++step) {
            const int rr = r + step * dr, cc = c + step * dc;
            complete = rr >= 0 && cc >= 0 && rr < rows && cc < cols && found.count(rr * cols + cc);
            if (complete)
              line[static_cast<size_t>(step - 1)] = &found.at(rr * cols + cc);
          }
          if (!complete)
            continue;
          for (size_t k = 0; k < 4; ++k)
            (*out)[k] = 3.0 * (*line[0])[k] - 3.0 * (*line[1])[k] + (*line[2])[k];
          return true;
        }
        return false;
      };
      if (!refine_from(starts) && !(from_line(&starts) && refine_from(starts)))
        continue;
      found[id] = uv;
      result->corners.insert(result->corners.end(), refined.begin(), refined.end());
      ++result->tags_accepted;
      // Its quad was libapriltag's and too far off; the grid's prediction was not.
      result->rejected.erase(std::remove_if(result->rejected.begin(), result->rejected.end(),
                                            [id](const TagRejection& r) { return r.tag_id == id; }),
                             result->rejected.end());
      grown = true;
    }
  }
}

// Kalibr's rules for one tag and the sub-pixel refinement: its corners (libapriltag's quad, or a
// tracked prediction) away from the image border, its bits wide enough to refine, each corner
// refined with the capture window within the jump bound of its start, and the tag still reading
// as its own code word at the refined corners.
std::optional<RejectReason> AcceptTag(const cv::Mat& gray, double noise_sigma, const Board& board,
                                      const DetectorOptions& options, int id,
                                      const std::array<Eigen::Vector2d, 4>& corners,
                                      std::array<DetectedCorner, 4>* refined) {
  const double margin = options.min_border_distance_px;
  const int border = board.config().black_tag_border;
  const int cells = Board::kTagDataBits + 2 * border;
  for (const Eigen::Vector2d& c : corners) {
    if (c.x() < margin || c.y() < margin || c.x() > gray.cols - 1 - margin ||
        c.y() > gray.rows - 1 - margin)
      return RejectReason::kNearBorder;
  }
  // The shortest edge sets the scale of the window and of the jump bound: a foreshortened
  // tag's bits are narrow across it, and the next X-junction is that much closer.
  double edge = std::numeric_limits<double>::infinity();
  for (size_t k = 0; k < 4; ++k)
    edge = std::min(edge, (corners[k] - corners[(k + 1) % 4]).norm());
  const double bit_px = edge / cells;
  if (bit_px < options.min_bit_px)
    return RejectReason::kTooSmall;
  // libapriltag fits straight edges; under strong distortion (fisheye lenses) a large tag's
  // edges bend and its quad corners miss the true corner by a few pixels. The next X-junction
  // is two (narrowest) bits away, so a jump up to 0.8 bit still lands on the right one.
  const double max_jump = std::max(options.max_refinement_jump_px, 0.8 * bit_px);
  const std::array<int, 4> ids = board.TagCornerIds(id);
  std::array<Eigen::Vector2d, 4> uv;
  for (size_t k = 0; k < 4; ++k) {
    DetectedCorner& out = (*refined)[k];
    out.id = ids[k];
    out.uv = corners[k];
    out.sigma = options.default_sigma_px;
    if (!options.refine)
      continue;
    double sigma = 0.0;
    if (!RefineCorner(gray, TagCornerHalfWindow(border, bit_px, kCaptureWindowBorders), &out.uv,
                      &sigma, noise_sigma) ||
        (out.uv - corners[k]).norm() > max_jump)
      return RejectReason::kRefinementJump;
    out.sigma = sigma;  // noise only; Detect adds the view's model error
    uv[k] = out.uv;
  }
  // A refined corner that landed on another junction shifts the bit grid near it: the tag must
  // still read as its code word at the refined corners.
  if (options.refine) {
    const int distance = TagCodeDistance(gray, uv, board, id);
    if (distance < 0 || distance > 2)
      return RejectReason::kRefinementJump;
  }
  return std::nullopt;
}

// The view's last rules: fewer than min_tags tags is no observation; corners sorted by id.
void FinishTagView(const DetectorOptions& options, DetectionResult* result) {
  if (result->tags_accepted < options.min_tags) {
    if (result->tags_accepted > 0)
      result->rejected.push_back({-1, RejectReason::kTooFewTags});
    result->corners.clear();
  }
  std::sort(result->corners.begin(), result->corners.end(),
            [](const DetectedCorner& a, const DetectedCorner& b) { return a.id < b.id; });
  result->board_found = !result->corners.empty();
}

}  // namespace internal

using namespace internal;  // NOLINT(build/namespaces): detector_internal.h's passes

DetectionResult Detector::DetectAprilGrid(const cv::Mat& gray, double noise_sigma,
                                          bool decimated_only) const {
  // Kalibr's rejection rules and the sub-pixel refinement, applied to one pass's tags.
  const auto accept = [&](const std::vector<TagDetection>& tags, const std::set<int>& bad_border) {
    DetectionResult result;
    result.tags_detected = static_cast<int>(tags.size());
    for (int id : bad_border) {
      if (std::none_of(tags.begin(), tags.end(),
                       [id](const TagDetection& t) { return t.id == id; }))
        result.rejected.push_back({id, RejectReason::kBadBorder});
    }

    std::map<int, int> id_count;
    for (const TagDetection& tag : tags)
      ++id_count[tag.id];
    for (const TagDetection& tag : tags) {
      if (tag.id >= board_.NumTags()) {
        result.rejected.push_back({tag.id, RejectReason::kUnknownId});
        continue;
      }
      if (id_count[tag.id] > 1) {
        result.rejected.push_back({tag.id, RejectReason::kDuplicateId});
        continue;
      }
      std::array<DetectedCorner, 4> refined;
      const std::optional<RejectReason> reason =
          AcceptTag(gray, noise_sigma, board_, options_, tag.id, tag.corners, &refined);
      if (reason) {
        result.rejected.push_back({tag.id, *reason});
        continue;
      }
      ++result.tags_accepted;
      result.corners.insert(result.corners.end(), refined.begin(), refined.end());
    }
    if (options_.refine) {
      std::set<int> decided;
      for (const TagRejection& r : result.rejected) {
        if (r.reason != RejectReason::kRefinementJump && r.reason != RejectReason::kTooSmall)
          decided.insert(r.tag_id);
      }
      CompleteGrid(gray, noise_sigma, board_, options_, decided, &result);
    }
    return result;
  };

  // Cheapest first, each further step only while a tag of the board whose corners are predicted
  // inside the image is still missing: one decimated libapriltag pass and grid completion (all
  // that a clear view needs); then the painted and thinned passes (docs/targets.md); then the
  // same at full resolution, which finds small or sharply printed tags that decimation loses --
  // except where the caller has a view already (`decimated_only`: the tracker's periodic look for
  // tags coming into view, whose full-resolution pass was 1/10 of a tracked video's CPU time and
  // added no corner to the Kalibr-style recording's 33628).
  const auto tag_missing = [&](const DetectionResult& r) {
    return r.tags_accepted < board_.NumTags() &&
           MissingTagInView(board_, TagsOfCorners(board_, r.corners), gray.size(),
                            -options_.min_border_distance_px);
  };
  std::unique_ptr<TagContext> context = AcquireTagContext();
  std::set<int> bad_border;
  const std::vector<TagDetection> first =
      RunCheckingBorder(context->detector, gray, gray, board_, &bad_border);
  DetectionResult result = accept(first, bad_border);
  // The pass that accepted more tags is kept; an id that any pass decoded twice is dropped (which
  // copy is the board's is unknown, also when one pass saw only one of them).
  const auto keep_better = [&](DetectionResult other) {
    std::set<int> duplicates;
    for (const TagRejection& r : other.rejected) {
      if (r.reason == RejectReason::kDuplicateId)
        duplicates.insert(r.tag_id);
    }
    if (other.tags_accepted > result.tags_accepted)
      result = std::move(other);
    for (int id : duplicates) {
      const std::array<int, 4> ids = board_.TagCornerIds(id);
      const auto end = std::remove_if(result.corners.begin(), result.corners.end(),
                                      [&ids](const DetectedCorner& c) {
                                        return std::find(ids.begin(), ids.end(), c.id) != ids.end();
                                      });
      if (end == result.corners.end())
        continue;
      result.corners.erase(end, result.corners.end());
      --result.tags_accepted;
      result.rejected.push_back({id, RejectReason::kDuplicateId});
    }
  };
  if (tag_missing(result))
    keep_better(
        accept(DetectGridTags(context->detector, gray, board_, &bad_border, &first), bad_border));
  if (!decimated_only && context->detector->quad_decimate > 1.0f && tag_missing(result)) {
    const float decimated = context->detector->quad_decimate;
    context->detector->quad_decimate = 1.0f;
    std::set<int> bad_border_full;
    DetectionResult full =
        accept(DetectGridTags(context->detector, gray, board_, &bad_border_full, nullptr),
               bad_border_full);
    context->detector->quad_decimate = decimated;
    keep_better(std::move(full));
  }
  ReleaseTagContext(std::move(context));
  if (options_.refine)
    DropTagsOffTheirEdges(gray, board_, options_, &result);
  FinishTagView(options_, &result);
  return result;
}

}  // namespace ctcal
