#include "ctcal/sensors/mrcal_lens.h"

#include <cmath>
#include <cstring>
#include <stdexcept>

#include "ctcal/sensors/camera_common.h"

#include "mrcal_api.h"

namespace ctcal {

struct MrcalLens::Impl {
  mrcal_lensmodel_t lens;
  // Splined models: the square of normalised stereographic coordinates u = 2 (x, y) / (|p| + z)
  // on which the spline is defined (inner knots, see Project).
  double u_min[2] = {0, 0};
  double u_max[2] = {0, 0};
};

namespace {

bool IsStereographicFamily(mrcal_lensmodel_type_t t) {
  return t == MRCAL_LENSMODEL_STEREOGRAPHIC || t == MRCAL_LENSMODEL_SPLINED_STEREOGRAPHIC;
}

bool IsPinholeLike(mrcal_lensmodel_type_t t) {
  return t == MRCAL_LENSMODEL_PINHOLE || MRCAL_LENSMODEL_IS_OPENCV(t) ||
         t == MRCAL_LENSMODEL_CAHVOR || t == MRCAL_LENSMODEL_CAHVORE;
}

std::string SupportedNames() {
  std::string out;
  for (const char* const* n = internal::Mrcal().supported_lensmodel_names(); *n; ++n)
    out += (out.empty() ? "" : ", ") + std::string(*n);
  return out;
}

}  // namespace

MrcalLens::MrcalLens(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {
  char buffer[256];
  if (!internal::Mrcal().lensmodel_name(buffer, sizeof(buffer), &impl_->lens))
    throw std::invalid_argument("mrcal cannot name its lens model");
  name_ = buffer;
  num_params_ = internal::Mrcal().lensmodel_num_params(&impl_->lens);
}

MrcalLens::~MrcalLens() = default;

std::shared_ptr<const MrcalLens> MrcalLens::FromName(const std::string& lensmodel) {
  auto impl = std::make_unique<Impl>();
  std::memset(&impl->lens, 0, sizeof(impl->lens));
  if (!internal::Mrcal().lensmodel_from_name(&impl->lens, lensmodel.c_str()) ||
      !mrcal_lensmodel_type_is_valid(impl->lens.type)) {
    if (mrcal_lensmodel_type_is_valid(
            internal::Mrcal().lensmodel_type_from_name(lensmodel.c_str())))
      throw std::invalid_argument("mrcal lens model '" + lensmodel +
                                  "': missing or unreadable configuration (e.g. "
                                  "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=10_fov_x_deg="
                                  "100)");
    throw std::invalid_argument("unknown mrcal lens model '" + lensmodel + "' (expected " +
                                SupportedNames() + ")");
  }
  if (impl->lens.type == MRCAL_LENSMODEL_SPLINED_STEREOGRAPHIC) {
    const auto& c = impl->lens.LENSMODEL_SPLINED_STEREOGRAPHIC__config;
    if ((c.order != 2 && c.order != 3) || c.Nx < c.order + 2 || c.Ny < c.order + 2 ||
        c.fov_x_deg == 0 || c.fov_x_deg >= 360)
      throw std::invalid_argument("mrcal lens model '" + lensmodel +
                                  "': a splined model needs order 2 or 3, Nx and Ny >= order + 2 "
                                  "and 0 < fov_x_deg < 360");
    std::vector<double> ux(c.Nx), uy(c.Ny);
    if (!internal::Mrcal().knots_for_splined_models(ux.data(), uy.data(), &impl->lens))
      throw std::invalid_argument("mrcal lens model '" + lensmodel + "': no spline knots");
    // A segment of an order-k spline blends k+1 control points; mrcal clamps to the edge segment
    // beyond the inner knots and extrapolates its polynomial. Only the span between the second
    // and the second-to-last knot is interpolated on both sides.
    impl->u_min[0] = ux[1];
    impl->u_max[0] = ux[c.Nx - 2];
    impl->u_min[1] = uy[1];
    impl->u_max[1] = uy[c.Ny - 2];
  }
  return std::shared_ptr<const MrcalLens>(new MrcalLens(std::move(impl)));
}

bool MrcalLens::HasGradients() const {
  return internal::Mrcal().lensmodel_metadata(&impl_->lens).has_gradients;
}

bool MrcalLens::IsSplined() const {
  return impl_->lens.type == MRCAL_LENSMODEL_SPLINED_STEREOGRAPHIC;
}

bool MrcalLens::HasCore() const {
  return internal::Mrcal().lensmodel_metadata(&impl_->lens).has_core;
}

std::vector<std::string> MrcalLens::ParamNames() const {
  std::vector<std::string> names;
  if (HasCore())
    names = {"fx", "fy", "cx", "cy"};
  const mrcal_lensmodel_type_t t = impl_->lens.type;
  if (MRCAL_LENSMODEL_IS_OPENCV(t)) {
    for (const char* n : {"k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "s1", "s2", "s3", "s4"})
      names.push_back(n);
  } else if (t == MRCAL_LENSMODEL_CAHVOR || t == MRCAL_LENSMODEL_CAHVORE) {
    for (const char* n : {"alpha", "beta", "r0", "r1", "r2", "e0", "e1", "e2"})
      names.push_back(n);
  } else if (t == MRCAL_LENSMODEL_SPLINED_STEREOGRAPHIC) {
    // mrcal's layout: control point (ix, iy) holds its x and y deltas at 2 (iy Nx + ix) + {0, 1}.
    const auto& c = impl_->lens.LENSMODEL_SPLINED_STEREOGRAPHIC__config;
    for (int iy = 0; iy < c.Ny; ++iy) {
      for (int ix = 0; ix < c.Nx; ++ix) {
        const std::string at = "[" + std::to_string(ix) + "," + std::to_string(iy) + "]";
        names.push_back("x" + at);
        names.push_back("y" + at);
      }
    }
  }
  names.resize(static_cast<std::size_t>(num_params_));
  return names;
}

bool MrcalLens::Project(const double* params, const Eigen::Vector3d& p_C, Eigen::Vector2d* uv,
                        Eigen::Matrix<double, 2, 3>* J_uv_p,
                        Eigen::Matrix<double, 2, Eigen::Dynamic>* J_uv_params) const {
  if (!IsFinitePoint(p_C))
    return false;
  const mrcal_lensmodel_type_t t = impl_->lens.type;
  const double norm = p_C.norm();
  if (IsPinholeLike(t) && !(p_C.z() > 0.0))
    return false;
  if (IsStereographicFamily(t) && !(norm + p_C.z() > 1e-12 * norm))
    return false;
  if (norm == 0.0)
    return false;
  if (t == MRCAL_LENSMODEL_SPLINED_STEREOGRAPHIC) {
    const double s = 2.0 / (norm + p_C.z());
    for (int i = 0; i < 2; ++i) {
      const double u = s * p_C(i);
      if (u < impl_->u_min[i] || u > impl_->u_max[i])
        return false;
    }
  }
  if ((J_uv_p || J_uv_params) && !HasGradients())
    return false;

  mrcal_point3_t p = {{p_C.x(), p_C.y(), p_C.z()}};
  mrcal_point2_t q;
  mrcal_point3_t dq_dp[2];
  if (J_uv_params)
    J_uv_params->resize(2, num_params_);
  // mrcal writes dq/dintrinsics as a dense row-major (2, N) array; Eigen's 2 x N matrix is
  // column-major, so mrcal fills a scratch row-major buffer.
  std::vector<double> dq_dintrinsics(J_uv_params ? 2 * static_cast<std::size_t>(num_params_) : 0);
  if (!internal::Mrcal().project(&q, J_uv_p ? dq_dp : nullptr,
                                 J_uv_params ? dq_dintrinsics.data() : nullptr, &p, 1, &impl_->lens,
                                 params))
    return false;
  *uv = Eigen::Vector2d(q.x, q.y);
  if (!uv->allFinite())
    return false;
  if (J_uv_p) {
    for (int r = 0; r < 2; ++r)
      for (int c = 0; c < 3; ++c)
        (*J_uv_p)(r, c) = dq_dp[r].xyz[c];
    if (!J_uv_p->allFinite())
      return false;
  }
  if (J_uv_params) {
    for (int r = 0; r < 2; ++r)
      for (int c = 0; c < num_params_; ++c)
        (*J_uv_params)(r, c) = dq_dintrinsics[static_cast<std::size_t>(r * num_params_ + c)];
  }
  return true;
}

bool MrcalLens::Unproject(const double* params, const Eigen::Vector2d& uv,
                          Eigen::Vector3d* ray_C) const {
  if (!uv.allFinite() || impl_->lens.type == MRCAL_LENSMODEL_CAHVORE)
    return false;
  mrcal_point2_t q = {{uv.x(), uv.y()}};
  mrcal_point3_t v;
  if (!internal::Mrcal().unproject(&v, &q, 1, &impl_->lens, params))
    return false;
  const Eigen::Vector3d ray(v.x, v.y, v.z);
  if (!ray.allFinite() || ray.norm() == 0.0)
    return false;
  *ray_C = ray.normalized();
  Eigen::Vector2d back;
  return Project(params, *ray_C, &back) && (back - uv).norm() <= kUnprojectionCheckPx;
}

bool MrcalLens::CheckParams(const double* params, std::string* why) const {
  for (int i = 0; i < num_params_; ++i) {
    if (!std::isfinite(params[i])) {
      *why = "parameter " + std::to_string(i) + " is not finite";
      return false;
    }
  }
  if (HasCore() && !(params[0] > 0.0 && params[1] > 0.0)) {
    *why = "focal lengths fx, fy must be > 0";
    return false;
  }
  return true;
}

MrcalLens::Regularization MrcalLens::MakeRegularization(const Eigen::Vector2i& resolution,
                                                        double num_measurements) const {
  Regularization r;
  r.weight = Eigen::VectorXd::Zero(num_params_);
  r.target = Eigen::VectorXd::Zero(num_params_);
  if (!HasCore())
    return r;
  // Each group's expected cost is 0.25 % of the measurements' (num_measurements * 1):
  // n_group * (w * typical)^2 = 0.0025 * num_measurements.
  const double share = 0.005 / 2.0 * num_measurements;
  const int n_distortion = num_params_ - 4;
  if (n_distortion > 0) {
    const double w = std::sqrt(share / (n_distortion * 0.2 * 0.2));
    for (int j = 4; j < num_params_; ++j) {
      const bool rational_denominator = (impl_->lens.type == MRCAL_LENSMODEL_OPENCV8 ||
                                         impl_->lens.type == MRCAL_LENSMODEL_OPENCV12) &&
                                        j >= 4 + 5 && j <= 4 + 7;
      r.weight(j) = rational_denominator ? 5.0 * w : w;
    }
  }
  const double w_c = std::sqrt(share / (2 * 50.0 * 50.0));
  r.weight(2) = r.weight(3) = w_c;
  r.target(2) = 0.5 * (resolution.x() - 1);
  r.target(3) = 0.5 * (resolution.y() - 1);
  return r;
}

}  // namespace ctcal
