// The detector's passes shared across its files (detector*.cpp, apriltag_tags.cpp,
// tag_edges.cpp, corner_refinement.cpp): libapriltag runs, tag checks, grid completion, the final
// refinement. Each is documented where it is defined. Private to targets/.
#pragma once

#include <opencv2/core.hpp>

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <map>
#include <optional>
#include <set>
#include <vector>

#include "ctcal/targets/board.h"
#include "ctcal/targets/detector.h"
#include "tag_family.h"

extern "C" {
#include <apriltag/common/zarray.h>
}

namespace ctcal::internal {

// The window of the tag corners' refinement during detection, in black borders: its capture range
// brings a start a pixel or two off (libapriltag's straight-edge quads, the grid completion's
// extrapolations on blurred fisheye rims) onto the junction. The final estimate comes from
// DetectorOptions::tag_window_borders (Detector::RefineTagCorners).
constexpr double kCaptureWindowBorders = 0.8;

// Smaller images are no views (libapriltag and the refinement need some room).
constexpr int kMinImageSide = 16;

// Tag id -> its four corners (tag order, px).
using TagCorners = std::map<int, std::array<Eigen::Vector2d, 4>>;

// apriltag_tags.cpp: libapriltag and the checks of single tags.
apriltag_detector_t* NewApriltagDetector(apriltag_family_t* family, float quad_decimate);
std::vector<TagDetection> RunApriltag(apriltag_detector_t* detector, const cv::Mat& gray);
bool InnerBorderIsBlack(const cv::Mat& gray, const TagDetection& tag, int black_border);
bool MissingTagInView(const Board& board, const TagCorners& tags, const cv::Size& image_size,
                      double margin_px);
// Bilinear interpolation of an 8-bit image at (x, y) (pixel centres at integers); -1 outside.
// Inline: the edge and code checks read ~30 000 samples per view.
inline double SampleBilinear(const cv::Mat& gray, double x, double y) {
  if (!(x >= 0.0 && y >= 0.0 && x <= gray.cols - 1.0 && y <= gray.rows - 1.0))
    return -1.0;
  const int x0 = std::min(static_cast<int>(x), gray.cols - 2);
  const int y0 = std::min(static_cast<int>(y), gray.rows - 2);
  const double fx = x - x0, fy = y - y0;
  const uint8_t* r0 = gray.ptr<uint8_t>(y0) + x0;
  const uint8_t* r1 = gray.ptr<uint8_t>(y0 + 1) + x0;
  return (1.0 - fy) * ((1.0 - fx) * r0[0] + fx * r0[1]) + fy * ((1.0 - fx) * r1[0] + fx * r1[1]);
}
int TagCodeDistance(const cv::Mat& gray, const std::array<Eigen::Vector2d, 4>& corners,
                    const Board& board, int id);
std::vector<TagDetection> RunCheckingBorder(apriltag_detector_t* detector, const cv::Mat& image,
                                            const cv::Mat& gray, const Board& board,
                                            std::set<int>* bad_border);
std::vector<TagDetection> DetectGridTags(apriltag_detector_t* detector, const cv::Mat& gray,
                                         const Board& board, std::set<int>* bad_border,
                                         const std::vector<TagDetection>* first_pass);

// tag_edges.cpp: where tags' corners lie against their edges.
int TagCornerHalfWindow(int black_border, double bit_px, double borders);
TagCorners TagsOfCorners(const Board& board, const std::vector<DetectedCorner>& corners);
void DropTagsOffTheirEdges(const cv::Mat& gray, const Board& board, const DetectorOptions& options,
                           DetectionResult* result);

// detector_aprilgrid.cpp: one tag's rules and refinement, a view's last rules, and tags
// libapriltag missed, found from the board.
std::optional<RejectReason> AcceptTag(const cv::Mat& gray, double noise_sigma, const Board& board,
                                      const DetectorOptions& options, int id,
                                      const std::array<Eigen::Vector2d, 4>& corners,
                                      std::array<DetectedCorner, 4>* refined);
void FinishTagView(const DetectorOptions& options, DetectionResult* result);
void CompleteGrid(const cv::Mat& gray, double noise_sigma, const Board& board,
                  const DetectorOptions& options, const std::set<int>& excluded,
                  DetectionResult* result);

// detector.cpp: a corner's final estimate after its capture window.
void RefineFinal(const cv::Mat& gray, double noise_sigma, int half_window, DetectedCorner* corner);

}  // namespace ctcal::internal

namespace ctcal {

// A libapriltag detector, held by Detector's pool (libapriltag is not thread-safe, so each
// concurrent call gets its own). Its family is the pool's, shared by every context: the family's
// quick-decode table (2 corrected bits: 18.8 MB, 80-270 ms to build; detector.cpp, Detector::Pool)
// is built once and only read while decoding. libapriltag frees a family's table when any detector
// holding it is destroyed, so a context lets go of the family first; the pool's owner frees it
// last.
struct Detector::TagContext {
  apriltag_detector_t* detector = nullptr;
  ~TagContext() {
    if (detector == nullptr)
      return;
    zarray_clear(detector->tag_families);
    apriltag_detector_destroy(detector);
  }
};

}  // namespace ctcal
