// LocalBoardWarp: the second-order bending of the board-to-image map at a corner, from its grid
// neighbours. A map that is exactly quadratic in the board coordinates is recovered exactly, and
// a corner without neighbours on both sides gets no warp.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <vector>

#include "ctcal/targets/detector.h"

namespace ctcal {
namespace {

// u(x) = u0 + J x + 1/2 [x' Q_u x, x' Q_v x] of the board coordinates x (m).
struct QuadraticMap {
  Eigen::Vector2d u0{320.0, 240.0};
  Eigen::Matrix2d J = (Eigen::Matrix2d() << 900.0, 150.0, -80.0, 700.0).finished();
  Eigen::Matrix2d Q_u = (Eigen::Matrix2d() << 400.0, -250.0, -250.0, 900.0).finished();
  Eigen::Matrix2d Q_v = (Eigen::Matrix2d() << -600.0, 300.0, 300.0, 200.0).finished();
  Eigen::Vector2d operator()(const Eigen::Vector2d& x) const {
    return u0 + J * x + 0.5 * Eigen::Vector2d(x.dot(Q_u * x), x.dot(Q_v * x));
  }
};

std::vector<DetectedCorner> Corners(const Board& board, const QuadraticMap& map,
                                    const Eigen::Vector2d& x0) {
  std::vector<DetectedCorner> corners;
  for (int id = 0; id < board.NumCorners(); ++id)
    corners.push_back({id, map(board.Corner(id).head<2>() - x0), 0.03});
  return corners;
}

TEST(LocalBoardWarp, RecoversAQuadraticMapExactly) {
  const Board board(TargetConfig{});  // 6 x 6 AprilGrid: a 12 x 12 point grid
  const QuadraticMap map;
  const int id = 5 * board.cols() + 6;
  const std::vector<DetectedCorner> corners = Corners(board, map, board.Corner(id).head<2>());
  CornerWarp warp;
  double px_per_m = 0.0;
  ASSERT_TRUE(LocalBoardWarp(board, corners, static_cast<size_t>(id), 0.01, &warp, &px_per_m));
  // In image offsets e = J dx: H = J^-T Q J^-1.
  const Eigen::Matrix2d J_inv = map.J.inverse();
  EXPECT_LT((warp.H_u - J_inv.transpose() * map.Q_u * J_inv).norm(), 1e-9);
  EXPECT_LT((warp.H_v - J_inv.transpose() * map.Q_v * J_inv).norm(), 1e-9);
  EXPECT_NEAR(px_per_m, Eigen::JacobiSVD<Eigen::Matrix2d>(map.J).singularValues()(1), 1e-6);
  EXPECT_EQ(warp.origin, corners[static_cast<size_t>(id)].uv);
  // The warp maps the rectified image of a board line back onto the image of that line: points
  // J dx on the straight line land on the quadratic map's curve.
  for (const double s : {-0.02, -0.01, 0.01, 0.02}) {
    const Eigen::Vector2d dx(s, 0.5 * s);
    EXPECT_LT((warp.ToImage(warp.origin + map.J * dx) - map(dx)).norm(), 1e-9) << s;
  }
}

TEST(LocalBoardWarp, NeedsNeighboursOnBothSides) {
  const Board board(TargetConfig{});
  const QuadraticMap map;
  CornerWarp warp;
  double px_per_m = 0.0;
  // A corner on the board's edge (row 0).
  const int edge = 6;
  EXPECT_FALSE(LocalBoardWarp(board, Corners(board, map, board.Corner(edge).head<2>()),
                              static_cast<size_t>(edge), 0.01, &warp, &px_per_m));
  // An inner corner whose right-hand neighbours are missing.
  const int id = 5 * board.cols() + 6;
  std::vector<DetectedCorner> corners;
  for (const DetectedCorner& c : Corners(board, map, board.Corner(id).head<2>()))
    if (c.id % board.cols() <= 6)
      corners.push_back(c);
  size_t index = 0;
  while (corners[index].id != id)
    ++index;
  EXPECT_FALSE(LocalBoardWarp(board, corners, index, 0.01, &warp, &px_per_m));
}

// Corners that no quadratic fits (another board's layout, a board that is not flat) give no warp.
TEST(LocalBoardWarp, RejectsCornersOffASmoothMap) {
  const Board board(TargetConfig{});
  const QuadraticMap map;
  const int id = 5 * board.cols() + 6;
  std::vector<DetectedCorner> corners = Corners(board, map, board.Corner(id).head<2>());
  corners[static_cast<size_t>(id + 1)].uv.x() += 3.0;
  CornerWarp warp;
  double px_per_m = 0.0;
  EXPECT_FALSE(LocalBoardWarp(board, corners, static_cast<size_t>(id), 1.0, &warp, &px_per_m));
}

// With no bending the warped refinement reads the same bilinear samples as the plain one: same
// corner (to the float rounding of OpenCV's sampler), same sigma. A warp that bends the patch
// (0.9 px at the window's edge) moves the result: the patch is really read through it.
TEST(LocalBoardWarp, ZeroBendIsThePlainRefinement) {
  cv::Mat image(64, 64, CV_8U, cv::Scalar(200));
  const cv::Point2f q(31.3f, 32.6f);
  // An X-junction at q: two opposite black quadrants, blurred.
  for (int v = 0; v < image.rows; ++v)
    for (int u = 0; u < image.cols; ++u)
      if ((u - q.x) * (v - q.y) > 0.0f)
        image.at<uint8_t>(v, u) = 40;
  cv::Mat blurred;
  cv::GaussianBlur(image, blurred, cv::Size(), 0.8);
  Eigen::Vector2d plain(30.5, 33.4), warped = plain;
  double sigma_plain = 0.0, sigma_warped = 0.0;
  ASSERT_TRUE(RefineCorner(blurred, 5, &plain, &sigma_plain, 1.5));
  CornerWarp warp;
  warp.origin = warped;
  ASSERT_TRUE(RefineCorner(blurred, 5, &warped, &sigma_warped, 1.5, &warp));
  EXPECT_LT((plain - warped).norm(), 1e-3);
  EXPECT_NEAR(sigma_plain, sigma_warped, 1e-3 * sigma_plain);
  CornerWarp bent = warp;
  bent.H_u << 0.05, 0.0, 0.0, 0.05;
  Eigen::Vector2d moved = Eigen::Vector2d(30.5, 33.4);
  ASSERT_TRUE(RefineCorner(blurred, 5, &moved, nullptr, 1.5, &bent));
  EXPECT_GT((moved - plain).norm(), 0.01);
}

}  // namespace
}  // namespace ctcal
