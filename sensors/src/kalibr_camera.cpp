#include "ctcal/sensors/kalibr_camera.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <vector>

#include "ctcal/sensors/camera_model.h"
#include "ctcal/sensors/mrcal_lens.h"

namespace ctcal {

namespace {

// mrcal's OpenCV models are fx fy cx cy then OpenCV's k1 k2 p1 p2 [k3 [k4 k5 k6 [s1..s4]]]: the
// first eight are pinhole-radtan's when the rest are zero.
bool IsOpenCvLens(const std::string& lens) {
  return lens == "LENSMODEL_OPENCV4" || lens == "LENSMODEL_OPENCV5" ||
         lens == "LENSMODEL_OPENCV8" || lens == "LENSMODEL_OPENCV12";
}

SensorConfig PinholeRadtan(const SensorConfig& c, const Eigen::Matrix<double, 8, 1>& x) {
  SensorConfig out = c;
  out.camera_model = "pinhole";
  out.distortion_model = "radtan";
  out.intrinsics = {x(0), x(1), x(2), x(3)};
  out.distortion_coeffs = {x(4), x(5), x(6), x(7)};
  return out;
}

}  // namespace

KalibrCamera AsKalibrCamera(const SensorConfig& c) {
  KalibrCamera k;
  k.camera = c;
  if (c.camera_model != "mrcal")
    return k;
  k.lens = c.distortion_model;
  const std::vector<double>& p = c.intrinsics;
  if (c.distortion_model == "LENSMODEL_PINHOLE" && p.size() == 4) {
    k.camera.camera_model = "pinhole";
    k.camera.distortion_model = "none";
    k.camera.distortion_coeffs.clear();
    return k;
  }
  Eigen::Matrix<double, 8, 1> x = Eigen::Matrix<double, 8, 1>::Zero();
  const bool opencv = IsOpenCvLens(c.distortion_model) && p.size() >= 8;
  if (opencv) {
    for (int i = 0; i < 8; ++i)
      x(i) = p[static_cast<std::size_t>(i)];
    if (std::all_of(p.begin() + 8, p.end(), [](double v) { return v == 0.0; })) {
      k.camera = PinholeRadtan(c, x);
      return k;
    }
  }

  // The fit: rays of a grid of pixels through the mrcal lens, then fx fy cx cy k1 k2 p1 p2
  // minimising sum |pi_radtan(ray) - uv|^2 by Gauss-Newton with the radtan model's analytic
  // Jacobian (camera_model.h), from the lens's own OpenCV terms or its core.
  const CameraModel lens = CameraModel::Create(c.camera_model, c.intrinsics, c.distortion_model,
                                               c.distortion_coeffs, {c.width, c.height});
  if (!opencv && lens.mrcal_lens() && lens.mrcal_lens()->HasCore()) {
    for (int i = 0; i < 4; ++i)
      x(i) = p[static_cast<std::size_t>(i)];
  } else if (!opencv) {
    x << c.width, c.width, 0.5 * (c.width - 1), 0.5 * (c.height - 1), 0, 0, 0, 0;
  }
  constexpr int kCells = 40;
  std::vector<Eigen::Vector3d> rays;
  std::vector<Eigen::Vector2d> pixels;
  for (int r = 0; r < kCells; ++r) {
    for (int col = 0; col < kCells; ++col) {
      // Edge to edge of the sensor ([-0.5, size - 0.5]): the worst pixels are in its corners.
      const Eigen::Vector2d uv(col * c.width / (kCells - 1.0) - 0.5,
                               r * c.height / (kCells - 1.0) - 0.5);
      Eigen::Vector3d ray;
      // A pinhole model cannot reach rays at or beyond 90 degrees: those pixels are left out.
      if (lens.Unproject(uv, &ray) && ray.z() > 0.2 * ray.norm()) {
        rays.push_back(ray);
        pixels.push_back(uv);
      }
    }
  }
  if (rays.size() < 20)
    throw std::runtime_error(c.name + ": its mrcal " + c.distortion_model + " lens has only " +
                             std::to_string(rays.size()) +
                             " grid pixels in front of it: no pinhole-radtan camera can stand in");
  const auto residuals = [&](const Eigen::Matrix<double, 8, 1>& xs, Eigen::MatrixXd* J) {
    const CameraModel radtan(CameraModelType::kPinholeRadtan, xs, {c.width, c.height});
    Eigen::VectorXd r(2 * static_cast<Eigen::Index>(rays.size()));
    if (J)
      J->resize(r.size(), 8);
    Eigen::Matrix<double, 2, Eigen::Dynamic> J_params;
    for (std::size_t i = 0; i < rays.size(); ++i) {
      Eigen::Vector2d uv;
      const auto row = 2 * static_cast<Eigen::Index>(i);
      if (!radtan.Project(rays[i], &uv, nullptr, J ? &J_params : nullptr)) {
        r.segment<2>(row).setConstant(1e3);  // outside radtan's domain: a large, flat penalty
        if (J)
          J->middleRows<2>(row).setZero();
        continue;
      }
      r.segment<2>(row) = uv - pixels[i];
      if (J)
        J->middleRows<2>(row) = J_params;
    }
    return r;
  };
  Eigen::MatrixXd J;
  Eigen::VectorXd r = residuals(x, &J);
  double lambda = 1e-6;
  for (int it = 0; it < 100; ++it) {
    const Eigen::MatrixXd H = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * r;
    Eigen::MatrixXd D = H.diagonal().asDiagonal();
    const Eigen::Matrix<double, 8, 1> step = -(H + lambda * D).ldlt().solve(g);
    const Eigen::Matrix<double, 8, 1> trial = x + step;
    Eigen::MatrixXd J_trial;
    const Eigen::VectorXd r_trial = residuals(trial, &J_trial);
    if (r_trial.squaredNorm() < r.squaredNorm()) {
      const bool converged = r.squaredNorm() - r_trial.squaredNorm() < 1e-12 * r.squaredNorm();
      x = trial;
      r = r_trial;
      J = J_trial;
      lambda = std::max(lambda / 10.0, 1e-12);
      if (converged)
        break;
    } else {
      lambda *= 10.0;
      if (lambda > 1e8)
        break;
    }
  }
  k.camera = PinholeRadtan(c, x);
  k.exact = false;
  k.points = static_cast<int>(rays.size());
  double sq = 0.0;
  for (Eigen::Index i = 0; i < r.size() / 2; ++i) {
    const double e = r.segment<2>(2 * i).norm();
    sq += e * e;
    k.max_px = std::max(k.max_px, e);
  }
  k.rms_px = std::sqrt(sq / static_cast<double>(rays.size()));
  return k;
}

std::string KalibrCameraNote(const std::string& file, const KalibrCamera& k) {
  if (k.exact)
    return "";
  char buf[160];
  std::snprintf(buf, sizeof buf, "(fit over %d pixels of the image: RMS %.3f px, max %.3f px)",
                k.points, k.rms_px, k.max_px);
  return file + ": " + k.camera.name + "'s mrcal " + k.lens +
         " written as its nearest pinhole-radtan " + buf;
}

}  // namespace ctcal
