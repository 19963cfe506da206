#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <map>
#include <vector>

#include "ctcal/targets/detector.h"

namespace ctcal {

// Along a row or a column of the point grid the board points lie on a straight line, and the
// camera maps that line to a smooth curve. A cubic of the board coordinate s fitted to 5
// consecutive corners leaves residuals that are the corners' own scatter (noise, blur, print, the
// refinement's model error) plus the fourth-order bend of perspective and lens distortion that a
// cubic misses, which is negligible over 5 corners: on rendered radtan, equidistant and double-
// sphere views the estimate matches the true error within ~20 % (a quadratic, or a cubic over 6
// corners, picked up the distortion: 2-4x the true error on fisheye views). For Gaussian scatter
// of sigma per coordinate a window's residual sum of squares (u and v) is sigma^2 chi^2(2); the
// median over all windows, divided by the chi^2 median, is robust to a few bad corners.
GridScatter EstimateGridScatter(const Board& board, const std::vector<DetectedCorner>& corners) {
  constexpr int kWindow = 5;
  constexpr int kTerms = 4;
  // Median of chi^2 with 2 * (kWindow - kTerms) = 2 degrees of freedom: 2 ln 2.
  constexpr double kChi2Median = 1.386294;
  std::map<int, Eigen::Vector2d> uv_of;
  for (const DetectedCorner& c : corners)
    uv_of[c.id] = c.uv;
  std::vector<double> rss;
  const auto fit_line = [&](const std::vector<int>& ids) {
    for (size_t start = 0; start + kWindow <= ids.size(); ++start) {
      bool complete = true;
      for (int k = 0; k < kWindow; ++k)
        complete &= uv_of.count(ids[start + static_cast<size_t>(k)]) > 0;
      if (!complete)
        continue;
      const Eigen::Vector3d& first = board.Corner(ids[start]);
      const double span = (board.Corner(ids[start + kWindow - 1]) - first).norm();
      Eigen::Matrix<double, kWindow, kTerms> A;
      Eigen::Matrix<double, kWindow, 2> b;
      for (int k = 0; k < kWindow; ++k) {
        const int id = ids[start + static_cast<size_t>(k)];
        const double s = 2.0 * (board.Corner(id) - first).norm() / span - 1.0;  // in [-1, 1]
        for (int j = 0; j < kTerms; ++j)
          A(k, j) = std::pow(s, j);
        b.row(k) = uv_of.at(id).transpose();
      }
      const Eigen::Matrix<double, kTerms, 2> x = A.colPivHouseholderQr().solve(b);
      rss.push_back((A * x - b).squaredNorm());
    }
  };
  for (int r = 0; r < board.rows(); ++r) {
    std::vector<int> ids;
    for (int c = 0; c < board.cols(); ++c)
      ids.push_back(r * board.cols() + c);
    fit_line(ids);
  }
  for (int c = 0; c < board.cols(); ++c) {
    std::vector<int> ids;
    for (int r = 0; r < board.rows(); ++r)
      ids.push_back(r * board.cols() + c);
    fit_line(ids);
  }
  GridScatter out;
  out.windows = static_cast<int>(rss.size());
  if (rss.empty())
    return out;
  const auto mid = rss.begin() + static_cast<long>(rss.size() / 2);
  std::nth_element(rss.begin(), mid, rss.end());
  out.sigma_px = std::sqrt(*mid / kChi2Median);
  return out;
}

}  // namespace ctcal
