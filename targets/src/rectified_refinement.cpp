#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <vector>

#include "ctcal/targets/detector.h"

namespace ctcal {

namespace {

// Grid neighbours on either side of a corner that the quadratic map is fitted to.
constexpr int kReach = 2;

const DetectedCorner* FindCorner(const std::vector<DetectedCorner>& sorted, int id) {
  const auto it = std::lower_bound(sorted.begin(), sorted.end(), id,
                                   [](const DetectedCorner& c, int key) { return c.id < key; });
  return it != sorted.end() && it->id == id ? &*it : nullptr;
}

// Radius (board metres) around a corner that holds only the junction's own two edges; the
// detectors' final refinements use the same fractions of the image's features.
double CleanRadiusM(const Board& board, const DetectorOptions& options) {
  const TargetConfig& config = board.config();
  switch (board.type()) {
    case TargetType::kAprilGrid:
      return options.tag_window_borders * config.black_tag_border * board.TagBitSize();
    case TargetType::kCheckerboard:
      return options.square_window_fraction * std::min(config.row_spacing_m, config.col_spacing_m);
    case TargetType::kCharuco:
      return std::min(0.5 * (config.square_length_m - config.marker_length_m),
                      options.square_window_fraction * config.square_length_m);
  }
  return 0.0;
}

}  // namespace

// Near a corner the board-to-image map u(x) of the board coordinates x is, to second order,
//   u(x0 + dx) = u0 + J dx + 1/2 [dx' Q_u dx, dx' Q_v dx].
// The board's lines through the corner are straight in e = J dx; the image point of e is
//   u0 + e + 1/2 [e' H_u e, e' H_v e],   H_u = J^-T Q_u J^-1 (likewise v),
// which is CornerWarp. J and Q come from a least-squares quadratic through the detected corners
// of the 5 x 5 grid neighbourhood; corner noise moves the fitted curvature, not the junction, so
// it only straightens the edges slightly less well.
bool LocalBoardWarp(const Board& board, const std::vector<DetectedCorner>& corners, size_t index,
                    double max_fit_px, CornerWarp* warp, double* px_per_m) {
  const DetectedCorner& centre = corners[index];
  const int r0 = centre.id / board.cols();
  const int c0 = centre.id % board.cols();
  const Eigen::Vector3d& x0 = board.Corner(centre.id);
  std::vector<Eigen::Vector2d> dx;
  std::vector<Eigen::Vector2d> uv;
  int row_mask = 0, col_mask = 0;
  double extent = 0.0;
  for (int dr = -kReach; dr <= kReach; ++dr) {
    for (int dc = -kReach; dc <= kReach; ++dc) {
      const int r = r0 + dr, c = c0 + dc;
      if (r < 0 || c < 0 || r >= board.rows() || c >= board.cols())
        continue;
      const DetectedCorner* n = FindCorner(corners, r * board.cols() + c);
      if (n == nullptr)
        continue;
      dx.push_back((board.Corner(n->id) - x0).head<2>());
      uv.push_back(n->uv);
      row_mask |= 1 << (dr + kReach);
      col_mask |= 1 << (dc + kReach);
      extent = std::max(extent, dx.back().cwiseAbs().maxCoeff());
    }
  }
  const auto bits = [](int mask) {
    int count = 0;
    for (; mask != 0; mask &= mask - 1)
      ++count;
    return count;
  };
  // Neighbours on both sides along both grid directions: a quadratic fitted to one side only
  // extrapolates the curvature, whose error (third-order bending) then moves the corner; at the
  // board's edge and the image's rim that pulled corners inward by 0.005-0.008 px.
  const int beside = 1 << (kReach - 1) | 1 << (kReach + 1);
  if (dx.size() < 8 || (row_mask & beside) != beside || (col_mask & beside) != beside ||
      bits(row_mask) < 3 || bits(col_mask) < 3 || !(extent > 0.0))
    return false;
  // Board coordinates scaled to [-1, 1] for the conditioning of the quadratic terms.
  const int m = static_cast<int>(dx.size());
  Eigen::MatrixXd A(m, 6);
  Eigen::MatrixXd b(m, 2);
  for (int k = 0; k < m; ++k) {
    const Eigen::Vector2d s = dx[static_cast<size_t>(k)] / extent;
    A.row(k) << 1.0, s.x(), s.y(), s.x() * s.x(), s.x() * s.y(), s.y() * s.y();
    b.row(k) = uv[static_cast<size_t>(k)].transpose();
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  if (qr.rank() < 6)
    return false;
  const Eigen::MatrixXd a = qr.solve(b);  // 6 x 2
  if ((A * a - b).rowwise().norm().maxCoeff() > max_fit_px)
    return false;
  Eigen::Matrix2d J;
  J << a(1, 0), a(2, 0), a(1, 1), a(2, 1);
  J /= extent;
  const double det = J.determinant();
  if (!(std::abs(det) > 0.0))
    return false;
  const Eigen::Matrix2d J_inv = J.inverse();
  const auto hessian = [&](int k) {
    Eigen::Matrix2d Q;
    Q << 2.0 * a(3, k), a(4, k), a(4, k), 2.0 * a(5, k);
    return Eigen::Matrix2d(J_inv.transpose() * (Q / (extent * extent)) * J_inv);
  };
  warp->origin = centre.uv;
  warp->H_u = hessian(0);
  warp->H_v = hessian(1);
  // The smaller singular value of J: the smaller eigenvalue of J'J, whose determinant is det^2.
  const double trace = J.squaredNorm();
  *px_per_m = std::sqrt(
      std::max(0.0, 0.5 * (trace - std::sqrt(std::max(0.0, trace * trace - 4.0 * det * det)))));
  return true;
}

void Detector::RefineRectified(const cv::Mat& gray, double noise_sigma,
                               DetectionResult* result) const {
  // A neighbourhood the quadratic misses by more than this is not a smooth view of a flat board.
  constexpr double kMaxFitPx = 1.0;
  // The rectified junction is the same junction: farther than this is a refinement gone astray,
  // and the first refinement's corner stands.
  constexpr double kMaxMovePx = 1.0;
  const std::vector<DetectedCorner> first = result->corners;  // every fit sees the same corners
  const double clean_m = CleanRadiusM(board_, options_);
  for (size_t i = 0; i < first.size(); ++i) {
    CornerWarp warp;
    double px_per_m = 0.0;
    if (!LocalBoardWarp(board_, first, i, kMaxFitPx, &warp, &px_per_m))
      continue;
    const int half_window = std::clamp(static_cast<int>(clean_m * px_per_m), 2, 12);
    // The warp's bend over the window: beyond a pixel the quadratic is extrapolated too far.
    const double h = half_window + 1.0;
    if (0.5 * h * h * std::max(warp.H_u.norm(), warp.H_v.norm()) > 1.0)
      continue;
    Eigen::Vector2d uv = first[i].uv;
    double sigma = 0.0;
    if (RefineCorner(gray, half_window, &uv, &sigma, noise_sigma, &warp) &&
        (uv - first[i].uv).norm() <= kMaxMovePx) {
      result->corners[i].uv = uv;
      result->corners[i].sigma = sigma;
    }
  }
}

}  // namespace ctcal
