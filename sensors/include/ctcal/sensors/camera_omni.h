// Kalibr's `omni` projection: the unified model of Mei & Rives (2007), with the radtan / none
// distortions of camera_distortion.h on its normalised plane.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <string>

#include "ctcal/sensors/camera_common.h"
#include "ctcal/sensors/camera_distortion.h"
#include "ctcal/sensors/camera_pinhole.h"

namespace ctcal {

// Omni projection, params [xi, fu, fv, pu, pv, distortion_coeffs...] (Kalibr's OmniProjection):
// the point is projected onto the unit sphere, then pinhole-projected from a centre shifted by xi
// along -z:
//   d  = |p|,  m = (x, y) / (z + xi d)
//   md = D(m, k),  uv = (fu mdx + pu, fv mdy + pv)
// Valid for z > -w d with w = xi (xi <= 1) or 1/xi (xi > 1) -- Kalibr's "fov parameter"; for
// xi > 1 the stricter bound keeps the point on the part of the sphere that maps one-to-one --
// and where the distortion is valid. xi >= 0.
// Unprojection: undistort, then lift m back onto the sphere:
//   eta = (xi + sqrt(1 + (1 - xi^2) |m|^2)) / (1 + |m|^2),  ray = (eta m, eta - xi)
// (defined for |m|^2 < 1/(xi^2 - 1) when xi > 1).
template <class Distortion>
struct OmniModel {
  static constexpr int kNumProjectionParams = 5;
  static constexpr int kNumParams = 5 + Distortion::kNumCoeffs;
  static constexpr const char* kCameraModel = "omni";
  static constexpr const char* kDistortionModel = Distortion::kName;

  static std::array<const char*, kNumParams> ParamNames() {
    std::array<const char*, kNumParams> names{"xi", "fu", "fv", "pu", "pv"};
    const auto coeffs = Distortion::CoeffNames();
    for (int i = 0; i < Distortion::kNumCoeffs; ++i)
      names[5 + i] = coeffs[i];
    return names;
  }

  static bool CheckParams(const double* params, std::string* why) {
    if (!camera_internal::CheckFinite(params, kNumParams, why) ||
        !camera_internal::CheckFocal(params[1], params[2], why))
      return false;
    if (params[0] < 0.0) {
      if (why)
        *why = "omni xi must be >= 0, got " + camera_internal::Num(params[0]);
      return false;
    }
    return true;
  }

  static void ParamBounds(double* lower, double* upper) {
    FreeBounds(kNumParams, lower, upper);
    lower[0] = 0.0;  // xi
  }

  template <typename T>
  static bool Project(const T* params, const Eigen::Matrix<T, 3, 1>& p_C,
                      Eigen::Matrix<T, 2, 1>* uv, JacobianPtr<T, 2, 3> J_uv_p = nullptr,
                      JacobianPtr<T, 2, kNumParams> J_uv_params = nullptr) {
    if (!IsFinitePoint(p_C))
      return false;
    using std::sqrt;
    const T& xi = params[0];
    const T& fu = params[1];
    const T& fv = params[2];
    const T& pu = params[3];
    const T& pv = params[4];
    const T d2 = p_C.squaredNorm();
    if (!(d2 > T(0)))
      return false;
    const T d = sqrt(d2);
    const T w = xi > T(1) ? T(1) / xi : xi;
    if (!(p_C.z() > -w * d))
      return false;
    const T den = p_C.z() + xi * d;
    const Eigen::Matrix<T, 2, 1> m(p_C.x() / den, p_C.y() / den);
    Eigen::Matrix<T, 2, 1> md;
    Eigen::Matrix<T, 2, 2> J_md_m;
    Eigen::Matrix<T, 2, Distortion::kNumCoeffs> J_md_k;
    const bool valid =
        Distortion::Distort(params + 5, m, &md, (J_uv_p || J_uv_params) ? &J_md_m : nullptr,
                            (J_uv_params && Distortion::kNumCoeffs > 0) ? &J_md_k : nullptr);
    (*uv)(0) = fu * md(0) + pu;
    (*uv)(1) = fv * md(1) + pv;
    const Eigen::Matrix<T, 2, 1> f(fu, fv);
    if (J_uv_p) {
      // d den / d p = e_z + xi p / d;  d m / d p = ([I2 0] - m (d den / d p)^T) / den.
      Eigen::Matrix<T, 1, 3> J_den_p = (xi / d) * p_C.transpose();
      J_den_p(2) += T(1);
      Eigen::Matrix<T, 2, 3> J_m_p = -m * J_den_p;
      J_m_p(0, 0) += T(1);
      J_m_p(1, 1) += T(1);
      J_m_p /= den;
      *J_uv_p = f.asDiagonal() * (J_md_m * J_m_p);
    }
    if (J_uv_params) {
      J_uv_params->setZero();
      // d m / d xi = -m d / den.
      const Eigen::Matrix<T, 2, 1> J_m_xi = -m * (d / den);
      J_uv_params->col(0) = f.asDiagonal() * (J_md_m * J_m_xi);
      (*J_uv_params)(0, 1) = md(0);
      (*J_uv_params)(1, 2) = md(1);
      (*J_uv_params)(0, 3) = T(1);
      (*J_uv_params)(1, 4) = T(1);
      if constexpr (Distortion::kNumCoeffs > 0) {
        J_uv_params->template rightCols<Distortion::kNumCoeffs>() = f.asDiagonal() * J_md_k;
      }
    }
    return valid;
  }

  static bool Unproject(const double* params, const Eigen::Vector2d& uv, Eigen::Vector3d* ray_C) {
    const double xi = params[0];
    const Eigen::Vector2d md((uv(0) - params[3]) / params[1], (uv(1) - params[4]) / params[2]);
    Eigen::Vector2d m;
    if (!Distortion::Undistort(params + 5, md, &m))
      return false;
    const double r2 = m.squaredNorm();
    const double disc = 1.0 + (1.0 - xi * xi) * r2;
    if (!(disc > 0.0))
      return false;
    const double eta = (xi + std::sqrt(disc)) / (1.0 + r2);
    *ray_C = Eigen::Vector3d(eta * m(0), eta * m(1), eta - xi).normalized();
    return ReprojectsOnto<OmniModel>(params, *ray_C, uv);
  }
};

using OmniRadtanModel = OmniModel<RadTanDistortion>;
using OmniNoneModel = OmniModel<NoDistortion>;

}  // namespace ctcal
