// Kalibr's `ds` projection: the double sphere model of Usenko, Demmel and Cremers (3DV 2018), as
// in basalt's DoubleSphereCamera.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <string>

#include "ctcal/sensors/camera_common.h"
#include "ctcal/sensors/camera_pinhole.h"

namespace ctcal {

// Double sphere, params [xi, alpha, fu, fv, pu, pv]: the point is projected onto a unit sphere,
// then onto a second unit sphere shifted by xi along z, then by a pinhole shifted by
// alpha / (1 - alpha):
//   d1 = |p|,  k = xi d1 + z,  d2 = sqrt(x^2 + y^2 + k^2)
//   den = alpha d2 + (1 - alpha) k,  uv = (fu x / den + pu, fv y / den + pv)
// Valid (paper, eq. 43) for z > -w2 d1 with
//   w1 = alpha / (1 - alpha) (alpha <= 0.5) or (1 - alpha) / alpha (alpha > 0.5),
//   w2 = (w1 + xi) / sqrt(2 w1 xi + xi^2 + 1).
// Parameters: alpha in [0, 1], xi in [-1, 1] (basalt's clamp).
// Unprojection in closed form (paper, eqs. 47-50):
//   m = ((u - pu)/fu, (v - pv)/fv), r2 = |m|^2 (needs r2 <= 1/(2 alpha - 1) for alpha > 0.5)
//   mz = (1 - alpha^2 r2) / (alpha sqrt(1 - (2 alpha - 1) r2) + 1 - alpha)
//   ray = (mz xi + sqrt(mz^2 + (1 - xi^2) r2)) / (mz^2 + r2) (mx, my, mz) - (0, 0, xi).
struct DoubleSphereModel {
  static constexpr int kNumProjectionParams = 6;
  static constexpr int kNumParams = 6;
  static constexpr const char* kCameraModel = "ds";
  static constexpr const char* kDistortionModel = "none";

  static std::array<const char*, kNumParams> ParamNames() {
    return {"xi", "alpha", "fu", "fv", "pu", "pv"};
  }

  static bool CheckParams(const double* params, std::string* why) {
    if (!camera_internal::CheckFinite(params, kNumParams, why) ||
        !camera_internal::CheckFocal(params[2], params[3], why))
      return false;
    if (!(params[0] >= -1.0 && params[0] <= 1.0) || !(params[1] >= 0.0 && params[1] <= 1.0)) {
      if (why)
        *why = "ds needs xi in [-1, 1] and alpha in [0, 1], got xi " +
               camera_internal::Num(params[0]) + ", alpha " + camera_internal::Num(params[1]);
      return false;
    }
    return true;
  }

  static void ParamBounds(double* lower, double* upper) {
    FreeBounds(kNumParams, lower, upper);
    lower[0] = -1.0;  // xi
    upper[0] = 1.0;
    lower[1] = 0.0;  // alpha
    upper[1] = 1.0;
  }

  template <typename T>
  static bool Project(const T* params, const Eigen::Matrix<T, 3, 1>& p_C,
                      Eigen::Matrix<T, 2, 1>* uv, JacobianPtr<T, 2, 3> J_uv_p = nullptr,
                      JacobianPtr<T, 2, kNumParams> J_uv_params = nullptr) {
    if (!IsFinitePoint(p_C))
      return false;
    using std::sqrt;
    const T& xi = params[0];
    const T& alpha = params[1];
    const T& x = p_C.x();
    const T& y = p_C.y();
    const T& z = p_C.z();
    const T d1_sq = p_C.squaredNorm();
    if (!(d1_sq > T(0)))
      return false;
    const T d1 = sqrt(d1_sq);
    const T w1 = alpha > T(0.5) ? (T(1) - alpha) / alpha : alpha / (T(1) - alpha);
    const T w2 = (w1 + xi) / sqrt(T(2) * w1 * xi + xi * xi + T(1));
    if (!(z > -w2 * d1))
      return false;
    const T k = xi * d1 + z;
    const T d2 = sqrt(x * x + y * y + k * k);
    const T den = alpha * d2 + (T(1) - alpha) * k;
    if (!(den > T(0)))
      return false;
    Eigen::Matrix<T, 1, 3> J_den_p = Eigen::Matrix<T, 1, 3>::Zero();
    Eigen::Matrix<T, 1, 2> J_den_xi_alpha = Eigen::Matrix<T, 1, 2>::Zero();
    if (J_uv_p) {
      // d k/d p = xi p/d1 + e_z;  d d2/d p = ((x, y, 0) + k d k/d p) / d2;
      // d den/d p = alpha d d2/d p + (1 - alpha) d k/d p.
      Eigen::Matrix<T, 1, 3> J_k_p = (xi / d1) * p_C.transpose();
      J_k_p(2) += T(1);
      Eigen::Matrix<T, 1, 3> J_d2_p = (k / d2) * J_k_p;
      J_d2_p(0) += x / d2;
      J_d2_p(1) += y / d2;
      J_den_p = alpha * J_d2_p + (T(1) - alpha) * J_k_p;
    }
    if (J_uv_params) {
      // d den/d xi = (alpha k/d2 + 1 - alpha) d1;  d den/d alpha = d2 - k.
      J_den_xi_alpha << (alpha * k / d2 + T(1) - alpha) * d1, d2 - k;
    }
    camera_internal::ProjectOverDenominator(params, p_C, den, J_den_p, J_den_xi_alpha, uv, J_uv_p,
                                            J_uv_params);
    return true;
  }

  static bool Unproject(const double* params, const Eigen::Vector2d& uv, Eigen::Vector3d* ray_C) {
    const double xi = params[0];
    const double alpha = params[1];
    const double mx = (uv(0) - params[4]) / params[2];
    const double my = (uv(1) - params[5]) / params[3];
    const double r2 = mx * mx + my * my;
    const double disc1 = 1.0 - (2.0 * alpha - 1.0) * r2;
    if (!(disc1 >= 0.0))
      return false;
    const double mz = (1.0 - alpha * alpha * r2) / (alpha * std::sqrt(disc1) + 1.0 - alpha);
    const double disc2 = mz * mz + (1.0 - xi * xi) * r2;
    if (!(disc2 >= 0.0))
      return false;
    const double s = (mz * xi + std::sqrt(disc2)) / (mz * mz + r2);
    *ray_C = Eigen::Vector3d(s * mx, s * my, s * mz - xi).normalized();
    return ReprojectsOnto<DoubleSphereModel>(params, *ray_C, uv);
  }
};

}  // namespace ctcal
