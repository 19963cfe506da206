// libapriltag on a view (one pool-held detector per call), the checks of single tags (their
// second border ring, thinning, their code read back, tags the board says are missing) and the
// multi-pass tag search through Kalibr's corner bridges.
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
namespace internal {

apriltag_detector_t* NewApriltagDetector(apriltag_family_t* family, float quad_decimate) {
  apriltag_detector_t* detector = apriltag_detector_create();
  // Up to 2 corrected bits: tag36h11's minimum distance of 11 keeps false positives negligible.
  apriltag_detector_add_family_bits(detector, family, 2);
  detector->nthreads = 1;  // parallel over images instead
  detector->quad_decimate = quad_decimate;
  detector->quad_sigma = 0.0f;
  detector->refine_edges = true;
  detector->decode_sharpening = 0.25;
  return detector;
}

std::vector<TagDetection> RunApriltag(apriltag_detector_t* detector, const cv::Mat& gray) {
  image_u8_t image{gray.cols, gray.rows, static_cast<int32_t>(gray.step[0]),
                   const_cast<uint8_t*>(gray.ptr<uint8_t>())};
  zarray_t* detections = apriltag_detector_detect(detector, &image);
  std::vector<TagDetection> out;
  out.reserve(static_cast<size_t>(zarray_size(detections)));
  for (int i = 0; i < zarray_size(detections); ++i) {
    apriltag_detection_t* det = nullptr;
    zarray_get(detections, i, &det);
    TagDetection tag;
    tag.id = det->id;
    tag.hamming = det->hamming;
    tag.decision_margin = det->decision_margin;
    // libapriltag's p[0..3] are the tag-frame points (-1,1), (1,1), (1,-1), (-1,-1) with the tag
    // frame's y pointing down the printed tag: bottom-left, bottom-right, top-right, top-left,
    // Kalibr's order. Its pixel (0,0) is the top-left pixel's corner: shift to its centre.
    for (int k = 0; k < 4; ++k)
      tag.corners[static_cast<size_t>(k)] = Eigen::Vector2d(det->p[k][0] - 0.5, det->p[k][1] - 0.5);
    out.push_back(tag);
  }
  apriltag_detections_destroy(detections);
  std::stable_sort(out.begin(), out.end(),
                   [](const TagDetection& a, const TagDetection& b) { return a.id < b.id; });
  return out;
}

// libapriltag checks only the outermost black ring of a tag. With the family for a 2-bit border,
// a 1-bit tag (or other clutter) can still decode within 2 bit errors; the second black ring,
// which such a tag does not have, tells them apart: every cell of it must be darker than the
// midpoint between the tag's outer black ring and the white outside.
bool InnerBorderIsBlack(const cv::Mat& gray, const TagDetection& tag, int black_border) {
  if (black_border < 2)
    return true;
  const int cells = Board::kTagDataBits + 2 * black_border;
  // Tag cell coordinates (x right, y down the printed tag) -> pixels.
  const std::vector<cv::Point2f> tag_cells = {
      {0.0f, static_cast<float>(cells)},
      {static_cast<float>(cells), static_cast<float>(cells)},
      {static_cast<float>(cells), 0.0f},
      {0.0f, 0.0f}};
  std::vector<cv::Point2f> pixels;
  for (const Eigen::Vector2d& c : tag.corners)
    pixels.emplace_back(static_cast<float>(c.x()), static_cast<float>(c.y()));
  const cv::Mat H = cv::getPerspectiveTransform(tag_cells, pixels);
  auto ring = [cells](double offset, int from, int to) {
    // Cell centres of the ring `offset` cells inside the quad (negative: outside), sides only
    // between `from` and `to` (outside, the corner squares must be skipped).
    std::vector<cv::Point2f> points;
    for (int k = from; k < to; ++k) {
      const float a = static_cast<float>(k + 0.5);
      const float lo = static_cast<float>(offset + 0.5);
      const float hi = static_cast<float>(cells - offset - 0.5);
      points.insert(points.end(), {{a, lo}, {a, hi}, {lo, a}, {hi, a}});
    }
    return points;
  };
  auto sample = [&gray, &H](std::vector<cv::Point2f> points) {
    cv::perspectiveTransform(points, points, H);
    std::vector<double> values;
    for (const cv::Point2f& p : points) {
      const int x = static_cast<int>(std::lround(p.x));
      const int y = static_cast<int>(std::lround(p.y));
      if (x >= 0 && y >= 0 && x < gray.cols && y < gray.rows)
        values.push_back(gray.at<uint8_t>(y, x));
    }
    return values;
  };
  auto median = [](std::vector<double> v) {
    if (v.empty())
      return 0.0;
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  const double black = median(sample(ring(0, 1, cells - 1)));
  const double white = median(sample(ring(-1, 2, cells - 2)));
  if (!(white > black))
    return false;
  const std::vector<double> inner = sample(ring(1, 1, cells - 1));
  const double threshold = 0.5 * (black + white);
  const auto dark =
      std::count_if(inner.begin(), inner.end(), [threshold](double v) { return v < threshold; });
  return !inner.empty() && dark >= static_cast<long>(0.9 * static_cast<double>(inner.size()));
}

namespace {

// The maximum filter over the pixels {0, 1}^2 up-left of each pixel erodes black by that set: an
// edge with outward unit normal n (image axes) moves inwards by d = -min(0, n_x, n_y, n_x + n_y).
// Moving both edges at a corner back out by their d solves n_1^T dc = d_1, n_2^T dc = d_2.
void UndoThinning(TagDetection* tag) {
  const std::array<Eigen::Vector2d, 4> c = tag->corners;
  double area = 0.0;
  for (size_t k = 0; k < 4; ++k) {
    const Eigen::Vector2d& a = c[k];
    const Eigen::Vector2d& b = c[(k + 1) % 4];
    area += a.x() * b.y() - a.y() * b.x();
  }
  // Outward normal of the edge k -> k+1 for either winding.
  auto normal = [&](size_t k) {
    const Eigen::Vector2d e = (c[(k + 1) % 4] - c[k]).normalized();
    const Eigen::Vector2d n(e.y(), -e.x());
    return area > 0.0 ? n : Eigen::Vector2d(-n);
  };
  auto shift = [](const Eigen::Vector2d& n) {
    return -std::min({0.0, n.x(), n.y(), n.x() + n.y()});
  };
  for (size_t k = 0; k < 4; ++k) {
    const Eigen::Vector2d n1 = normal((k + 3) % 4);  // edge into corner k
    const Eigen::Vector2d n2 = normal(k);            // edge out of corner k
    Eigen::Matrix2d A;
    A << n1.transpose(), n2.transpose();
    if (std::abs(A.determinant()) < 1e-3)
      continue;
    tag->corners[k] = c[k] + A.inverse() * Eigen::Vector2d(shift(n1), shift(n2));
  }
}

}  // namespace

// Whether a tag of the board that is not in `tags` can be in the image: a homography fitted to
// the tags found (board plane -> image) predicts where the others are, and a tag counts when its
// four corners fall inside the image grown by `margin_px` (negative: shrunk). The homography
// ignores lens distortion, which the caller's margin allows for. Extra passes only pay when a
// tag is missing; a partial view whose missing tags all fall outside the frame is done.
bool MissingTagInView(const Board& board, const TagCorners& tags, const cv::Size& image_size,
                      double margin_px) {
  std::vector<cv::Point2f> board_xy, image_xy;
  for (const auto& [id, corners] : tags) {
    const std::array<int, 4> ids = board.TagCornerIds(id);
    for (size_t k = 0; k < 4; ++k) {
      const Eigen::Vector3d& p = board.Corner(ids[k]);
      board_xy.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
      image_xy.emplace_back(static_cast<float>(corners[k].x()), static_cast<float>(corners[k].y()));
    }
  }
  if (board_xy.size() < 8)
    return true;  // too little to predict from
  const cv::Mat H = cv::findHomography(board_xy, image_xy, 0);
  if (H.empty())
    return true;
  for (int id = 0; id < board.NumTags(); ++id) {
    if (tags.count(id))
      continue;
    std::vector<cv::Point2f> corners;
    for (int k : board.TagCornerIds(id))
      corners.emplace_back(static_cast<float>(board.Corner(k).x()),
                           static_cast<float>(board.Corner(k).y()));
    cv::perspectiveTransform(corners, corners, H);
    if (std::all_of(corners.begin(), corners.end(), [&](const cv::Point2f& c) {
          return c.x >= -margin_px && c.y >= -margin_px &&
                 c.x <= image_size.width - 1 + margin_px &&
                 c.y <= image_size.height - 1 + margin_px;
        }))
      return true;
  }
  return false;
}

// Reads tag `id` at the given corners (tag order) and compares it with what the board prints
// there: the number of the 36 data bits that differ from Kalibr's code word of `id`, or -1 if
// the view is no tag of this border width at all (no contrast, or a border ring not black).
// Each cell is sampled at its centre through the homography of the four corners (tag cells,
// x right and y down the printed tag -> pixels); the threshold is the midpoint between the
// black border and the white gap outside the tag.
int TagCodeDistance(const cv::Mat& gray, const std::array<Eigen::Vector2d, 4>& corners,
                    const Board& board, int id) {
  const int border = board.config().black_tag_border;
  const int cells = Board::kTagDataBits + 2 * border;
  const float n = static_cast<float>(cells);
  const std::vector<cv::Point2f> tag_cells = {{0.0f, n}, {n, n}, {n, 0.0f}, {0.0f, 0.0f}};
  std::vector<cv::Point2f> pixels;
  for (const Eigen::Vector2d& c : corners)
    pixels.emplace_back(static_cast<float>(c.x()), static_cast<float>(c.y()));
  const cv::Mat H = cv::getPerspectiveTransform(tag_cells, pixels);
  const auto sample = [&](double x, double y) {
    const double w = H.at<double>(2, 0) * x + H.at<double>(2, 1) * y + H.at<double>(2, 2);
    return SampleBilinear(
        gray, (H.at<double>(0, 0) * x + H.at<double>(0, 1) * y + H.at<double>(0, 2)) / w,
        (H.at<double>(1, 0) * x + H.at<double>(1, 1) * y + H.at<double>(1, 2)) / w);
  };
  std::vector<double> ring_values, white_values;
  for (int a = 0; a < cells; ++a) {
    for (int b = 0; b < cells; ++b) {
      const bool in_border = a < border || b < border || a >= cells - border || b >= cells - border;
      if (in_border)
        ring_values.push_back(sample(a + 0.5, b + 0.5));
    }
  }
  // The gap beside each edge, away from the corner squares.
  for (int a = 2; a < cells - 2; ++a) {
    for (const auto& [x, y] : std::vector<std::pair<double, double>>{
             {a + 0.5, -0.5}, {a + 0.5, cells + 0.5}, {-0.5, a + 0.5}, {cells + 0.5, a + 0.5}})
      white_values.push_back(sample(x, y));
  }
  if (std::count(ring_values.begin(), ring_values.end(), -1.0) > 0 ||
      std::count(white_values.begin(), white_values.end(), -1.0) > 0)
    return -1;  // partly outside the image
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  const double black = median(ring_values);
  const double white = median(white_values);
  // A tag reads with at least this contrast (grey levels) on any usable image.
  if (white - black < 15.0)
    return -1;
  const double threshold = 0.5 * (black + white);
  const auto dark_border = std::count_if(ring_values.begin(), ring_values.end(),
                                         [threshold](double v) { return v < threshold; });
  if (dark_border < static_cast<long>(0.9 * static_cast<double>(ring_values.size())))
    return -1;
  const uint64_t code = board.TagCode(id);
  int distance = 0;
  for (int row = 0; row < Board::kTagDataBits; ++row) {
    for (int col = 0; col < Board::kTagDataBits; ++col) {
      const bool is_white = sample(border + col + 0.5, border + row + 0.5) > threshold;
      const int bit =
          Board::kTagDataBits * Board::kTagDataBits - 1 - (row * Board::kTagDataBits + col);
      distance += is_white != (((code >> bit) & 1u) != 0u) ? 1 : 0;
    }
  }
  return distance;
}

// One libapriltag pass over `image` (the original or a modified copy of `gray`); tags whose
// second border ring is not black in `gray` go to `bad_border` instead.
std::vector<TagDetection> RunCheckingBorder(apriltag_detector_t* detector, const cv::Mat& image,
                                            const cv::Mat& gray, const Board& board,
                                            std::set<int>* bad_border) {
  std::vector<TagDetection> kept;
  for (const TagDetection& tag : RunApriltag(detector, image)) {
    if (InnerBorderIsBlack(gray, tag, board.config().black_tag_border))
      kept.push_back(tag);
    else
      bad_border->insert(tag.id);
  }
  return kept;
}

// Kalibr's black squares touch every tag at its four corners. Blurred and thresholded, the touch
// points become black bridges: the tag's black square merges with its neighbours into one
// component and libapriltag's quad search (black/white boundary clusters) finds no quad. Each
// detected tag predicts its four corner squares through its homography (tag plane -> image);
// painting them white frees the neighbours, which the next pass finds, and so on. libapriltag
// fits its corners to whole edges, so the small bite this takes out of a tag's corner does not
// move them; the sub-pixel refinement runs on the untouched image anyway.
// `first_pass`: the tags of one RunCheckingBorder on `gray` already made (nullptr: run it).
std::vector<TagDetection> DetectGridTags(apriltag_detector_t* detector, const cv::Mat& gray,
                                         const Board& board, std::set<int>* bad_border,
                                         const std::vector<TagDetection>* first_pass) {
  auto run = [&](const cv::Mat& image) {
    return RunCheckingBorder(detector, image, gray, board, bad_border);
  };
  // Tags by id; a run that decodes an id twice keeps both (the duplicate rule needs them).
  // `confirmed` come from the image itself or its painted copy, `seeds` from the thinned copy.
  std::map<int, std::vector<TagDetection>> confirmed;
  std::map<int, std::vector<TagDetection>> seeds;
  auto merge = [](const std::vector<TagDetection>& tags,
                  std::map<int, std::vector<TagDetection>>* into) {
    std::map<int, std::vector<TagDetection>> by_id;
    for (const TagDetection& tag : tags)
      by_id[tag.id].push_back(tag);
    bool added = false;
    for (auto& [id, list] : by_id) {
      added |= into->count(id) == 0;
      (*into)[id] = std::move(list);
    }
    return added;
  };
  auto board_ids = [&board](const std::map<int, std::vector<TagDetection>>& tags) {
    int n = 0;
    for (const auto& entry : tags)
      n += entry.first < board.NumTags() ? 1 : 0;
    return n;
  };
  merge(first_pass != nullptr ? *first_pass : run(gray), &confirmed);
  auto missing_tag_in_view = [&]() {
    TagCorners unique;
    for (const auto& [id, list] : confirmed) {
      if (id < board.NumTags() && list.size() == 1)
        unique[id] = list.front().corners;
    }
    // A tenth of the image of slack for lens distortion: a painting pass is cheap.
    return MissingTagInView(board, unique, gray.size(), 0.1 * std::min(gray.cols, gray.rows));
  };
  auto add_thinned_seeds = [&] {
    // Seeds where bridges hide most tags: a 2 x 2 maximum filter thins every black region by a
    // pixel on its top and left. Their corners are biased by up to a pixel: they only seed the
    // painting, and are used as detections only if the painted image never gives the tag.
    cv::Mat thinned;
    cv::dilate(gray, thinned, cv::Mat::ones(2, 2, CV_8U));
    std::vector<TagDetection> thinned_tags = RunApriltag(detector, thinned);
    for (TagDetection& tag : thinned_tags)
      UndoThinning(&tag);
    thinned_tags.erase(std::remove_if(thinned_tags.begin(), thinned_tags.end(),
                                      [&](const TagDetection& tag) {
                                        return !InnerBorderIsBlack(gray, tag,
                                                                   board.config().black_tag_border);
                                      }),
                       thinned_tags.end());
    merge(thinned_tags, &seeds);
  };
  const double size = board.config().tag_size;
  const double gap = board.config().tag_spacing * size;
  const double grow = 0.15 * gap;
  const std::vector<cv::Point2f> tag_square = {{0.0f, 0.0f},
                                               {static_cast<float>(size), 0.0f},
                                               {static_cast<float>(size), static_cast<float>(size)},
                                               {0.0f, static_cast<float>(size)}};
  cv::Mat work;
  std::set<int> painted;
  auto paint_passes = [&] {
    for (int pass = 0; pass < 4 && board_ids(confirmed) < board.NumTags() && missing_tag_in_view();
         ++pass) {
      if (work.empty())
        work = gray.clone();
      bool painted_new = false;
      for (const auto* tags : {&confirmed, &seeds}) {
        for (const auto& [id, list] : *tags) {
          if (id >= board.NumTags() || list.size() != 1 || !painted.insert(id).second)
            continue;
          painted_new = true;
          const TagDetection& tag = list.front();
          std::vector<cv::Point2f> image_corners;
          for (const Eigen::Vector2d& c : tag.corners)
            image_corners.emplace_back(static_cast<float>(c.x()), static_cast<float>(c.y()));
          const cv::Mat H = cv::getPerspectiveTransform(tag_square, image_corners);
          // White level: the gaps beside the tag's four edges.
          std::vector<cv::Point2f> gap_centres = {
              {static_cast<float>(0.5 * size), static_cast<float>(-0.5 * gap)},
              {static_cast<float>(size + 0.5 * gap), static_cast<float>(0.5 * size)},
              {static_cast<float>(0.5 * size), static_cast<float>(size + 0.5 * gap)},
              {static_cast<float>(-0.5 * gap), static_cast<float>(0.5 * size)}};
          cv::perspectiveTransform(gap_centres, gap_centres, H);
          int white = 0;
          for (const cv::Point2f& p : gap_centres) {
            const int x = std::clamp(static_cast<int>(std::lround(p.x)), 0, gray.cols - 1);
            const int y = std::clamp(static_cast<int>(std::lround(p.y)), 0, gray.rows - 1);
            white = std::max(white, static_cast<int>(gray.at<uint8_t>(y, x)));
          }
          for (const cv::Point2f& corner : tag_square) {
            const float x0 = corner.x > 0.0f ? corner.x - static_cast<float>(grow)
                                             : corner.x - static_cast<float>(gap + grow);
            const float y0 = corner.y > 0.0f ? corner.y - static_cast<float>(grow)
                                             : corner.y - static_cast<float>(gap + grow);
            const float w = static_cast<float>(gap + 2.0 * grow);
            std::vector<cv::Point2f> square = {
                {x0, y0}, {x0 + w, y0}, {x0 + w, y0 + w}, {x0, y0 + w}};
            cv::perspectiveTransform(square, square, H);
            std::vector<cv::Point> polygon;
            for (const cv::Point2f& p : square)
              polygon.emplace_back(static_cast<int>(std::lround(p.x)),
                                   static_cast<int>(std::lround(p.y)));
            cv::fillConvexPoly(work, polygon, cv::Scalar(white));
          }
        }
      }
      if (!painted_new || !merge(run(work), &confirmed))
        break;
    }
  };
  // Painting around the tags found first; only if tags that should be in view are still
  // missing, the thinned copy seeds another round (each is one libapriltag pass, so this order
  // saves passes on the common images where the first pass found most tags).
  // When the first pass found less than half the board, bridges are everywhere (fisheye
  // views): seed first, which the painting then confirms on the untouched image.
  if (2 * board_ids(confirmed) < board.NumTags() && missing_tag_in_view())
    add_thinned_seeds();
  paint_passes();
  if (seeds.empty() && board_ids(confirmed) < board.NumTags() && missing_tag_in_view()) {
    add_thinned_seeds();
    paint_passes();
  }
  for (auto& entry : seeds)
    confirmed.insert(entry);  // only where no confirmed detection exists
  std::vector<TagDetection> tags;
  for (auto& entry : confirmed)
    tags.insert(tags.end(), entry.second.begin(), entry.second.end());
  return tags;
}

}  // namespace internal

using namespace internal;  // NOLINT(build/namespaces): detector_internal.h's passes

std::vector<TagDetection> DetectTags36h11(const cv::Mat& image, int black_border,
                                          float quad_decimate) {
  if (black_border != 1 && black_border != 2)
    throw std::invalid_argument("black_border must be 1 or 2");
  const cv::Mat gray = ToGray8(image);
  if (gray.cols < kMinImageSide || gray.rows < kMinImageSide)
    return {};
  internal::TagFamilyPtr family = internal::CreateTag36h11(black_border);
  apriltag_detector_t* detector = NewApriltagDetector(family.get(), quad_decimate);
  std::vector<TagDetection> tags = RunApriltag(detector, gray);
  apriltag_detector_destroy(detector);
  return tags;
}

}  // namespace ctcal
