#include "ctcal/report/lens_fit.h"

#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <cmath>
#include <stdexcept>

#include "ctcal/sensors/camera_model.h"
#include "ctcal/sensors/mrcal_lens.h"

namespace ctcal::report {

namespace {

CameraModel Build(const SensorConfig& s) {
  try {
    return CameraModel::Create(s.camera_model, s.intrinsics, s.distortion_model,
                               s.distortion_coeffs, Eigen::Vector2i(s.width, s.height));
  } catch (const std::exception& e) {
    throw std::invalid_argument("sensors." + s.name + ": " + e.what());
  }
}

std::string SplineName(int nx, int ny, int fov_x_deg) {
  return "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=" + std::to_string(nx) +
         "_Ny=" + std::to_string(ny) + "_fov_x_deg=" + std::to_string(fov_x_deg);
}

}  // namespace

std::string SuggestedSplinedModel(const SensorConfig& s) {
  const CameraModel camera = Build(s);
  // The rays of the image's border pixels; the spline must project all of them inside its knots.
  std::vector<Eigen::Vector3d> rays;
  double max_angle = 0.0;
  const int steps = 40;
  for (int i = 0; i <= steps; ++i) {
    for (const Eigen::Vector2d& uv :
         {Eigen::Vector2d(-0.5 + s.width * i / double(steps), -0.5),
          Eigen::Vector2d(-0.5 + s.width * i / double(steps), s.height - 0.5),
          Eigen::Vector2d(-0.5, -0.5 + s.height * i / double(steps)),
          Eigen::Vector2d(s.width - 0.5, -0.5 + s.height * i / double(steps))}) {
      Eigen::Vector3d ray;
      if (!camera.Unproject(uv, &ray))
        continue;
      rays.push_back(ray);
      max_angle = std::max(max_angle, std::atan2(std::abs(ray.x()), ray.z()));
    }
  }
  const int nx = 16;
  const auto covers = [&](const std::string& name) {
    const auto lens = MrcalLens::FromName(name);
    Eigen::VectorXd p = Eigen::VectorXd::Zero(lens->NumParams());
    p.head<4>() << 1.0, 1.0, 0.0, 0.0;
    Eigen::Vector2d uv;
    for (const Eigen::Vector3d& r : rays)
      if (!lens->Project(p.data(), r, &uv))
        return false;
    return true;
  };
  // The smallest field of view (5 degree steps) and then the fewest rows that cover the image.
  int fov = std::max(10, 5 * static_cast<int>(std::ceil(2.0 * max_angle * 180.0 / M_PI / 5.0)));
  int ny = std::max(5, static_cast<int>(std::lround(nx * double(s.height) / s.width)));
  while (fov < 355 && !covers(SplineName(nx, 60, fov)))
    fov += 5;
  while (ny < 60 && !covers(SplineName(nx, ny, fov)))
    ++ny;
  return SplineName(nx, ny, fov);
}

LensFitDiagnosis DiagnoseLensFit(const SensorConfig& s, const std::vector<CornerResidual>& corners,
                                 int cells_x, int min_corners) {
  LensFitDiagnosis d;
  d.cells_x = std::max(cells_x, 2);
  d.cells_y = std::max(2, static_cast<int>(std::lround(d.cells_x * double(s.height) / s.width)));
  const int K = d.cells_x * d.cells_y;
  std::vector<std::vector<Eigen::Vector2d>> in_cell(static_cast<std::size_t>(K));
  for (const CornerResidual& c : corners) {
    if (c.outlier || !std::isfinite(c.du) || !std::isfinite(c.dv) || s.width <= 0 || s.height <= 0)
      continue;
    const int col = static_cast<int>(std::floor((c.u + 0.5) / s.width * d.cells_x));
    const int row = static_cast<int>(std::floor((c.v + 0.5) / s.height * d.cells_y));
    if (col < 0 || col >= d.cells_x || row < 0 || row >= d.cells_y)
      continue;
    in_cell[static_cast<std::size_t>(row * d.cells_x + col)].emplace_back(c.du, c.dv);
  }
  double within = 0.0;
  for (int k = 0; k < K; ++k) {
    const auto& r = in_cell[static_cast<std::size_t>(k)];
    if (static_cast<int>(r.size()) < std::max(min_corners, 2))
      continue;
    LensFitCell cell;
    cell.row = k / d.cells_x;
    cell.col = k % d.cells_x;
    cell.n = static_cast<int>(r.size());
    for (const Eigen::Vector2d& x : r)
      cell.mean += x / cell.n;
    for (const Eigen::Vector2d& x : r)
      within += (x - cell.mean).squaredNorm();
    d.corners += cell.n;
    d.cells.push_back(cell);
  }
  const int n_cells = static_cast<int>(d.cells.size());
  if (n_cells == 0 || d.corners <= n_cells)
    return d;
  d.noise_px = std::sqrt(within / (2.0 * (d.corners - n_cells)));
  if (!(d.noise_px > 0.0))
    return d;
  double border_sum = 0.0, inner_sum = 0.0;
  int border_n = 0, inner_n = 0;
  for (LensFitCell& cell : d.cells) {
    cell.chi2 = cell.n * cell.mean.squaredNorm() / (d.noise_px * d.noise_px);
    d.chi2 += cell.chi2;
    d.max_mean_px = std::max(d.max_mean_px, cell.mean.norm());
    const bool border =
        cell.row == 0 || cell.col == 0 || cell.row == d.cells_y - 1 || cell.col == d.cells_x - 1;
    (border ? border_sum : inner_sum) += cell.mean.norm();
    ++(border ? border_n : inner_n);
  }
  d.border_mean_px = border_n > 0 ? border_sum / border_n : 0.0;
  d.inner_mean_px = inner_n > 0 ? inner_sum / inner_n : 0.0;
  d.dof = 2 * n_cells;
  d.p_value = boost::math::cdf(
      boost::math::complement(boost::math::chi_squared_distribution<double>(d.dof), d.chi2));
  d.significant = d.p_value < 1e-3 && d.max_mean_px >= 0.1;
  if (d.significant) {
    const bool splined = s.camera_model == "mrcal" &&
                         s.distortion_model.rfind("LENSMODEL_SPLINED_STEREOGRAPHIC", 0) == 0;
    if (splined) {
      d.suggestion = "a denser spline than " + s.distortion_model +
                     " (more Nx, Ny), or check the target's flatness and the detector";
    } else {
      try {
        d.suggestion = "camera_model: mrcal, lensmodel: " + SuggestedSplinedModel(s) +
                       " (start: focal length and centre of this fit, control points 0)";
      } catch (const std::exception&) {
        d.suggestion =
            "camera_model: mrcal with a richer lensmodel (LENSMODEL_OPENCV8 or "
            "LENSMODEL_SPLINED_STEREOGRAPHIC_...)";
      }
    }
  }
  return d;
}

}  // namespace ctcal::report
