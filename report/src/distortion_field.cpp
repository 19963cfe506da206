// The distortion field of distortion_field.h: unproject a pixel grid with the camera's model and
// project every ray again with the reference lens.
#include "ctcal/report/distortion_field.h"

#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

#include "ctcal/sensors/camera_model.h"

namespace ctcal::report {
namespace {

// The ideal equidistant lens: r = f theta about the principal point, theta the ray's angle to
// the optical axis (defined up to, not including, 180 deg).
Eigen::Vector2d EquidistantProject(const Eigen::Vector3d& ray, const Eigen::Vector2d& f,
                                   const Eigen::Vector2d& c) {
  const double rxy = std::hypot(ray.x(), ray.y());
  if (rxy < 1e-15)
    return c;
  const double theta = std::atan2(rxy, ray.z());
  return {c.x() + f.x() * theta * ray.x() / rxy, c.y() + f.y() * theta * ray.y() / rxy};
}

}  // namespace

DistortionField ComputeDistortionField(const SensorConfig& s, int nx, int ny, int heat_nx) {
  const Eigen::Vector2i resolution(s.width, s.height);
  const auto create = [&](const std::vector<double>& coeffs) {
    try {
      return CameraModel::Create(s.camera_model, s.intrinsics, s.distortion_model, coeffs,
                                 resolution);
    } catch (const std::exception& e) {
      throw std::invalid_argument("sensors." + s.name + ": " + e.what());
    }
  };
  const CameraModel cam = create(s.distortion_coeffs);
  DistortionField out;
  if (s.width <= 0 || s.height <= 0 || cam.type() == CameraModelType::kPinholeNone)
    return out;

  // The paraxial focal length and principal point: central differences about the optical axis
  // (exact for the pinhole family, the fu / (1 + xi) of omni and double sphere).
  const auto project = [&](const Eigen::Vector3d& p) {
    Eigen::Vector2d uv;
    if (!cam.Project(p, &uv))
      throw std::invalid_argument("sensors." + s.name + ": the optical axis does not project");
    return uv;
  };
  const double h = 1e-6;
  out.principal_point = project({0.0, 0.0, 1.0});
  out.focal = {(project({h, 0.0, 1.0}).x() - project({-h, 0.0, 1.0}).x()) / (2 * h),
               (project({0.0, h, 1.0}).y() - project({0.0, -h, 1.0}).y()) / (2 * h)};

  const bool pinhole_family = s.camera_model == "pinhole";
  std::optional<CameraModel> undistorted;
  if (pinhole_family) {
    undistorted = create(std::vector<double>(s.distortion_coeffs.size(), 0.0));
    out.reference = s.distortion_model == "equidistant"
                        ? "the same lens without k1..k4 (ideal equidistant, r = f theta)"
                        : "the same camera without distortion (ideal pinhole)";
  } else {
    out.reference = "ideal equidistant lens (r = f theta) of the paraxial focal length";
  }
  // The reference pixel of the ray through `uv`, when the model unprojects it consistently.
  const auto reference = [&](const Eigen::Vector2d& uv) -> std::optional<Eigen::Vector2d> {
    Eigen::Vector3d ray;
    Eigen::Vector2d back;
    if (!cam.Unproject(uv, &ray) || !cam.Project(ray, &back) || (back - uv).norm() > 1e-3)
      return std::nullopt;
    if (!pinhole_family)
      return EquidistantProject(ray, out.focal, out.principal_point);
    Eigen::Vector2d ref;
    if (!undistorted->Project(ray, &ref) || !ref.allFinite())
      return std::nullopt;
    return ref;
  };

  const double W = s.width, H = s.height;
  nx = std::max(nx, 1);
  ny = std::max(ny, 1);
  for (int j = 0; j <= ny; ++j) {
    for (int i = 0; i <= nx; ++i) {
      const Eigen::Vector2d uv(-0.5 + W * i / nx, -0.5 + H * j / ny);
      if (const auto ref = reference(uv)) {
        out.reference_uv.push_back(*ref);
        out.model_uv.push_back(uv);
      }
    }
  }
  heat_nx = std::max(heat_nx, 1);
  const int heat_ny = std::max(1, static_cast<int>(std::lround(heat_nx * H / W)));
  out.magnitude.resize(heat_ny, heat_nx);
  for (int r = 0; r < heat_ny; ++r) {
    for (int c = 0; c < heat_nx; ++c) {
      const Eigen::Vector2d uv(-0.5 + W * (c + 0.5) / heat_nx, -0.5 + H * (r + 0.5) / heat_ny);
      const auto ref = reference(uv);
      out.magnitude(r, c) = ref ? (uv - *ref).norm() : std::numeric_limits<double>::quiet_NaN();
      if (ref)
        out.max_magnitude = std::max(out.max_magnitude, out.magnitude(r, c));
    }
  }
  for (std::size_t i = 0; i < out.model_uv.size(); ++i)
    out.max_magnitude = std::max(out.max_magnitude, (out.model_uv[i] - out.reference_uv[i]).norm());
  return out;
}

}  // namespace ctcal::report
