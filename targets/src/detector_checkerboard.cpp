// The checkerboard detection: OpenCV's findChessboardCornersSB, ordered by the print.
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

}  // namespace ctcal
