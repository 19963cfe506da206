#include "ctcal/targets/detector.h"

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>

#include "tag_family.h"

namespace ctcal {

const char* ToString(RejectReason reason) {
  switch (reason) {
    case RejectReason::kNearBorder:
      return "near the image border";
    case RejectReason::kDuplicateId:
      return "duplicate id";
    case RejectReason::kUnknownId:
      return "id not on this board";
    case RejectReason::kRefinementJump:
      return "sub-pixel refinement jumped";
    case RejectReason::kBadBorder:
      return "black border not as printed (wrong blackTagBorder?)";
    case RejectReason::kTooSmall:
      return "too small to refine";
    case RejectReason::kOffEdges:
      return "a refined corner off the tag's edges";
    case RejectReason::kNotThisBoard:
      return "corners off this board's grid (another board size in view, or the wrong file?)";
    case RejectReason::kTooFewTags:
      return "too few tags in the view";
  }
  return "?";
}

cv::Mat ToGray8(const cv::Mat& image) {
  if (image.empty())
    throw std::invalid_argument("empty image");
  cv::Mat gray;
  switch (image.channels()) {
    case 1:
      gray = image;
      break;
    case 3:
      cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
      break;
    case 4:
      cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
      break;
    default:
      throw std::invalid_argument("unsupported image with " + std::to_string(image.channels()) +
                                  " channels");
  }
  if (gray.depth() == CV_8U)
    return gray;
  if (gray.depth() != CV_16U)
    throw std::invalid_argument("unsupported image depth (expected 8- or 16-bit)");
  double lo = 0.0, hi = 0.0;
  cv::minMaxLoc(gray, &lo, &hi);
  cv::Mat out;
  const double scale = hi > lo ? 255.0 / (hi - lo) : 1.0;
  gray.convertTo(out, CV_8U, scale, -lo * scale);
  return out;
}

// Immerkaer's estimate (Fast noise variance estimation, CVIU 1996), made robust to edges by a
// median: the mask [1 -2 1; -2 4 -2; 1 -2 1] cancels every locally linear intensity, leaving
// noise of variance 36 sigma^2; the median of its magnitude over the image is 0.6745 * 6 sigma.
double EstimateNoiseSigma(const cv::Mat& gray) {
  CV_Assert(gray.type() == CV_8UC1);
  if (gray.rows < 3 || gray.cols < 3)
    return 0.0;
  const cv::Mat mask = (cv::Mat_<float>(3, 3) << 1, -2, 1, -2, 4, -2, 1, -2, 1);
  cv::Mat response;
  cv::filter2D(gray, response, CV_16S, mask);
  std::vector<int64_t> histogram(16 * 255 + 1, 0);
  for (int v = 1; v + 1 < response.rows; ++v) {
    const int16_t* row = response.ptr<int16_t>(v);
    for (int u = 1; u + 1 < response.cols; ++u)
      ++histogram[static_cast<size_t>(std::abs(row[u]))];
  }
  const int64_t half = static_cast<int64_t>(response.rows - 2) * (response.cols - 2) / 2;
  int64_t count = 0;
  size_t median = 0;
  while (median + 1 < histogram.size() && count + histogram[median] <= half)
    count += histogram[median++];
  return 1.4826 * static_cast<double>(median) / 6.0;
}

// ---------------------------------------------------------------------------------------------
// Sub-pixel refinement.
//
// For a corner q and any pixel p near it, the image gradient g(p) is either ~0 (flat region) or
// orthogonal to p - q (p on an edge through q): g(p)^T (p - q) = 0. Stacking the window's pixels
// with Gaussian weights w gives the normal equations
//   G q = sum_i w_i g_i g_i^T p_i,   G = sum_i w_i g_i g_i^T,
// solved repeatedly with the window re-centred on q (the gradients are re-sampled by bilinear
// interpolation at the new sub-pixel positions).
//
// Uncertainty: at the solution F(q) = sum_i w_i g_i g_i^T d_i = 0 with d_i = p_i - q. Image noise
// perturbs each gradient by dg_i; to first order dF = sum_i w_i (dg_i g_i^T d_i + g_i dg_i^T d_i),
// whose first term vanishes with the model residual g_i^T d_i = 0, and dF/dq = -G, so
//   dq = G^-1 sum_i w_i g_i d_i^T dg_i.
// Central differences of white noise of sigma_n grey levels have Cov(dg_i) = sigma_n^2 / 2 I
// (neighbouring gradients' correlation neglected), hence
//   Cov(q) = sigma_n^2 / 2 G^-1 (sum_i w_i^2 |d_i|^2 g_i g_i^T) G^-1.
// (The sandwich of the model residuals r_i = g_i^T d_i instead measured how far a blurred
// X-junction is from the ideal one, symmetric misfit that does not move q: 7x the scatter.)
namespace {
// The corner itself at least this far inside the image (px), and at least this fraction of the
// window's weight on measured gradients: a corner 4 px from the border (Kalibr's bound) keeps the
// band of rows or columns within 3 px of it, 40 % of a 12 px window's weight.
constexpr double kRefineMinBorderPx = 2.0;
constexpr double kRefineMinMeasuredWeight = 0.25;
// The window of the tag corners' refinement during detection, in black borders: its capture range
// brings a start a pixel or two off (libapriltag's straight-edge quads, the grid completion's
// extrapolations on blurred fisheye rims) onto the junction. The final estimate comes from
// DetectorOptions::tag_window_borders (Detector::RefineTagCorners).
constexpr double kCaptureWindowBorders = 0.8;
}  // namespace

bool RefineCorner(const cv::Mat& gray, int half_window, Eigen::Vector2d* uv, double* sigma_px,
                  double noise_sigma, const CornerWarp* warp) {
  CV_Assert(gray.type() == CV_8UC1);
  // Near the image border the window keeps its size and loses the pixels beyond the border (their
  // gradients are not measured). Shrinking it to fit instead left corners 4-6 px from the border
  // with a 3 x 3 or 5 x 5 window: 0.2-0.3 px off, and one 3.6 px off with a sigma of 0.07 px
  // (docs/targets.md), since a window that small holds no X-junction to speak of.
  const auto inside = [&](const Eigen::Vector2d& p, double margin) {
    return p.x() >= margin && p.y() >= margin && p.x() <= gray.cols - 1.0 - margin &&
           p.y() <= gray.rows - 1.0 - margin;
  };
  if (!inside(*uv, kRefineMinBorderPx))
    return false;
  const int h = std::max(1, half_window);
  const int n = 2 * h + 3;  // patch with a one-pixel rim for central differences
  const double weight_sigma = 0.5 * (h + 1);
  std::vector<double> weights(static_cast<size_t>((2 * h + 1) * (2 * h + 1)));
  double weight_sum = 0.0;
  for (int dy = -h; dy <= h; ++dy) {
    for (int dx = -h; dx <= h; ++dx) {
      weight_sum += weights[static_cast<size_t>((dy + h) * (2 * h + 1) + dx + h)] =
          std::exp(-(dx * dx + dy * dy) / (2.0 * weight_sigma * weight_sigma));
    }
  }
  cv::Mat patch;
  // in_image[r * n + c]: the patch sample (r, c) lies in the image (outside, getRectSubPix and the
  // clamped bilinear read repeat the border, which is no measurement).
  std::vector<uint8_t> in_image(static_cast<size_t>(n * n));
  // The patch centred on `at` (getRectSubPix: pixel centres at integer coordinates); with a warp,
  // `at` and the patch are in rectified coordinates, each pixel read bilinearly at its image point.
  const auto sample_patch = [&](const Eigen::Vector2d& at) {
    if (warp == nullptr) {
      cv::getRectSubPix(gray, cv::Size(n, n),
                        cv::Point2f(static_cast<float>(at.x()), static_cast<float>(at.y())), patch,
                        CV_32F);
      for (int r = 0; r < n; ++r) {
        for (int c = 0; c < n; ++c)
          in_image[static_cast<size_t>(r * n + c)] =
              inside(at + Eigen::Vector2d(c - h - 1, r - h - 1), 0.0);
      }
      return;
    }
    patch.create(n, n, CV_32F);
    for (int r = 0; r < n; ++r) {
      float* out = patch.ptr<float>(r);
      for (int c = 0; c < n; ++c) {
        const Eigen::Vector2d p = warp->ToImage(at + Eigen::Vector2d(c - h - 1, r - h - 1));
        in_image[static_cast<size_t>(r * n + c)] = inside(p, 0.0);
        const double x = std::clamp(p.x(), 0.0, gray.cols - 1.001);
        const double y = std::clamp(p.y(), 0.0, gray.rows - 1.001);
        const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
        const double fx = x - x0, fy = y - y0;
        const uint8_t* top = gray.ptr<uint8_t>(y0) + x0;
        const uint8_t* bottom = gray.ptr<uint8_t>(y0 + 1) + x0;
        out[c] = static_cast<float>((1.0 - fy) * ((1.0 - fx) * top[0] + fx * top[1]) +
                                    fy * ((1.0 - fx) * bottom[0] + fx * bottom[1]));
      }
    }
  };
  // f(d, w, g) for every pixel of the window whose gradient is measured (its four neighbours in
  // the image): its offset d from the centre, its weight w and the central-difference gradient g
  // of the patch there. Returns the weight of those pixels.
  const auto for_each_gradient = [&](const auto& f) {
    double measured = 0.0;
    for (int dy = -h; dy <= h; ++dy) {
      const float* row = patch.ptr<float>(dy + h + 1);
      const float* up = patch.ptr<float>(dy + h);
      const float* down = patch.ptr<float>(dy + h + 2);
      const uint8_t* in_row = &in_image[static_cast<size_t>((dy + h + 1) * n)];
      const uint8_t* in_up = in_row - n;
      const uint8_t* in_down = in_row + n;
      // The point-mirrored pixel (the window is centred on the corner): a blurred X-junction
      // misfits the model symmetrically about its centre, which cancels in a symmetric window
      // only (a window cut on one side left corners near the border 0.1-0.25 px off).
      const uint8_t* mirror_row = &in_image[static_cast<size_t>((h - dy + 1) * n)];
      const uint8_t* mirror_up = mirror_row - n;
      const uint8_t* mirror_down = mirror_row + n;
      for (int dx = -h; dx <= h; ++dx) {
        const int c = dx + h + 1, m = h - dx + 1;
        if (!(in_row[c - 1] && in_row[c + 1] && in_up[c] && in_down[c] && mirror_row[m - 1] &&
              mirror_row[m + 1] && mirror_up[m] && mirror_down[m]))
          continue;
        const Eigen::Vector2d g(0.5 * (row[c + 1] - row[c - 1]), 0.5 * (down[c] - up[c]));
        const double w = weights[static_cast<size_t>((dy + h) * (2 * h + 1) + dx + h)];
        measured += w;
        f(Eigen::Vector2d(dx, dy), w, g);
      }
    }
    return measured;
  };
  const Eigen::Vector2d start = *uv;
  Eigen::Vector2d q = start;
  Eigen::Matrix2d G = Eigen::Matrix2d::Zero();
  Eigen::Matrix2d G_inv = Eigen::Matrix2d::Zero();
  bool converged = false;
  for (int iteration = 0; iteration < 30; ++iteration) {
    if (!inside(warp == nullptr ? q : warp->ToImage(q), kRefineMinBorderPx))
      return false;
    sample_patch(q);
    G.setZero();
    Eigen::Vector2d b = Eigen::Vector2d::Zero();
    const double measured =
        for_each_gradient([&](const Eigen::Vector2d& d, double w, const Eigen::Vector2d& g) {
          const Eigen::Matrix2d wgg = w * g * g.transpose();
          G += wgg;
          b += wgg * d;  // p_i - q_current
        });
    // Most of the window beyond the image: too little of the junction is seen.
    if (measured < kRefineMinMeasuredWeight * weight_sum)
      return false;
    const double det = G.determinant();
    if (!(det > 1e-9 * G.trace() * G.trace()) || G.trace() <= 0.0)
      return false;
    G_inv = G.inverse();
    const Eigen::Vector2d step = G_inv * b;
    q += step;
    if ((q - start).norm() > h + 1.0)
      return false;
    // Converged at a thousandth of a pixel: the bilinear re-sampling makes smaller steps noise.
    if (step.squaredNorm() < 1e-6) {
      converged = true;
      break;
    }
  }
  if (!converged)
    return false;
  if (sigma_px != nullptr) {
    sample_patch(q);
    Eigen::Matrix2d meat = Eigen::Matrix2d::Zero();
    for_each_gradient([&](const Eigen::Vector2d& d, double w, const Eigen::Vector2d& g) {
      meat += (w * w * d.squaredNorm()) * g * g.transpose();
    });
    const Eigen::Matrix2d cov = (0.5 * noise_sigma * noise_sigma) * G_inv * meat * G_inv;
    *sigma_px = std::sqrt(std::max(0.0, 0.5 * cov.trace()));
  }
  *uv = warp == nullptr ? q : warp->ToImage(q);
  return true;
}

// ---------------------------------------------------------------------------------------------
// libapriltag detectors: not thread-safe, so a small pool hands one to each concurrent call.

struct Detector::TagContext {
  internal::TagFamilyPtr family;
  apriltag_detector_t* detector = nullptr;
  ~TagContext() {
    if (detector != nullptr)
      apriltag_detector_destroy(detector);  // before the family: it frees the decode table
  }
};

struct Detector::Pool {
  std::mutex mutex;
  std::vector<std::unique_ptr<TagContext>> free;
};

namespace {

constexpr int kMinImageSide = 16;

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

// Tag id -> its four corners (tag order, px).
using TagCorners = std::map<int, std::array<Eigen::Vector2d, 4>>;

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

// Bilinear interpolation of an 8-bit image at (x, y) (pixel centres at integers); -1 outside.
double SampleBilinear(const cv::Mat& gray, double x, double y) {
  if (!(x >= 0.0 && y >= 0.0 && x <= gray.cols - 1.0 && y <= gray.rows - 1.0))
    return -1.0;
  const int x0 = std::min(static_cast<int>(x), gray.cols - 2);
  const int y0 = std::min(static_cast<int>(y), gray.rows - 2);
  const double fx = x - x0, fy = y - y0;
  const uint8_t* r0 = gray.ptr<uint8_t>(y0) + x0;
  const uint8_t* r1 = gray.ptr<uint8_t>(y0 + 1) + x0;
  return (1.0 - fy) * ((1.0 - fx) * r0[0] + fx * r0[1]) + fy * ((1.0 - fx) * r1[0] + fx * r1[1]);
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

// How far each refined corner of a tag lies off the tag's own edges (px), a check the grid and the
// code cannot make: on a foreshortened fisheye view a corner can slide 1-2 px along a narrow bit
// onto the corner square's side and the tag still reads as its code. Each edge's position is
// measured across it (the centroid of the intensity rise from the black border into the white
// gap) at 8 places along its middle (15-85 %, clear of the corner squares), relative to the edge
// the four refined corners predict (homography, tag cells -> px). Lens distortion bends the edge
// into a bow, zero at both ends: the offsets d(t) are fitted by
//   d(t) = alpha (1 - t) + beta t + gamma t (1 - t),
// and alpha, beta are the edge's offsets at its two corners, i.e. the corners' offsets across it.
// A corner's two edges give its offset; -1 where an edge cannot be measured (image border).
// The four edges of a tag measured against the edges its corners predict (see below).
struct TagEdgeFit {
  Eigen::Matrix3d H;  // tag cells (x right, y down the printed tag) -> px, through the corners
  // Each edge's offset at its start and end corner (cells, outward positive), where measured.
  std::array<Eigen::Vector2d, 4> ends;
  std::array<bool, 4> measured{};
};

// The tag's corners in tag cells, in the tag's corner order.
std::array<Eigen::Vector2d, 4> TagCellCorners(int cells) {
  const double n = cells;
  return {Eigen::Vector2d(0.0, n), Eigen::Vector2d(n, n), Eigen::Vector2d(n, 0.0),
          Eigen::Vector2d(0.0, 0.0)};
}

// Outward unit normal (tag cells) of edge k -> k+1: corners run clockwise on the printed tag
// (x right, y down), so outward is to the left.
Eigen::Vector2d TagEdgeOutward(int cells, size_t k) {
  const std::array<Eigen::Vector2d, 4> cell = TagCellCorners(cells);
  const Eigen::Vector2d along = (cell[(k + 1) % 4] - cell[k]) / cells;
  return Eigen::Vector2d(-along.y(), along.x());
}

Eigen::Vector2d ToPixel(const Eigen::Matrix3d& H, const Eigen::Vector2d& x) {
  return (H * x.homogeneous()).hnormalized();
}

// `reach`: how far across each edge (cells) the profile runs each way.
TagEdgeFit FitTagEdges(const cv::Mat& gray, const std::array<Eigen::Vector2d, 4>& corners,
                       int cells, double reach) {
  const std::array<Eigen::Vector2d, 4> cell = TagCellCorners(cells);
  std::vector<cv::Point2f> from, to;
  for (size_t k = 0; k < 4; ++k) {
    from.emplace_back(static_cast<float>(cell[k].x()), static_cast<float>(cell[k].y()));
    to.emplace_back(static_cast<float>(corners[k].x()), static_cast<float>(corners[k].y()));
  }
  const cv::Mat Hcv = cv::getPerspectiveTransform(from, to);
  TagEdgeFit fit;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      fit.H(r, c) = Hcv.at<double>(r, c);
  constexpr double kStep = 0.1;
  constexpr int kSamples = 8;
  for (size_t k = 0; k < 4; ++k) {
    const Eigen::Vector2d a = cell[k], b = cell[(k + 1) % 4];
    const Eigen::Vector2d outward = TagEdgeOutward(cells, k);
    Eigen::Matrix<double, kSamples, 3> A;
    Eigen::Matrix<double, kSamples, 1> d;
    bool ok = true;
    for (int j = 0; j < kSamples && ok; ++j) {
      const double t = 0.15 + 0.7 * j / (kSamples - 1);
      const Eigen::Vector2d base = a + t * (b - a);
      double previous = -1.0, sum_g = 0.0, sum_gs = 0.0;
      for (double s = -reach; s <= reach + 1e-9 && ok; s += kStep) {
        const Eigen::Vector2d uv = ToPixel(fit.H, base + s * outward);
        const double value = SampleBilinear(gray, uv.x(), uv.y());
        ok = value >= 0.0;
        if (ok && previous >= 0.0 && value > previous) {
          sum_g += value - previous;
          sum_gs += (value - previous) * (s - 0.5 * kStep);
        }
        previous = value;
      }
      ok = ok && sum_g > 0.0;
      A(j, 0) = 1.0 - t;
      A(j, 1) = t;
      A(j, 2) = t * (1.0 - t);
      d(j) = ok ? sum_gs / sum_g : 0.0;
    }
    if (!ok)
      continue;
    const Eigen::Vector3d x = A.colPivHouseholderQr().solve(d);
    fit.ends[k] = x.head<2>();
    fit.measured[k] = true;
  }
  return fit;
}

std::array<double, 4> TagCornerEdgeOffsets(const cv::Mat& gray,
                                           const std::array<Eigen::Vector2d, 4>& corners,
                                           int black_border, int cells) {
  const std::array<Eigen::Vector2d, 4> cell = TagCellCorners(cells);
  // Across the edge: inside stays in the black border, outside in the white gap.
  const TagEdgeFit fit = FitTagEdges(gray, corners, cells, std::min(0.8 * black_border, 1.6));
  const auto& ends = fit.ends;
  const auto& measured = fit.measured;
  const auto to_px = [&fit](const Eigen::Vector2d& x) { return ToPixel(fit.H, x); };
  const double n = cells;
  // Ends in px across their edge, with the tag's scale at each corner.
  std::array<Eigen::Vector2d, 4> ends_px;
  std::vector<double> all_ends;
  for (size_t k = 0; k < 4; ++k) {
    if (!measured[k])
      continue;
    const Eigen::Vector2d outward =
        Eigen::Vector2d(-(cell[(k + 1) % 4] - cell[k]).y(), (cell[(k + 1) % 4] - cell[k]).x()) / n;
    for (int e = 0; e < 2; ++e) {
      const Eigen::Vector2d& c = cell[(k + static_cast<size_t>(e)) % 4];
      ends_px[k](e) = ends[k](e) * (to_px(c + 0.5 * outward) - to_px(c - 0.5 * outward)).norm();
      all_ends.push_back(ends_px[k](e));
    }
  }
  // Ink spreads on the print and the camera's response is not linear: every edge of a real tag
  // sits a common distance outside (or inside) the line through its X-junctions (0.3-0.6 px on
  // EuRoC's views), which moves no X-junction. The median over the tag's edge ends is that
  // distance; a corner's offset is what remains.
  double spread = 0.0;
  if (!all_ends.empty()) {
    std::nth_element(all_ends.begin(), all_ends.begin() + static_cast<long>(all_ends.size() / 2),
                     all_ends.end());
    spread = all_ends[all_ends.size() / 2];
  }
  std::array<double, 4> offsets;
  for (size_t k = 0; k < 4; ++k) {
    const size_t before = (k + 3) % 4;  // the edge ending at corner k
    offsets[k] = measured[k] && measured[before]
                     ? std::hypot(ends_px[k](0) - spread, ends_px[before](1) - spread)
                     : -1.0;
  }
  return offsets;
}

// Half-width of a tag corner's refinement window: `borders` black borders of the tag's shortest
// edge (the clean neighbourhood of the junction is the border's width and the corner square),
// at least Kalibr's 5 x 5.
int TagCornerHalfWindow(int black_border, double bit_px, double borders) {
  return std::clamp(static_cast<int>(borders * black_border * bit_px), 2, 12);
}

// The tags whose four corners are all among `corners`.
TagCorners TagsOfCorners(const Board& board, const std::vector<DetectedCorner>& corners) {
  std::map<int, Eigen::Vector2d> uv_of;
  for (const DetectedCorner& c : corners)
    uv_of[c.id] = c.uv;
  TagCorners tags;
  for (int id = 0; id < board.NumTags(); ++id) {
    const std::array<int, 4> ids = board.TagCornerIds(id);
    if (std::all_of(ids.begin(), ids.end(), [&](int k) { return uv_of.count(k) > 0; })) {
      std::array<Eigen::Vector2d, 4> c;
      for (size_t k = 0; k < 4; ++k)
        c[k] = uv_of.at(ids[k]);
      tags[id] = c;
    }
  }
  return tags;
}

// Drops every accepted tag with a corner off the tag's own edges (TagCornerEdgeOffsets). How well
// the edges can be measured depends on the view (blur, ink, the camera's response: good corners
// of real TUM-VI views sit up to 1 px off, those of rendered views within 0.6 px), so a tag is an
// outlier when its largest offset exceeds both max_edge_offset_px and `kViewMedians` times the
// view's median of that largest offset.
void DropTagsOffTheirEdges(const cv::Mat& gray, const Board& board, const DetectorOptions& options,
                           DetectionResult* result) {
  constexpr double kViewMedians = 4.0;
  const int border = board.config().black_tag_border;
  const int cells = Board::kTagDataBits + 2 * border;
  const TagCorners tags = TagsOfCorners(board, result->corners);
  std::map<int, double> worst;
  for (const auto& [id, uv] : tags) {
    const std::array<double, 4> offsets = TagCornerEdgeOffsets(gray, uv, border, cells);
    worst[id] = *std::max_element(offsets.begin(), offsets.end());
  }
  if (worst.empty())
    return;
  std::vector<double> values;
  for (const auto& entry : worst)
    values.push_back(entry.second);
  std::nth_element(values.begin(), values.begin() + static_cast<long>(values.size() / 2),
                   values.end());
  const double bound =
      std::max(options.max_edge_offset_px, kViewMedians * values[values.size() / 2]);
  for (const auto& [id, offset] : worst) {
    if (!(offset > bound))
      continue;
    const std::array<int, 4> ids = board.TagCornerIds(id);
    result->corners.erase(std::remove_if(result->corners.begin(), result->corners.end(),
                                         [&ids](const DetectedCorner& c) {
                                           return std::find(ids.begin(), ids.end(), c.id) !=
                                                  ids.end();
                                         }),
                          result->corners.end());
    --result->tags_accepted;
    result->rejected.push_back({id, RejectReason::kOffEdges});
  }
}

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

}  // namespace

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

Detector::Detector(const Board& board, const DetectorOptions& options)
    : board_(board), options_(options), pool_(std::make_unique<Pool>()) {}

Detector::~Detector() = default;

std::unique_ptr<Detector::TagContext> Detector::AcquireTagContext() const {
  {
    std::lock_guard<std::mutex> lock(pool_->mutex);
    if (!pool_->free.empty()) {
      std::unique_ptr<TagContext> context = std::move(pool_->free.back());
      pool_->free.pop_back();
      return context;
    }
  }
  auto context = std::make_unique<TagContext>();
  context->family = internal::CreateTag36h11(board_.config().black_tag_border);
  float decimate = options_.quad_decimate;
  if (decimate <= 0.0f)
    decimate = board_.config().black_tag_border >= 2 ? 2.0f : 1.0f;
  context->detector = NewApriltagDetector(context->family.get(), decimate);
  return context;
}

void Detector::ReleaseTagContext(std::unique_ptr<TagContext> context) const {
  std::lock_guard<std::mutex> lock(pool_->mutex);
  pool_->free.push_back(std::move(context));
}

DetectionResult Detector::Detect(const cv::Mat& image) const {
  DetectionResult result;
  cv::Mat gray;
  try {
    gray = ToGray8(image);
  } catch (const std::exception& e) {
    result.error = e.what();
    return result;
  }
  if (!gray.isContinuous())
    gray = gray.clone();
  // No board fits in fewer pixels (and libapriltag's decimation needs a few to work on).
  if (gray.cols < kMinImageSide || gray.rows < kMinImageSide)
    return result;
  // The 8-bit quantisation alone is uniform noise of 1/sqrt(12) grey levels.
  const double noise_sigma =
      options_.refine ? std::max(EstimateNoiseSigma(gray), 1.0 / std::sqrt(12.0)) : 0.0;
  switch (board_.type()) {
    case TargetType::kAprilGrid:
      result = DetectAprilGrid(gray, noise_sigma);
      break;
    case TargetType::kCheckerboard:
      result = DetectCheckerboard(gray, noise_sigma);
      break;
    case TargetType::kCharuco:
      result = DetectCharuco(gray, noise_sigma);
      break;
  }
  if (options_.refine && result.board_found) {
    if (board_.type() == TargetType::kAprilGrid)
      RefineTagCorners(gray, noise_sigma, &result);
    if (options_.rectify)
      RefineRectified(gray, noise_sigma, &result);
    AddModelError(&result);
  }
  return result;
}

namespace {

// The final estimate of a corner refined with a capture window: refined again from there with the
// smaller window `half_window` (the lens' outward pull grows with the window's area, the noise
// falls only with its width; docs/targets.md). A corner the final window moves by more than 0.3
// px keeps the capture estimate (on TUM-VI's blurred fisheye rim the two differ by up to that).
void RefineFinal(const cv::Mat& gray, double noise_sigma, int half_window, DetectedCorner* corner) {
  constexpr double kMaxMovePx = 0.3;
  Eigen::Vector2d uv = corner->uv;
  double sigma = 0.0;
  if (RefineCorner(gray, half_window, &uv, &sigma, noise_sigma) &&
      (uv - corner->uv).norm() <= kMaxMovePx) {
    corner->uv = uv;
    corner->sigma = sigma;
  }
}

}  // namespace

// Every accepted tag corner refined once more from its estimate with the final window
// (DetectorOptions::tag_window_borders, smaller than the capture window): the lens' outward pull
// grows with the window's area while the noise only falls with its width (docs/targets.md). The
// detection's decisions (completion, code and edge checks, the grid scatter) all rest on the
// capture window's corners, as before: on TUM-VI's blurred fisheye rim the final window's corners
// differ by up to 0.3 px, which the grid completion's line extrapolation amplifies 7-fold. A
// corner the final window moves by more than that keeps its capture estimate.
void Detector::RefineTagCorners(const cv::Mat& gray, double noise_sigma,
                                DetectionResult* result) const {
  const int border = board_.config().black_tag_border;
  const int cells = 6 + 2 * border;
  std::vector<DetectedCorner>& corners = result->corners;  // sorted by id
  const auto find = [&](int id) -> DetectedCorner* {
    const auto it = std::lower_bound(corners.begin(), corners.end(), id,
                                     [](const DetectedCorner& c, int key) { return c.id < key; });
    return it != corners.end() && it->id == id ? &*it : nullptr;
  };
  for (int tag = 0; tag < board_.NumTags(); ++tag) {
    const std::array<int, 4> ids = board_.TagCornerIds(tag);
    std::array<DetectedCorner*, 4> c{};
    bool whole = true;
    for (size_t k = 0; k < 4; ++k)
      whole &= (c[k] = find(ids[k])) != nullptr;
    if (!whole)
      continue;
    double edge = std::numeric_limits<double>::infinity();
    for (size_t k = 0; k < 4; ++k)
      edge = std::min(edge, (c[k]->uv - c[(k + 1) % 4]->uv).norm());
    const double bit_px = edge / cells;
    const int fine = TagCornerHalfWindow(border, bit_px, options_.tag_window_borders);
    if (fine == TagCornerHalfWindow(border, bit_px, kCaptureWindowBorders))
      continue;
    for (DetectedCorner* corner : c)
      RefineFinal(gray, noise_sigma, fine, corner);
  }
}

// The refinement's sigma propagates image noise only. The corners of a view also carry errors
// that no noise term sees: the refinement's model of an X-junction against the real blurred one,
// the print, the lens' point-spread. Their size shows in how far the corners scatter about a
// smooth grid (EstimateGridScatter); what exceeds the noise is this view's model error, added in
// quadrature to every corner's noise sigma.
void Detector::AddModelError(DetectionResult* result) const {
  const GridScatter scatter = EstimateGridScatter(board_, result->corners);
  double noise2 = 0.0;
  for (const DetectedCorner& c : result->corners)
    noise2 += c.sigma * c.sigma / static_cast<double>(result->corners.size());
  result->grid_scatter_px =
      scatter.windows >= options_.min_scatter_windows ? scatter.sigma_px : 0.0;
  const double model2 = scatter.windows >= options_.min_scatter_windows
                            ? std::max(0.0, scatter.sigma_px * scatter.sigma_px - noise2)
                            : options_.default_model_sigma_px * options_.default_model_sigma_px;
  result->model_sigma_px = std::sqrt(model2);
  for (DetectedCorner& c : result->corners)
    c.sigma = std::max(options_.min_sigma_px, std::sqrt(c.sigma * c.sigma + model2));
  // Corners that scatter by pixels about every row and column are not where this board's file
  // puts them: a board of another size in view (Kalibr's sample grid read with a 6 x 6 file: 29
  // tags, 38 px; with the right 8-column file 2.4 px), whose ids still decode. No observation
  // rather than a wrong one.
  if (result->grid_scatter_px > options_.max_grid_scatter_px) {
    result->rejected.push_back({-1, RejectReason::kNotThisBoard});
    result->corners.clear();
    result->board_found = false;
  }
}

DetectionResult Detector::DetectAprilGrid(const cv::Mat& gray, double noise_sigma) const {
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
    const double margin = options_.min_border_distance_px;
    const int cells = Board::kTagDataBits + 2 * board_.config().black_tag_border;
    for (const TagDetection& tag : tags) {
      if (tag.id >= board_.NumTags()) {
        result.rejected.push_back({tag.id, RejectReason::kUnknownId});
        continue;
      }
      if (id_count[tag.id] > 1) {
        result.rejected.push_back({tag.id, RejectReason::kDuplicateId});
        continue;
      }
      bool near_border = false;
      for (const Eigen::Vector2d& c : tag.corners) {
        near_border |= c.x() < margin || c.y() < margin || c.x() > gray.cols - 1 - margin ||
                       c.y() > gray.rows - 1 - margin;
      }
      if (near_border) {
        result.rejected.push_back({tag.id, RejectReason::kNearBorder});
        continue;
      }
      // The shortest edge sets the scale of the window and of the jump bound: a foreshortened
      // tag's bits are narrow across it, and the next X-junction is that much closer.
      double edge = std::numeric_limits<double>::infinity();
      for (size_t k = 0; k < 4; ++k)
        edge = std::min(edge, (tag.corners[k] - tag.corners[(k + 1) % 4]).norm());
      const double bit_px = edge / cells;
      if (bit_px < options_.min_bit_px) {
        result.rejected.push_back({tag.id, RejectReason::kTooSmall});
        continue;
      }
      // libapriltag fits straight edges; under strong distortion (fisheye lenses) a large tag's
      // edges bend and its quad corners miss the true corner by a few pixels. The next X-junction
      // is two (narrowest) bits away, so a jump up to 0.8 bit still lands on the right one.
      const double max_jump = std::max(options_.max_refinement_jump_px, 0.8 * bit_px);
      const std::array<int, 4> ids = board_.TagCornerIds(tag.id);
      std::array<DetectedCorner, 4> refined;
      bool ok = true;
      for (size_t k = 0; k < 4; ++k) {
        refined[k].id = ids[k];
        refined[k].uv = tag.corners[k];
        refined[k].sigma = options_.default_sigma_px;
        if (!options_.refine)
          continue;
        double sigma = 0.0;
        if (!RefineCorner(gray,
                          TagCornerHalfWindow(board_.config().black_tag_border, bit_px,
                                              kCaptureWindowBorders),
                          &refined[k].uv, &sigma, noise_sigma) ||
            (refined[k].uv - tag.corners[k]).norm() > max_jump) {
          ok = false;
          break;
        }
        refined[k].sigma = sigma;  // noise only; Detect adds the view's model error
      }
      // A refined corner that landed on another junction shifts the bit grid near it: the tag
      // must still read as its code word at the refined corners.
      if (ok && options_.refine) {
        std::array<Eigen::Vector2d, 4> uv;
        for (size_t k = 0; k < 4; ++k)
          uv[k] = refined[k].uv;
        const int distance = TagCodeDistance(gray, uv, board_, tag.id);
        ok = distance >= 0 && distance <= 2;
      }
      if (!ok) {
        result.rejected.push_back({tag.id, RejectReason::kRefinementJump});
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
  // same at full resolution, which finds small or sharply printed tags that decimation loses.
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
  if (context->detector->quad_decimate > 1.0f && tag_missing(result)) {
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
  if (result.tags_accepted < options_.min_tags) {
    if (result.tags_accepted > 0)
      result.rejected.push_back({-1, RejectReason::kTooFewTags});
    result.corners.clear();
  }
  std::sort(result.corners.begin(), result.corners.end(),
            [](const DetectedCorner& a, const DetectedCorner& b) { return a.id < b.id; });
  result.board_found = !result.corners.empty();
  return result;
}

namespace {

// Puts findChessboardCornersSB's corners (row by row, `cols` per row) into the board's order and
// checks that they are this board's inner corners; false if not. SB orders the grid by the image,
// not by the print: of 32 rendered equidistant views of a 7 x 6 board it returned 4 turned by a
// half (the earlier check sampled two squares through one homography of the whole board, a
// square off under this distortion) and 2 with a row of the board's outer edge against the white
// paper in place of a row of inner corners (a grid of the right size, one row of real corners
// short; docs/targets.md). What settles it is the print itself: every cell of the grid, the outer
// ring of squares included, must be black where the board prints black.
// - Handedness: a camera looking at the printed side sees the board's x (the row index) turned
//   counter-clockwise by 90 deg from its y (the column index) in the image (v down), whatever
//   the roll: the cross product of the column step and the row step is positive. SB does not know
//   which side is printed; a grid it lists mirrored gets each row reversed.
// - A half turn maps cell (i, j) onto (rows - 2 - i, cols - 2 - j), which changes its colour when
//   rows + cols is odd: the reading whose black cells are darker is the board's. When rows + cols
//   is even the half turn looks the same and OpenCV's order stands (as in Kalibr).
// Each cell is read at its centre, from its nearest corner and that corner's steps to its row and
// column neighbours (local: a homography through the whole board misses by a square on a fisheye).
bool OrderCheckerboardCorners(const cv::Mat& gray, int rows, int cols,
                              std::vector<cv::Point2f>* found) {
  const auto at = [&](int r, int c) {
    const cv::Point2f& p = (*found)[static_cast<size_t>(r * cols + c)];
    return Eigen::Vector2d(p.x, p.y);
  };
  double handedness = 0.0;
  for (int r = 0; r + 1 < rows; ++r) {
    for (int c = 0; c + 1 < cols; ++c) {
      const Eigen::Vector2d col_step = at(r, c + 1) - at(r, c), row_step = at(r + 1, c) - at(r, c);
      handedness += col_step.x() * row_step.y() - col_step.y() * row_step.x();
    }
  }
  if (handedness < 0.0) {
    for (int r = 0; r < rows; ++r)
      std::reverse(found->begin() + r * cols, found->begin() + (r + 1) * cols);
  }
  // Cell (i, j), i in -1..rows-1, j in -1..cols-1, lies between corner rows i, i+1 and columns
  // j, j+1; the board prints it black when i + j is even (the square before corner 0 is black).
  struct Cell {
    double intensity;
    bool black;
  };
  std::vector<Cell> cells;
  for (int i = -1; i < rows; ++i) {
    for (int j = -1; j < cols; ++j) {
      const int r = std::clamp(i, 0, rows - 1), c = std::clamp(j, 0, cols - 1);
      // Cells of the outer ring are read a quarter square out: printed boards are often cut
      // inside their outer squares (opencv-doc's left*.jpg); paper beyond a false row is paper
      // at any distance.
      const double toward_row = (i >= r ? 1.0 : -1.0) * (i < 0 || i == rows - 1 ? 0.5 : 1.0);
      const double toward_col = (j >= c ? 1.0 : -1.0) * (j < 0 || j == cols - 1 ? 0.5 : 1.0);
      const Eigen::Vector2d row_step =
          r + 1 < rows ? at(r + 1, c) - at(r, c) : at(r, c) - at(r - 1, c);
      const Eigen::Vector2d col_step =
          c + 1 < cols ? at(r, c + 1) - at(r, c) : at(r, c) - at(r, c - 1);
      const Eigen::Vector2d centre =
          at(r, c) + 0.5 * toward_row * row_step + 0.5 * toward_col * col_step;
      const double intensity = SampleBilinear(gray, centre.x(), centre.y());
      if (intensity >= 0.0)  // cells beyond the image are not read
        cells.push_back({intensity, (i + j) % 2 == 0});
    }
  }
  double black_minus_white = 0.0;
  for (const Cell& cell : cells)
    black_minus_white += cell.black ? cell.intensity : -cell.intensity;
  if ((rows + cols) % 2 == 1 && black_minus_white > 0.0) {
    std::reverse(found->begin(), found->end());
    for (Cell& cell : cells)
      cell.black = !cell.black;
  }
  // Every cell on its side of the midpoint between the black and the white cells' mean
  // intensities: a row of paper taken for squares reads white where black is printed.
  double black_sum = 0.0, white_sum = 0.0;
  int blacks = 0;
  for (const Cell& cell : cells) {
    (cell.black ? black_sum : white_sum) += cell.intensity;
    blacks += cell.black;
  }
  const int whites = static_cast<int>(cells.size()) - blacks;
  if (blacks == 0 || whites == 0)
    return false;
  const double threshold = 0.5 * (black_sum / blacks + white_sum / whites);
  return std::all_of(cells.begin(), cells.end(),
                     [&](const Cell& cell) { return cell.black == (cell.intensity < threshold); });
}

}  // namespace

DetectionResult Detector::DetectCheckerboard(const cv::Mat& gray, double noise_sigma) const {
  DetectionResult result;
  const int rows = board_.rows();
  const int cols = board_.cols();
  std::vector<cv::Point2f> found;
  // OpenCV's pattern size is (points per row, points per column) and it returns the points row
  // by row: index r * cols + c, the board's id.
  if (!cv::findChessboardCornersSB(gray, cv::Size(cols, rows), found, cv::CALIB_CB_NORMALIZE_IMAGE))
    return result;
  if (static_cast<int>(found.size()) != rows * cols)
    return result;
  if (!OrderCheckerboardCorners(gray, rows, cols, &found)) {
    result.rejected.push_back({-1, RejectReason::kNotThisBoard});
    return result;
  }
  // Capture window: 40 % of the smallest distance between neighbouring corners; the final
  // estimate with square_window_fraction of it (the lens' pull, RefineFinal).
  double min_step = 1e9;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c + 1 < cols; ++c) {
      const cv::Point2f d = found[r * cols + c + 1] - found[r * cols + c];
      min_step = std::min(min_step, static_cast<double>(std::hypot(d.x, d.y)));
    }
  }
  const int half_window = std::clamp(static_cast<int>(0.4 * min_step), 2, 12);
  const int final_window =
      std::clamp(static_cast<int>(options_.square_window_fraction * min_step), 2, 12);
  // findChessboardCornersSB's corners are already sub-pixel but its outer-row corners are off by
  // up to ~1.5 px on real photos (opencv-doc's left*.jpg), which the refinement corrects; the
  // next X-junction is a whole square away, so a fifth of a square is still the same corner.
  const double max_jump = std::max(options_.max_refinement_jump_px, 0.2 * min_step);
  for (int id = 0; id < rows * cols; ++id) {
    DetectedCorner corner;
    corner.id = id;
    corner.uv = Eigen::Vector2d(found[id].x, found[id].y);
    corner.sigma = options_.default_sigma_px;
    if (options_.refine) {
      Eigen::Vector2d uv = corner.uv;
      double sigma = 0.0;
      if (RefineCorner(gray, half_window, &uv, &sigma, noise_sigma) &&
          (uv - corner.uv).norm() <= max_jump) {
        corner.uv = uv;
        corner.sigma = sigma;  // noise only; Detect adds the view's model error
        if (final_window < half_window)
          RefineFinal(gray, noise_sigma, final_window, &corner);
      } else {
        result.rejected.push_back({id, RejectReason::kRefinementJump});
        continue;
      }
    }
    result.corners.push_back(corner);
  }
  result.board_found = !result.corners.empty();
  return result;
}

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

std::vector<DetectionResult> Detector::DetectFiles(
    const std::vector<std::string>& paths,
    const std::function<void(size_t, size_t)>& progress) const {
  std::vector<DetectionResult> results(paths.size());
  std::atomic<size_t> next{0};
  std::mutex progress_mutex;
  size_t done = 0;
  auto worker = [&] {
    for (size_t i = next++; i < paths.size(); i = next++) {
      const cv::Mat image = cv::imread(paths[i], cv::IMREAD_UNCHANGED);
      if (image.empty()) {
        results[i].error = "cannot read image " + paths[i];
      } else {
        results[i] = Detect(image);
        results[i].image_width = image.cols;
        results[i].image_height = image.rows;
        if (!results[i].error.empty())
          results[i].error = paths[i] + ": " + results[i].error;
      }
      if (progress) {
        std::lock_guard<std::mutex> lock(progress_mutex);
        progress(++done, paths.size());
      }
    }
  };
  int threads = options_.threads > 0 ? options_.threads
                                     : static_cast<int>(std::thread::hardware_concurrency());
  threads = std::clamp(threads, 1, std::max<int>(1, static_cast<int>(paths.size())));
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t)
    pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool)
    t.join();
  return results;
}

}  // namespace ctcal
