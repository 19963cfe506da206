// Synthetic images of a board as a camera sees it, for the simulator (`ctcal simulate --images`)
// and the detector's tests. Knows no camera model: the camera comes in as its unprojection.
//
// Per-pixel inverse mapping: each pixel's footprint (its four corners, rays precomputed once per
// camera) is intersected with the board plane z_W = 0 and the board's texture is sampled there;
// pixels whose four corners see different inks are supersampled (box filter, the pixel's area),
// then the image is blurred (optics), noise is added (sensor), and it is quantised to 8 bits.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <cstdint>
#include <functional>
#include <vector>

#include "ctcal/targets/board.h"

namespace ctcal {

// Pixel (SPEC section 4 coordinates) -> unit-free viewing ray in the camera frame C; false where
// the camera sees nothing (outside a fisheye's image circle).
using UnprojectFunction = std::function<bool(const Eigen::Vector2d& uv, Eigen::Vector3d* ray_C)>;

struct RenderOptions {
  int supersampling = 4;       // samples per axis in pixels that straddle an ink edge
  double blur_sigma_px = 0.6;  // Gaussian point-spread of the optics (0 = none)
  double noise_sigma = 1.5;    // additive Gaussian noise, grey levels
  double black_level = 30.0;   // grey levels of the ink, the paper and the world behind
  double white_level = 220.0;
  double background_level = 90.0;
  // White paper around the printed pattern (m); negative = the pattern's own feature scale
  // (one tag gap for an AprilGrid, one square for a checkerboard).
  double sheet_margin_m = -1.0;
};

class BoardRenderer {
 public:
  // Unprojects the (width+1) x (height+1) pixel corners once.
  BoardRenderer(const Board& board, int width, int height, const UnprojectFunction& unproject,
                const RenderOptions& options = {});

  // Global shutter: the board frame W seen from camera pose T_W_C.
  cv::Mat Render(const Eigen::Isometry3d& T_W_C, uint64_t seed) const;
  // Rolling shutter: pixel row v is exposed at pose T_W_C_of_row(v).
  cv::Mat Render(const std::function<Eigen::Isometry3d(int row)>& T_W_C_of_row,
                 uint64_t seed) const;

  int width() const { return width_; }
  int height() const { return height_; }

 private:
  // Ink codes of a board-plane sample.
  enum Ink : uint8_t { kBlack = 0, kWhite = 1, kBackground = 2 };
  Ink InkAt(double x, double y) const;
  // Board-plane points and inks of one row of pixel corners under one pose.
  void IntersectCornerRow(int corner_row, const Eigen::Isometry3d& T_W_C,
                          std::vector<Eigen::Vector2d>* xy, std::vector<uint8_t>* ink) const;
  void ShadeRow(const std::vector<Eigen::Vector2d>& xy_top, const std::vector<uint8_t>& ink_top,
                const std::vector<Eigen::Vector2d>& xy_bottom,
                const std::vector<uint8_t>& ink_bottom, float* out) const;
  cv::Mat Finish(cv::Mat radiance, uint64_t seed) const;

  Board board_;
  int width_;
  int height_;
  RenderOptions options_;
  Eigen::AlignedBox2d sheet_;
  double feature_size_;
  std::vector<Eigen::Vector3d> corner_rays_C_;  // (height+1) x (width+1), row-major
  std::vector<uint8_t> corner_ray_valid_;
};

}  // namespace ctcal
