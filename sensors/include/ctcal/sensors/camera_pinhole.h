// Kalibr's `pinhole` projection with the radtan / none distortions, and with the equidistant
// (Kannala-Brandt) distortion, which acts on the incidence angle.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>

#include "ctcal/sensors/camera_common.h"
#include "ctcal/sensors/camera_distortion.h"

namespace ctcal {

namespace camera_internal {

inline constexpr double kPi = 3.14159265358979323846;

// A parameter value in an error message, as short as "%g" makes it.
inline std::string Num(double x) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%g", x);
  return buf;
}

// Focal lengths must be positive and finite (shared by every model's CheckParams).
inline bool CheckFocal(double fu, double fv, std::string* why) {
  if (fu > 0.0 && fv > 0.0 && std::isfinite(fu) && std::isfinite(fv))
    return true;
  if (why)
    *why = "focal lengths fu, fv must be positive, got " + Num(fu) + ", " + Num(fv);
  return false;
}

inline bool CheckFinite(const double* params, int n, std::string* why) {
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(params[i])) {
      if (why)
        *why = "parameter " + std::to_string(i) + " is not finite";
      return false;
    }
  }
  return true;
}

// The last step of the models that divide the point by one scalar den(p, a, b) (double sphere,
// EUCM; params [a, b, fu, fv, pu, pv]):
//   m = (x, y) / den,  uv = (fu mx + pu, fv my + pv)
//   d m/d p = ([I2 0] - m d den/d p) / den,  d m/d a = -m d den/d a / den  (likewise b).
// J_den_p and J_den_ab are read only where J_uv_p and J_uv_params are wanted.
template <typename T>
void ProjectOverDenominator(const T* params, const Eigen::Matrix<T, 3, 1>& p_C, const T& den,
                            const Eigen::Matrix<T, 1, 3>& J_den_p,
                            const Eigen::Matrix<T, 1, 2>& J_den_ab, Eigen::Matrix<T, 2, 1>* uv,
                            JacobianPtr<T, 2, 3> J_uv_p, JacobianPtr<T, 2, 6> J_uv_params) {
  const Eigen::Matrix<T, 2, 1> f(params[2], params[3]);
  const Eigen::Matrix<T, 2, 1> m = p_C.template head<2>() / den;
  *uv = f.cwiseProduct(m) + Eigen::Matrix<T, 2, 1>(params[4], params[5]);
  if (J_uv_p) {
    Eigen::Matrix<T, 2, 3> J_m_p = -m * J_den_p;
    J_m_p(0, 0) += T(1);
    J_m_p(1, 1) += T(1);
    *J_uv_p = (f / den).asDiagonal() * J_m_p;
  }
  if (J_uv_params) {
    J_uv_params->setZero();
    J_uv_params->template leftCols<2>() = -(f.cwiseProduct(m) / den) * J_den_ab;
    (*J_uv_params)(0, 2) = m(0);
    (*J_uv_params)(1, 3) = m(1);
    (*J_uv_params)(0, 4) = T(1);
    (*J_uv_params)(1, 5) = T(1);
  }
}

}  // namespace camera_internal

// Pinhole projection, params [fu, fv, pu, pv, distortion_coeffs...] (Kalibr's PinholeProjection):
//   m  = (x/z, y/z)                      normalised image plane
//   md = D(m, k)                          camera_distortion.h
//   uv = (fu mdx + pu, fv mdy + pv)
// Valid for z > 0 and where the distortion is valid (radtan: does not fold over).
// Unprojection: undistort (Newton for radtan), ray = normalise(m, 1).
template <class Distortion>
struct PinholeModel {
  static constexpr int kNumProjectionParams = 4;
  static constexpr int kNumParams = 4 + Distortion::kNumCoeffs;
  static constexpr const char* kCameraModel = "pinhole";
  static constexpr const char* kDistortionModel = Distortion::kName;

  static std::array<const char*, kNumParams> ParamNames() {
    std::array<const char*, kNumParams> names{"fu", "fv", "pu", "pv"};
    const auto coeffs = Distortion::CoeffNames();
    for (int i = 0; i < Distortion::kNumCoeffs; ++i)
      names[4 + i] = coeffs[i];
    return names;
  }

  static bool CheckParams(const double* params, std::string* why) {
    return camera_internal::CheckFinite(params, kNumParams, why) &&
           camera_internal::CheckFocal(params[0], params[1], why);
  }

  static void ParamBounds(double* lower, double* upper) { FreeBounds(kNumParams, lower, upper); }

  template <typename T>
  static bool Project(const T* params, const Eigen::Matrix<T, 3, 1>& p_C,
                      Eigen::Matrix<T, 2, 1>* uv, JacobianPtr<T, 2, 3> J_uv_p = nullptr,
                      JacobianPtr<T, 2, kNumParams> J_uv_params = nullptr) {
    if (!IsFinitePoint(p_C))
      return false;
    const T& fu = params[0];
    const T& fv = params[1];
    const T& pu = params[2];
    const T& pv = params[3];
    const T& z = p_C.z();
    if (!(z > T(0)))
      return false;
    const T z_inv = T(1) / z;
    const Eigen::Matrix<T, 2, 1> m(p_C.x() * z_inv, p_C.y() * z_inv);
    Eigen::Matrix<T, 2, 1> md;
    Eigen::Matrix<T, 2, 2> J_md_m;
    Eigen::Matrix<T, 2, Distortion::kNumCoeffs> J_md_k;
    const bool valid =
        Distortion::Distort(params + 4, m, &md, J_uv_p ? &J_md_m : nullptr,
                            (J_uv_params && Distortion::kNumCoeffs > 0) ? &J_md_k : nullptr);
    (*uv)(0) = fu * md(0) + pu;
    (*uv)(1) = fv * md(1) + pv;
    if (J_uv_p) {
      Eigen::Matrix<T, 2, 3> J_m_p;
      J_m_p << z_inv, T(0), -m(0) * z_inv,  //
          T(0), z_inv, -m(1) * z_inv;
      *J_uv_p = Eigen::Matrix<T, 2, 1>(fu, fv).asDiagonal() * (J_md_m * J_m_p);
    }
    if (J_uv_params) {
      J_uv_params->setZero();
      (*J_uv_params)(0, 0) = md(0);
      (*J_uv_params)(1, 1) = md(1);
      (*J_uv_params)(0, 2) = T(1);
      (*J_uv_params)(1, 3) = T(1);
      if constexpr (Distortion::kNumCoeffs > 0) {
        J_uv_params->template rightCols<Distortion::kNumCoeffs>() =
            Eigen::Matrix<T, 2, 1>(fu, fv).asDiagonal() * J_md_k;
      }
    }
    return valid;
  }

  static bool Unproject(const double* params, const Eigen::Vector2d& uv, Eigen::Vector3d* ray_C) {
    const Eigen::Vector2d md((uv(0) - params[2]) / params[0], (uv(1) - params[3]) / params[1]);
    Eigen::Vector2d m;
    if (!Distortion::Undistort(params + 4, md, &m))
      return false;
    *ray_C = Eigen::Vector3d(m(0), m(1), 1.0).normalized();
    return ReprojectsOnto<PinholeModel>(params, *ray_C, uv);
  }
};

// Kalibr's pinhole + equidistant distortion = Kannala-Brandt with 4 coefficients (basalt's
// KannalaBrandtCamera4), params [fu, fv, pu, pv, k1, k2, k3, k4]:
//   r = sqrt(x^2 + y^2),  theta = atan2(r, z)            incidence angle
//   theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8)
//   md = theta_d / r * (x, y)                             (-> (x, y)/z as r -> 0)
//   uv = (fu mdx + pu, fv mdy + pv)
// For z > 0 this is exactly Kalibr's EquidistantDistortion applied to (x/z, y/z). Kalibr stops at
// z > 0; like basalt we continue to theta < pi (fisheyes beyond 180 degrees), which changes
// nothing for points in front of the camera.
// Valid where theta_d(theta) is increasing, d theta_d / d theta > 0 (otherwise two incidence
// angles share a pixel radius), and not on the optical axis behind the camera (r = 0, z <= 0,
// where the direction (x, y)/r is undefined).
// Unprojection: theta from theta_d = |md| by Newton's method, ray = (sin(theta) md/|md|,
// cos(theta)).
struct PinholeEquidistantModel {
  static constexpr int kNumProjectionParams = 4;
  static constexpr int kNumParams = 8;
  static constexpr const char* kCameraModel = "pinhole";
  static constexpr const char* kDistortionModel = "equidistant";

  static std::array<const char*, kNumParams> ParamNames() {
    return {"fu", "fv", "pu", "pv", "k1", "k2", "k3", "k4"};
  }

  static bool CheckParams(const double* params, std::string* why) {
    return camera_internal::CheckFinite(params, kNumParams, why) &&
           camera_internal::CheckFocal(params[0], params[1], why);
  }

  static void ParamBounds(double* lower, double* upper) { FreeBounds(kNumParams, lower, upper); }

  // theta_d(theta) and its derivative.
  template <typename T>
  static T ThetaD(const T* k, const T& theta, T* dthetad_dtheta) {
    const T t2 = theta * theta;
    const T poly = T(1) + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3])));
    *dthetad_dtheta =
        T(1) + t2 * (T(3) * k[0] + t2 * (T(5) * k[1] + t2 * (T(7) * k[2] + t2 * T(9) * k[3])));
    return theta * poly;
  }

  template <typename T>
  static bool Project(const T* params, const Eigen::Matrix<T, 3, 1>& p_C,
                      Eigen::Matrix<T, 2, 1>* uv, JacobianPtr<T, 2, 3> J_uv_p = nullptr,
                      JacobianPtr<T, 2, kNumParams> J_uv_params = nullptr) {
    if (!IsFinitePoint(p_C))
      return false;
    using std::atan2;
    using std::sqrt;
    const T& fu = params[0];
    const T& fv = params[1];
    const T& pu = params[2];
    const T& pv = params[3];
    const T* k = params + 4;
    const T& x = p_C.x();
    const T& y = p_C.y();
    const T& z = p_C.z();
    const T r2 = x * x + y * y;

    // Within 1e-8 rad of the axis theta_d/r = 1/z up to O(theta^2) = 1e-16: use the limit, which
    // also keeps sqrt(r2) (infinite derivative at 0) out of the Jets.
    if (r2 <= T(1e-16) * z * z) {
      if (!(z > T(0)))
        return false;
      const T z_inv = T(1) / z;
      (*uv)(0) = fu * x * z_inv + pu;
      (*uv)(1) = fv * y * z_inv + pv;
      if (J_uv_p) {
        *J_uv_p << fu * z_inv, T(0), -fu * x * z_inv * z_inv,  //
            T(0), fv * z_inv, -fv * y * z_inv * z_inv;
      }
      if (J_uv_params) {
        J_uv_params->setZero();
        (*J_uv_params)(0, 0) = x * z_inv;
        (*J_uv_params)(1, 1) = y * z_inv;
        (*J_uv_params)(0, 2) = T(1);
        (*J_uv_params)(1, 3) = T(1);
      }
      return true;
    }

    const T r = sqrt(r2);
    const T theta = atan2(r, z);
    T dthetad;
    const T thetad = ThetaD(k, theta, &dthetad);
    const T s = thetad / r;
    const Eigen::Matrix<T, 2, 1> md(s * x, s * y);
    (*uv)(0) = fu * md(0) + pu;
    (*uv)(1) = fv * md(1) + pv;

    if (J_uv_p) {
      // d theta/d(x,y) = z/(d^2 r) (x,y), d theta/dz = -r/d^2 with d^2 = r^2 + z^2;
      // ds/d(x,y) = A (x,y) with A = dthetad z/(d^2 r^2) - thetad/r^3, ds/dz = -dthetad/d^2.
      const T d2 = r2 + z * z;
      const T A = dthetad * z / (d2 * r2) - thetad / (r2 * r);
      const T s_z = -dthetad / d2;
      Eigen::Matrix<T, 2, 3> J_md_p;
      J_md_p << s + A * x * x, A * x * y, x * s_z,  //
          A * x * y, s + A * y * y, y * s_z;
      *J_uv_p = Eigen::Matrix<T, 2, 1>(fu, fv).asDiagonal() * J_md_p;
    }
    if (J_uv_params) {
      J_uv_params->setZero();
      (*J_uv_params)(0, 0) = md(0);
      (*J_uv_params)(1, 1) = md(1);
      (*J_uv_params)(0, 2) = T(1);
      (*J_uv_params)(1, 3) = T(1);
      // d theta_d / d k_i = theta^(2i+3), i = 0..3.
      const T t2 = theta * theta;
      T theta_pow = theta * t2;
      for (int i = 0; i < 4; ++i) {
        (*J_uv_params)(0, 4 + i) = fu * theta_pow * x / r;
        (*J_uv_params)(1, 4 + i) = fv * theta_pow * y / r;
        theta_pow *= t2;
      }
    }
    return dthetad > T(0);
  }

  static bool Unproject(const double* params, const Eigen::Vector2d& uv, Eigen::Vector3d* ray_C) {
    const Eigen::Vector2d md((uv(0) - params[2]) / params[0], (uv(1) - params[3]) / params[1]);
    const double thetad = md.norm();
    if (thetad < 1e-12) {
      *ray_C = Eigen::Vector3d(md(0), md(1), 1.0).normalized();
      return ReprojectsOnto<PinholeEquidistantModel>(params, *ray_C, uv);
    }
    // Newton on theta_d(theta) = |md|, from theta = |md|, kept inside (0, pi).
    const double kPi = camera_internal::kPi;
    double theta = std::min(thetad, kPi - 1e-9);
    bool converged = false;
    for (int it = 0; it < 50 && !converged; ++it) {
      double dthetad;
      const double e = ThetaD(params + 4, theta, &dthetad) - thetad;
      if (std::abs(e) <= 1e-14 * std::max(1.0, thetad)) {
        converged = true;
        break;
      }
      if (!(dthetad > 0.0))
        return false;
      theta = std::clamp(theta - e / dthetad, 0.5 * theta, 0.5 * (theta + kPi));
    }
    if (!converged)
      return false;
    const double sin_over_rd = std::sin(theta) / thetad;
    *ray_C = Eigen::Vector3d(sin_over_rd * md(0), sin_over_rd * md(1), std::cos(theta));
    return ReprojectsOnto<PinholeEquidistantModel>(params, *ray_C, uv);
  }
};

using PinholeRadtanModel = PinholeModel<RadTanDistortion>;
using PinholeNoneModel = PinholeModel<NoDistortion>;

}  // namespace ctcal
