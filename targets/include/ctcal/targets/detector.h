// Board corner detection in one image or in many (parallel over images, deterministic output).
//
// Pixel convention (SPEC section 4): pixel (0, 0) is the centre of the top-left pixel, as in
// OpenCV. libapriltag puts the centre of the top-left pixel at (0.5, 0.5); its corners are shifted
// by -0.5 px on the way out.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <array>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "ctcal/targets/board.h"

namespace ctcal {

struct DetectedCorner {
  int id = -1;
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();  // px, SPEC section 4
  double sigma = 0.0;                            // px, per coordinate
};

// Kalibr's rules plus the refinement's own checks; defaults follow Kalibr where it has one.
struct DetectorOptions {
  // A tag with a corner closer than this to the image border is dropped (Kalibr: 4 px).
  double min_border_distance_px = 4.0;
  // A view with fewer accepted tags is no observation (Kalibr: minTagsForValidObs = 4).
  int min_tags = 4;
  // A corner the sub-pixel refinement moves farther than this is dropped with its whole tag
  // (Kalibr: maxSubpixDisplacement2 = 1.5 px^2, i.e. 1.22 px), or 0.8 bit of the tag's shortest
  // edge if larger (distorted and foreshortened tags, docs/targets.md).
  double max_refinement_jump_px = 1.22;
  // A tag narrower than this per bit along its shortest edge is dropped: the refinement window
  // then reaches the next X-junction (rendered double-sphere views: corners of tags at 1.2-1.5
  // px per bit were off by ~1 px). Set between that and the simulator's 512x512 fisheye, whose
  // tags at ~1.7 px per bit have corners within 0.17 px (95 %); tests/sim/test_images.cpp.
  double min_bit_px = 1.6;
  // A tag with a refined corner farther than this from its own edges (measured across each edge
  // along its middle, extrapolated to the corner) is dropped: on oblique fisheye views a corner
  // can slide along a narrow bit onto the corner square and still pass the jump bound and the
  // code check. On rendered double-sphere views good corners sit within 0.56 px (99.9 %), corners
  // more than 1 px off at 0.73-2.9 px (docs/targets.md).
  double max_edge_offset_px = 0.75;
  // Half-width of a tag corner's refinement window, in black borders of the tag's shortest edge
  // (2-12 px). The lens bends the junction's edges, which pulls the estimate outward in
  // proportion to the window's area (0.005-0.009 px at mid-field with 0.8, the same in every
  // view), while the noise grows only as one over the window's width: with 0.5 the corners'
  // error is ~20 % larger, the pull half as large, and images-only calibrations end with their
  // camera parameters within 3 sigma of the truth instead of 3-6.5 sigma off (docs/targets.md).
  double tag_window_borders = 0.5;
  // Half-width of the final refinement window of checkerboard and ChArUco corners, in squares
  // (2-12 px), after the capture window (0.4 square; ChArUco: the margin to the markers). The
  // same pull as for tags: a 12 px window left a checkerboard's corners 0.009 px outward at a
  // radtan camera's mid-field and 0.01-0.02 px on an equidistant fisheye (docs/targets.md).
  double square_window_fraction = 0.125;
  // Sub-pixel refinement on/off. The reported sigma is the refinement's noise sigma and the view's
  // model error (EstimateGridScatter beyond the noise) in quadrature, at least min_sigma_px.
  bool refine = true;
  // Inner corners refined once more in a patch rectified by their grid neighbourhood's quadratic
  // board map (LocalBoardWarp): it removes most of the lens' outward pull from them (0.007 px at
  // mid-field with a 0.8 window, 0.003 px with tag_window_borders' 0.5), but the board's edge
  // corners keep it, and that difference biased a radtan focal length by 4.8 sigma on
  // independently rendered images. Off until edge corners are rectified too (docs/targets.md).
  bool rectify = false;
  double min_sigma_px = 0.01;
  // The model error is measured only on views with at least this many grid fits (5 corners in a
  // row or column each); on others it is taken as default_model_sigma_px (rendered views: 0.02-
  // 0.05 px, real EuRoC and TUM-VI views 0.04 px, docs/targets.md).
  int min_scatter_windows = 12;
  double default_model_sigma_px = 0.04;
  // A view whose corners scatter about the board's grid by more than this (px) is not this board
  // (rendered and real views with the right file: 0.02-2.8 px, Kalibr's blurred sample images
  // the most; a grid read with a file of another column count: 11-140 px).
  double max_grid_scatter_px = 5.0;
  // Reported when no refinement ran (px).
  double default_sigma_px = 0.5;
  // libapriltag's quad search on an image decimated by this factor (corners are then fitted at
  // full resolution and refined). 0 = automatic: 2 for Kalibr's 2-bit border, 3x faster than 1
  // and, by averaging away the thin bridges between tags and the corner squares, finding more
  // tags on real photos; 1 for 1-bit borders, whose quads lose corners when decimated.
  float quad_decimate = 0.0f;
  // Worker threads for DetectFiles (0 = hardware concurrency).
  int threads = 0;
  // Sequences (DetectFiles, the calibrator's bags; AprilGrids): each frame's tags tracked from
  // the frames before (BoardTracker, board_tracking.h), libapriltag only where that fails. Off:
  // every image detected on its own, as Detect does.
  bool track = true;
  // A sequence is tracked in chunks of this many frames, each from a full detection on one
  // worker: a fixed length, so that the corners do not depend on the thread count.
  int track_chunk_frames = 50;
  // While a tracked frame misses a tag that the board puts inside the image, the full detector
  // runs at most every this many frames (tags coming into view apart from the tracked ones).
  int track_redetect_frames = 10;
};

enum class RejectReason {
  kNearBorder,      // a tag corner within min_border_distance_px of the image border
  kDuplicateId,     // the same tag id decoded twice (both dropped: which one is the board's?)
  kUnknownId,       // a tag id the board does not have (another board in view, wrong file?)
  kRefinementJump,  // refinement moved a corner too far / did not converge / the tag no
                    // longer reads as its code word at the refined corners
  kBadBorder,       // decoded, but its black border is not blackTagBorder bits wide
  kTooSmall,        // fewer than min_bit_px pixels per bit: too small to refine its corners
  kOffEdges,        // a refined corner lies off the tag's own edges (max_edge_offset_px)
  kTooFewTags,      // the whole view: fewer than min_tags tags left
  kNotThisBoard,    // the whole view: corners scatter about the grid by more than
                    // max_grid_scatter_px (a board of another size in view)
};
const char* ToString(RejectReason reason);

struct TagRejection {
  int tag_id = -1;
  RejectReason reason = RejectReason::kNearBorder;
};

struct DetectionResult {
  bool board_found = false;             // a valid observation of the board (corners non-empty)
  std::vector<DetectedCorner> corners;  // sorted by id
  int tags_detected = 0;  // tags (AprilGrid) or markers (ChArUco) decoded before the rules
  int tags_accepted = 0;
  std::vector<TagRejection> rejected;
  std::string error;    // set when the image could not be used at all (unreadable, empty)
  int image_width = 0;  // of the image read by DetectFiles (0: not read)
  int image_height = 0;
  // The corners' scatter about a smooth grid (EstimateGridScatter; 0 when too few corners to
  // tell) and the model error taken from it, which every corner's sigma includes (px).
  double grid_scatter_px = 0.0;
  double model_sigma_px = 0.0;
  // The full detector (libapriltag) ran on this image; false: the board was tracked from the
  // frames before (BoardTracker).
  bool full_detection = true;
};

class Detector {
 public:
  explicit Detector(const Board& board, const DetectorOptions& options = {});
  ~Detector();
  Detector(const Detector&) = delete;
  Detector& operator=(const Detector&) = delete;

  const Board& board() const { return board_; }
  const DetectorOptions& options() const { return options_; }

  // Any of CV_8U / CV_16U with 1, 3 or 4 channels (colour is BGR/BGRA as ReadImageFile and
  // cv::imread give it).
  // Thread-safe: concurrent calls use separate libapriltag detectors.
  DetectionResult Detect(const cv::Mat& image) const;
  // Reads every file (ReadImageFile: PNG or JPEG, unchanged) and detects, `options().threads`
  // images at a time (with `options().track`: the files are one camera's frames in time order,
  // tracked in chunks); result i belongs to paths[i] whatever the thread schedule, a file that
  // cannot be read gets ReadImageFile's error. `progress(done, total)` is called from one thread
  // at a time.
  std::vector<DetectionResult> DetectFiles(
      const std::vector<std::string>& paths,
      const std::function<void(size_t, size_t)>& progress = nullptr) const;

 private:
  friend class BoardTracker;
  struct TagContext;
  std::unique_ptr<TagContext> AcquireTagContext() const;
  void ReleaseTagContext(std::unique_ptr<TagContext> context) const;
  // The 8-bit grey image and its noise sigma (grey levels, for the corners' sigma); false when the
  // image is no view (result->error set for an unusable one).
  bool PrepareGray(const cv::Mat& image, cv::Mat* gray, double* noise_sigma,
                   DetectionResult* result) const;
  // A found board's last steps: the final refinement (and rectified one), the model error.
  void FinishView(const cv::Mat& gray, double noise_sigma, DetectionResult* result) const;
  // `decimated_only`: without the last pass at full resolution (BoardTracker's re-detection in a
  // tracked frame, detector_aprilgrid.cpp).
  DetectionResult DetectAprilGrid(const cv::Mat& gray, double noise_sigma,
                                  bool decimated_only = false) const;
  DetectionResult DetectCheckerboard(const cv::Mat& gray, double noise_sigma) const;
  DetectionResult DetectCharuco(const cv::Mat& gray, double noise_sigma) const;
  // Every corner refined again in a patch rectified by its neighbourhood's quadratic board map
  // (LocalBoardWarp): on the straight-edged junction the refinement is not pulled outward by the
  // lens' bending nor by the foreshortening's scale change across its window.
  void RefineRectified(const cv::Mat& gray, double noise_sigma, DetectionResult* result) const;
  // Every AprilGrid corner refined once more with the final window (tag_window_borders).
  void RefineTagCorners(const cv::Mat& gray, double noise_sigma, DetectionResult* result) const;
  void AddModelError(DetectionResult* result) const;

  Board board_;
  DetectorOptions options_;
  struct Pool;
  std::unique_ptr<Pool> pool_;
};

// One 8-bit grey image from any supported input: 16-bit images are stretched from their own
// minimum to maximum (cameras store 10- or 12-bit data in 16-bit containers), colour is averaged
// to grey. Throws std::invalid_argument for other depths or channel counts.
cv::Mat ToGray8(const cv::Mat& image);

// A raw libapriltag tag36h11 detection with corners in SPEC section 4 pixels, in the tag's own
// order bottom-left, bottom-right, top-right, top-left (as seen printed upright).
struct TagDetection {
  int id = -1;
  int hamming = 0;
  double decision_margin = 0.0;
  std::array<Eigen::Vector2d, 4> corners;
};
// Every tag36h11 tag with a `black_border`-bit border (1 = AprilTag 3's standard tags, 2 =
// Kalibr's), unrefined and unfiltered, sorted by id.
std::vector<TagDetection> DetectTags36h11(const cv::Mat& image, int black_border,
                                          float quad_decimate = 1.0f);

// Refines an X-junction or a corner near `uv` by the gradient-orthogonality condition (every
// image gradient in a window is orthogonal to the vector from the corner to its pixel), weighted
// by a Gaussian; near the image border the window keeps its size and leaves out the pixels whose
// gradient is not measured and their mirror images through the corner (the corner must stay 2 px
// inside and keep a quarter of the window's weight). Returns false if it does not converge.
// `sigma_px` (optional): the estimate's standard deviation per coordinate caused by white image
// noise of `noise_sigma` grey levels, propagated through the refinement (docs/targets.md).
//
// `warp` (optional) refines in a locally rectified patch instead: a window pixel at offset e from
// `warp->origin` is read from the image at origin + e + 1/2 (e' H_u e, e' H_v e), the second-order
// bending of the board's lines (lens distortion, perspective) that LocalBoardWarp measures, so
// that the junction's edges are straight in the window; the result is mapped back into the image.
struct CornerWarp {
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();  // px, where the warp is the identity
  Eigen::Matrix2d H_u = Eigen::Matrix2d::Zero();     // 1/px, Hessian of the image u
  Eigen::Matrix2d H_v = Eigen::Matrix2d::Zero();     // 1/px, Hessian of the image v
  Eigen::Vector2d ToImage(const Eigen::Vector2d& rectified) const {
    const Eigen::Vector2d e = rectified - origin;
    return rectified + 0.5 * Eigen::Vector2d(e.dot(H_u * e), e.dot(H_v * e));
  }
};
bool RefineCorner(const cv::Mat& gray, int half_window, Eigen::Vector2d* uv,
                  double* sigma_px = nullptr, double noise_sigma = 1.0,
                  const CornerWarp* warp = nullptr);

// The board-to-image map near corners[index] (corners sorted by id) as a quadratic in the board
// coordinates, fitted to the detected corners of its 5 x 5 grid neighbourhood; its second
// derivatives in image pixels are the rectifying warp there. `px_per_m`: the map's smallest
// stretch (px per board metre). False without neighbours on both sides along both grid directions
// (a one-sided fit extrapolates the bending), with fewer than 8, or when the quadratic misses a
// corner by more than `max_fit_px` (corners of another board, or a board that is not flat).
bool LocalBoardWarp(const Board& board, const std::vector<DetectedCorner>& corners, size_t index,
                    double max_fit_px, CornerWarp* warp, double* px_per_m);

// How far the corners of one view scatter about a smooth grid (px per coordinate), estimated from
// the view alone: polynomials fitted along the rows and columns of the point grid, the median of
// their residuals (docs/targets.md). `windows`: how many fits it rests on (0: sigma_px unknown).
struct GridScatter {
  double sigma_px = 0.0;
  int windows = 0;
};
GridScatter EstimateGridScatter(const Board& board, const std::vector<DetectedCorner>& corners);

// The standard deviation of an 8-bit image's white noise (grey levels), robust to edges
// (Immerkaer's mask with a median).
double EstimateNoiseSigma(const cv::Mat& gray);

}  // namespace ctcal
