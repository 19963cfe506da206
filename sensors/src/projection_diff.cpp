#include "ctcal/sensors/projection_diff.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

namespace ctcal {

namespace {

constexpr double kPi = 3.14159265358979323846;

// R maximising sum_i b_i . (R a_i): with H = sum_i b_i a_i^T = U S V^T, R = U diag(1, 1, d) V^T,
// d = det(U V^T) keeping R a rotation (Kabsch).
Eigen::Matrix3d FitRotation(const std::vector<Eigen::Vector3d>& a,
                            const std::vector<Eigen::Vector3d>& b) {
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < a.size(); ++i)
    H += b[i] * a[i].transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

}  // namespace

ProjectionDiff DiffProjections(const CameraModel& a, const CameraModel& b,
                               const ProjectionDiffOptions& options) {
  if (a.resolution() != b.resolution())
    throw std::invalid_argument(
        "projection difference: the two cameras have different resolutions (" +
        std::to_string(a.width()) + "x" + std::to_string(a.height()) + " and " +
        std::to_string(b.width()) + "x" + std::to_string(b.height()) + ")");
  const int nx = std::max(options.cells_x, 2);
  const int ny = std::max(2, static_cast<int>(std::lround(nx * double(a.height()) / a.width())));
  const double W = a.width(), H = a.height();
  const auto cell_of = [&](const Eigen::Vector2d& uv, int* r, int* c) {
    *c = static_cast<int>(std::floor((uv.x() + 0.5) / W * nx));
    *r = static_cast<int>(std::floor((uv.y() + 0.5) / H * ny));
    return *c >= 0 && *c < nx && *r >= 0 && *r < ny;
  };

  ProjectionDiff out;
  out.width = a.width();
  out.height = a.height();
  out.observed = Eigen::MatrixXi::Constant(ny, nx, options.observed.empty() ? 1 : 0);
  for (const Eigen::Vector2d& uv : options.observed) {
    int r, c;
    if (uv.allFinite() && cell_of(uv, &r, &c))
      out.observed(r, c) = 1;
  }

  // Rays of both models at every cell centre.
  std::vector<std::optional<Eigen::Vector3d>> ray_a(static_cast<std::size_t>(nx * ny));
  std::vector<Eigen::Vector3d> fit_a, fit_b;
  for (int r = 0; r < ny; ++r) {
    for (int c = 0; c < nx; ++c) {
      const Eigen::Vector2d q(-0.5 + W * (c + 0.5) / nx, -0.5 + H * (r + 0.5) / ny);
      Eigen::Vector3d va, vb;
      if (!a.Unproject(q, &va))
        continue;
      ray_a[static_cast<std::size_t>(r * nx + c)] = va;
      if (out.observed(r, c) && b.Unproject(q, &vb)) {
        fit_a.push_back(va);
        fit_b.push_back(vb);
      }
    }
  }
  if (fit_a.size() < 3)
    throw std::invalid_argument(
        "projection difference: fewer than 3 observed grid points have "
        "a ray in both models");
  if (options.fit_rotation)
    out.R_b_a = FitRotation(fit_a, fit_b);
  const double cos_angle = std::clamp((out.R_b_a.trace() - 1.0) / 2.0, -1.0, 1.0);
  out.rotation_deg = std::acos(cos_angle) * 180.0 / kPi;

  const double nan = std::numeric_limits<double>::quiet_NaN();
  out.diff_px = Eigen::MatrixXd::Constant(ny, nx, nan);
  double sum = 0.0, sum_sq = 0.0;
  for (int r = 0; r < ny; ++r) {
    for (int c = 0; c < nx; ++c) {
      const auto& va = ray_a[static_cast<std::size_t>(r * nx + c)];
      Eigen::Vector2d qb;
      if (!va || !b.Project(out.R_b_a * *va, &qb))
        continue;
      const Eigen::Vector2d q(-0.5 + W * (c + 0.5) / nx, -0.5 + H * (r + 0.5) / ny);
      const double d = (qb - q).norm();
      out.diff_px(r, c) = d;
      if (!out.observed(r, c))
        continue;
      ++out.points;
      sum += d;
      sum_sq += d * d;
      out.max_px = std::max(out.max_px, d);
    }
  }
  if (out.points > 0) {
    out.mean_px = sum / out.points;
    out.rms_px = std::sqrt(sum_sq / out.points);
  }
  return out;
}

}  // namespace ctcal
