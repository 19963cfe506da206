// RefineCorner (detector.h): an X-junction's sub-pixel position and its noise covariance.
#include <opencv2/core.hpp>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

#include "ctcal/targets/detector.h"

namespace ctcal {

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

// The window's Gaussian weights (sigma (h + 1) / 2), row-major over (2h+1)^2 pixels: computed once
// per half-width up to kCachedHalf (a view refines a few hundred corners with a few widths).
constexpr int kCachedHalf = 32;
std::vector<double> ComputeWeights(int h) {
  const double weight_sigma = 0.5 * (h + 1);
  std::vector<double> weights(static_cast<size_t>((2 * h + 1) * (2 * h + 1)));
  for (int dy = -h; dy <= h; ++dy) {
    for (int dx = -h; dx <= h; ++dx) {
      weights[static_cast<size_t>((dy + h) * (2 * h + 1) + dx + h)] =
          std::exp(-(dx * dx + dy * dy) / (2.0 * weight_sigma * weight_sigma));
    }
  }
  return weights;
}
const std::vector<double>& WindowWeights(int h, std::vector<double>* uncached) {
  static const std::vector<std::vector<double>> table = [] {
    std::vector<std::vector<double>> t;
    for (int k = 0; k <= kCachedHalf; ++k)
      t.push_back(ComputeWeights(k));
    return t;
  }();
  if (h <= kCachedHalf)
    return table[static_cast<size_t>(h)];
  *uncached = ComputeWeights(h);
  return *uncached;
}
// The n x n patch whose centre sample lies at `at` (pixel centres at integer coordinates), each
// sample bilinear in its four neighbours with the same weights (one sub-pixel offset for the whole
// patch), as cv::getRectSubPix gives it (float, the border pixels repeated beyond the image) but
// without its per-call set-up, which was a third of a tracked view's refinement.
void SamplePatch(const cv::Mat& gray, const Eigen::Vector2d& at, int n, float* patch) {
  const double x = at.x() - 0.5 * (n - 1), y = at.y() - 0.5 * (n - 1);
  const double x_floor = std::floor(x), y_floor = std::floor(y);
  const int ix = static_cast<int>(x_floor), iy = static_cast<int>(y_floor);
  const float ax = static_cast<float>(x - x_floor), ay = static_cast<float>(y - y_floor);
  const float w00 = (1.0f - ax) * (1.0f - ay), w01 = ax * (1.0f - ay);
  const float w10 = (1.0f - ax) * ay, w11 = ax * ay;
  const size_t step = gray.step[0];
  if (ix >= 0 && iy >= 0 && ix + n < gray.cols && iy + n < gray.rows) {
    for (int r = 0; r < n; ++r) {
      const uint8_t* top = gray.ptr<uint8_t>(iy + r) + ix;
      const uint8_t* bottom = top + step;
      float* out = patch + r * n;
      for (int c = 0; c < n; ++c)
        out[c] = top[c] * w00 + top[c + 1] * w01 + bottom[c] * w10 + bottom[c + 1] * w11;
    }
    return;
  }
  const auto clamp_x = [&](int v) { return std::clamp(v, 0, gray.cols - 1); };
  const auto clamp_y = [&](int v) { return std::clamp(v, 0, gray.rows - 1); };
  for (int r = 0; r < n; ++r) {
    const uint8_t* top = gray.ptr<uint8_t>(clamp_y(iy + r));
    const uint8_t* bottom = gray.ptr<uint8_t>(clamp_y(iy + r + 1));
    float* out = patch + r * n;
    for (int c = 0; c < n; ++c) {
      const int left = clamp_x(ix + c), right = clamp_x(ix + c + 1);
      out[c] = top[left] * w00 + top[right] * w01 + bottom[left] * w10 + bottom[right] * w11;
    }
  }
}
// One pixel's terms (offset d = (dx, dy), weight w, gradient g = (gx, gy)): w g g^T into G and
// w g g^T d into b; with kMeat, w^2 |d|^2 g g^T into the covariance's middle (in gxx, gxy, gyy).
template <bool kMeat>
inline void AddPixel(double dx, double dy, double w, double gx, double gy, double& gxx, double& gxy,
                     double& gyy, double& bx, double& by) {
  if constexpr (kMeat) {
    const double scale = w * w * (dx * dx + dy * dy);
    gxx += scale * gx * gx;
    gxy += scale * gx * gy;
    gyy += scale * gy * gy;
  } else {
    const double wgx = w * gx, wgy = w * gy;
    const double along = gx * dx + gy * dy;  // g^T d
    gxx += wgx * gx;
    gxy += wgx * gy;
    gyy += wgy * gy;
    bx += wgx * along;
    by += wgy * along;
  }
}

// The normal equations' sums over a window whose every pixel's gradient is measured (the patch
// wholly inside the image, `patch` n x n with the window's (2h+1)^2 pixels inside its one-pixel
// rim): G = sum w g g^T (gxx, gxy, gyy) and b = sum w g g^T d (bx, by), or with kMeat the
// covariance's sum w^2 |d|^2 g g^T instead (in gxx, gxy, gyy; bx, by zero). One loop per row
// that the compiler vectorises (the sums reassociated across its SIMD lanes).
struct WindowSums {
  double gxx = 0.0, gxy = 0.0, gyy = 0.0, bx = 0.0, by = 0.0;
};
template <bool kMeat>
WindowSums SumWholeWindow(const float* patch, int n, int h, const double* weights) {
  double gxx = 0.0, gxy = 0.0, gyy = 0.0, bx = 0.0, by = 0.0;
  const int m = 2 * h + 1;
  for (int dy = -h; dy <= h; ++dy) {
    const float* row = patch + (dy + h + 1) * n + 1;  // the window's first pixel of the row
    const float* up = row - n;
    const float* down = row + n;
    const double* w_row = weights + (dy + h) * m;
#pragma omp simd reduction(+ : gxx, gxy, gyy, bx, by)
    for (int k = 0; k < m; ++k) {
      const double dx = k - h;
      const double gx = 0.5 * static_cast<double>(row[k + 1] - row[k - 1]);
      const double gy = 0.5 * static_cast<double>(down[k] - up[k]);
      AddPixel<kMeat>(dx, dy, w_row[k], gx, gy, gxx, gxy, gyy, bx, by);
    }
  }
  return {gxx, gxy, gyy, bx, by};
}
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
  std::vector<double> uncached;
  const std::vector<double>& weights = WindowWeights(h, &uncached);
  double weight_sum = 0.0;
  for (double w : weights)
    weight_sum += w;
  // The patch (row-major, n x n floats), the thread's kept buffer: a tracked view refines a few
  // hundred corners, each over a few iterations.
  thread_local std::vector<float> patch_buffer;
  patch_buffer.resize(static_cast<size_t>(n * n));
  float* const patch = patch_buffer.data();
  // in_image[r * n + c]: the patch sample (r, c) lies in the image (outside, the sampling repeats
  // the border, which is no measurement).
  std::vector<uint8_t> in_image;
  // all_in: every sample of the patch lies in the image (most corners; no flag to look at).
  bool all_in = false;
  // The patch centred on `at` (pixel centres at integer coordinates); with a warp, `at` and the
  // patch are in rectified coordinates, each pixel read bilinearly at its image point.
  const auto sample_patch = [&](const Eigen::Vector2d& at) {
    if (warp == nullptr) {
      SamplePatch(gray, at, n, patch);
      all_in = inside(at, h + 1.0);
      if (all_in)
        return;
      in_image.resize(static_cast<size_t>(n * n));
      for (int r = 0; r < n; ++r) {
        for (int c = 0; c < n; ++c)
          in_image[static_cast<size_t>(r * n + c)] =
              inside(at + Eigen::Vector2d(c - h - 1, r - h - 1), 0.0);
      }
      return;
    }
    all_in = false;
    in_image.resize(static_cast<size_t>(n * n));
    for (int r = 0; r < n; ++r) {
      float* out = patch + r * n;
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
  // f(dx, dy, w, gx, gy) for every pixel of a window cut by the image border whose gradient is
  // measured (its four neighbours in the image): its offset (dx, dy) from the centre, its weight
  // w and the central-difference gradient (gx, gy) of the patch there. Returns the weight of those
  // pixels. (A window wholly inside: SumWholeWindow.)
  const auto for_each_gradient = [&](const auto& f) {
    double measured = 0.0;
    for (int dy = -h; dy <= h; ++dy) {
      const float* row = patch + (dy + h + 1) * n;
      const float* up = row - n;
      const float* down = row + n;
      const double* weight_row = &weights[static_cast<size_t>((dy + h) * (2 * h + 1))] + h;
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
        const double w = weight_row[dx];
        measured += w;
        f(dx, dy, w, 0.5 * (row[c + 1] - row[c - 1]), 0.5 * (down[c] - up[c]));
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
    // G and b = sum_i w_i g_i g_i^T d_i with d_i = p_i - q_current, as scalars (G symmetric).
    double gxx = 0.0, gxy = 0.0, gyy = 0.0, bx = 0.0, by = 0.0;
    double measured = weight_sum;
    if (all_in) {
      const WindowSums sums = SumWholeWindow<false>(patch, n, h, weights.data());
      gxx = sums.gxx, gxy = sums.gxy, gyy = sums.gyy, bx = sums.bx, by = sums.by;
    } else {
      measured = for_each_gradient([&](int dx, int dy, double w, double gx, double gy) {
        AddPixel<false>(dx, dy, w, gx, gy, gxx, gxy, gyy, bx, by);
      });
    }
    G << gxx, gxy, gxy, gyy;
    const Eigen::Vector2d b(bx, by);
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
    double mxx = 0.0, mxy = 0.0, myy = 0.0;
    if (all_in) {
      const WindowSums sums = SumWholeWindow<true>(patch, n, h, weights.data());
      mxx = sums.gxx, mxy = sums.gxy, myy = sums.gyy;
    } else {
      double unused_x = 0.0, unused_y = 0.0;
      for_each_gradient([&](int dx, int dy, double w, double gx, double gy) {
        AddPixel<true>(dx, dy, w, gx, gy, mxx, mxy, myy, unused_x, unused_y);
      });
    }
    Eigen::Matrix2d meat;
    meat << mxx, mxy, mxy, myy;
    const Eigen::Matrix2d cov = (0.5 * noise_sigma * noise_sigma) * G_inv * meat * G_inv;
    *sigma_px = std::sqrt(std::max(0.0, 0.5 * cov.trace()));
  }
  *uv = warp == nullptr ? q : warp->ToImage(q);
  return true;
}

}  // namespace ctcal
