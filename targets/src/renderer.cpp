#include "ctcal/targets/renderer.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ctcal {

BoardRenderer::BoardRenderer(const Board& board, int width, int height,
                             const UnprojectFunction& unproject, const RenderOptions& options)
    : board_(board), width_(width), height_(height), options_(options) {
  if (width < 1 || height < 1)
    throw std::invalid_argument("BoardRenderer: image size must be positive");
  if (!unproject)
    throw std::invalid_argument("BoardRenderer: no unprojection given");
  options_.supersampling = std::max(1, options_.supersampling);
  double margin = options.sheet_margin_m;
  if (margin < 0.0) {
    margin = board.type() == TargetType::kAprilGrid
                 ? board.config().tag_spacing * board.config().tag_size
                 : std::min(board.config().row_spacing_m, board.config().col_spacing_m);
  }
  sheet_ = board.PatternBox();
  sheet_.min() -= Eigen::Vector2d::Constant(margin);
  sheet_.max() += Eigen::Vector2d::Constant(margin);
  feature_size_ = board.FeatureSize();
  const size_t n = static_cast<size_t>(width + 1) * static_cast<size_t>(height + 1);
  corner_rays_C_.resize(n);
  corner_ray_valid_.resize(n);
  for (int r = 0; r <= height; ++r) {
    for (int c = 0; c <= width; ++c) {
      const size_t i = static_cast<size_t>(r) * static_cast<size_t>(width + 1) + c;
      Eigen::Vector3d ray;
      const bool ok = unproject(Eigen::Vector2d(c - 0.5, r - 0.5), &ray) && ray.allFinite() &&
                      ray.squaredNorm() > 0.0;
      corner_ray_valid_[i] = ok ? 1 : 0;
      corner_rays_C_[i] = ok ? ray : Eigen::Vector3d::Zero();
    }
  }
}

BoardRenderer::Ink BoardRenderer::InkAt(double x, double y) const {
  if (!sheet_.contains(Eigen::Vector2d(x, y)))
    return kBackground;
  return board_.IsBlack(x, y) ? kBlack : kWhite;
}

void BoardRenderer::IntersectCornerRow(int corner_row, const Eigen::Isometry3d& T_W_C,
                                       std::vector<Eigen::Vector2d>* xy,
                                       std::vector<uint8_t>* ink) const {
  // Ray p_W(t) = t_W_C + t * R_W_C * ray_C meets z_W = 0 at t = -t_W_C.z / (R_W_C * ray_C).z,
  // which must be positive (in front of the camera).
  const Eigen::Matrix3d& R_W_C = T_W_C.linear();
  const Eigen::Vector3d& t_W_C = T_W_C.translation();
  xy->resize(static_cast<size_t>(width_ + 1));
  ink->resize(static_cast<size_t>(width_ + 1));
  const size_t base = static_cast<size_t>(corner_row) * static_cast<size_t>(width_ + 1);
  for (int c = 0; c <= width_; ++c) {
    const size_t i = base + static_cast<size_t>(c);
    uint8_t code = 3;  // no intersection
    if (corner_ray_valid_[i]) {
      const Eigen::Vector3d d_W = R_W_C * corner_rays_C_[i];
      const double t = -t_W_C.z() / d_W.z();
      if (std::isfinite(t) && t > 0.0) {
        (*xy)[static_cast<size_t>(c)] = t_W_C.head<2>() + t * d_W.head<2>();
        code = InkAt((*xy)[static_cast<size_t>(c)].x(), (*xy)[static_cast<size_t>(c)].y());
      }
    }
    (*ink)[static_cast<size_t>(c)] = code;
  }
}

void BoardRenderer::ShadeRow(const std::vector<Eigen::Vector2d>& xy_top,
                             const std::vector<uint8_t>& ink_top,
                             const std::vector<Eigen::Vector2d>& xy_bottom,
                             const std::vector<uint8_t>& ink_bottom, float* out) const {
  const float levels[3] = {static_cast<float>(options_.black_level),
                           static_cast<float>(options_.white_level),
                           static_cast<float>(options_.background_level)};
  const int ss = options_.supersampling;
  const double inv_ss = 1.0 / ss;
  for (int c = 0; c < width_; ++c) {
    const size_t l = static_cast<size_t>(c);
    const size_t r = l + 1;
    const uint8_t a = ink_top[l], b = ink_top[r], d = ink_bottom[l], e = ink_bottom[r];
    if (a == 3 || b == 3 || d == 3 || e == 3) {
      out[c] = levels[kBackground];  // (part of) the pixel sees no board plane
      continue;
    }
    const Eigen::Vector2d& p00 = xy_top[l];
    const Eigen::Vector2d& p10 = xy_top[r];
    const Eigen::Vector2d& p01 = xy_bottom[l];
    const Eigen::Vector2d& p11 = xy_bottom[r];
    // A pixel whose footprint is smaller than the finest printed feature and whose corners agree
    // is uniform; otherwise an edge (or a whole feature) may cross it.
    const double extent =
        std::max((p11 - p00).cwiseAbs().maxCoeff(), (p10 - p01).cwiseAbs().maxCoeff());
    if (a == b && a == d && a == e && extent < feature_size_) {
      out[c] = levels[a];
      continue;
    }
    // Box filter over the pixel; within one pixel the plane mapping is bilinear to first order.
    float sum = 0.0f;
    for (int j = 0; j < ss; ++j) {
      const double fy = (j + 0.5) * inv_ss;
      const Eigen::Vector2d left = p00 + fy * (p01 - p00);
      const Eigen::Vector2d right = p10 + fy * (p11 - p10);
      for (int i = 0; i < ss; ++i) {
        const double fx = (i + 0.5) * inv_ss;
        const Eigen::Vector2d p = left + fx * (right - left);
        sum += levels[InkAt(p.x(), p.y())];
      }
    }
    out[c] = sum / static_cast<float>(ss * ss);
  }
}

cv::Mat BoardRenderer::Render(const Eigen::Isometry3d& T_W_C, uint64_t seed) const {
  cv::Mat radiance(height_, width_, CV_32F);
  std::vector<Eigen::Vector2d> xy_top, xy_bottom;
  std::vector<uint8_t> ink_top, ink_bottom;
  IntersectCornerRow(0, T_W_C, &xy_top, &ink_top);
  for (int v = 0; v < height_; ++v) {
    IntersectCornerRow(v + 1, T_W_C, &xy_bottom, &ink_bottom);
    ShadeRow(xy_top, ink_top, xy_bottom, ink_bottom, radiance.ptr<float>(v));
    std::swap(xy_top, xy_bottom);
    std::swap(ink_top, ink_bottom);
  }
  return Finish(radiance, seed);
}

cv::Mat BoardRenderer::Render(const std::function<Eigen::Isometry3d(int row)>& T_W_C_of_row,
                              uint64_t seed) const {
  cv::Mat radiance(height_, width_, CV_32F);
  std::vector<Eigen::Vector2d> xy_top, xy_bottom;
  std::vector<uint8_t> ink_top, ink_bottom;
  for (int v = 0; v < height_; ++v) {
    // The whole pixel row is read at row v's time: both corner rows use its pose.
    const Eigen::Isometry3d T_W_C = T_W_C_of_row(v);
    IntersectCornerRow(v, T_W_C, &xy_top, &ink_top);
    IntersectCornerRow(v + 1, T_W_C, &xy_bottom, &ink_bottom);
    ShadeRow(xy_top, ink_top, xy_bottom, ink_bottom, radiance.ptr<float>(v));
  }
  return Finish(radiance, seed);
}

cv::Mat BoardRenderer::Finish(cv::Mat radiance, uint64_t seed) const {
  if (options_.blur_sigma_px > 0.0) {
    cv::GaussianBlur(radiance, radiance, cv::Size(), options_.blur_sigma_px, options_.blur_sigma_px,
                     cv::BORDER_REPLICATE);
  }
  if (options_.noise_sigma > 0.0) {
    cv::Mat noise(radiance.size(), CV_32F);
    cv::RNG rng(seed);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, options_.noise_sigma);
    radiance += noise;
  }
  cv::Mat image;
  radiance.convertTo(image, CV_8U);  // rounds and saturates
  return image;
}

}  // namespace ctcal
