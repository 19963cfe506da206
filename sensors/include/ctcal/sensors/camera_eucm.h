// Kalibr's `eucm` projection: the enhanced unified camera model of Khomutenko, Garcia and
// Martinet (RA-L 2016) in the formulation of Usenko et al. (3DV 2018, section 3.3), as in basalt's
// ExtendedUnifiedCamera.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <string>

#include "ctcal/sensors/camera_common.h"
#include "ctcal/sensors/camera_pinhole.h"

namespace ctcal {

// EUCM, params [alpha, beta, fu, fv, pu, pv]: the unified model with the sphere replaced by an
// ellipsoid of revolution (beta):
//   rho = sqrt(beta (x^2 + y^2) + z^2),  den = alpha rho + (1 - alpha) z
//   uv = (fu x / den + pu, fv y / den + pv)
// Valid for z > -w rho with w = alpha / (1 - alpha) (alpha <= 0.5) or (1 - alpha) / alpha
// (alpha > 0.5): for alpha <= 0.5 that is den > 0, for alpha > 0.5 it also keeps the point on the
// part of the ellipsoid that maps one-to-one. Parameters: alpha in [0, 1], beta > 0.
// Unprojection in closed form:
//   m = ((u - pu)/fu, (v - pv)/fv), r2 = |m|^2 (needs r2 < 1/(beta (2 alpha - 1)), alpha > 0.5)
//   mz = (1 - beta alpha^2 r2) / (alpha sqrt(1 - (2 alpha - 1) beta r2) + 1 - alpha)
//   ray = (mx, my, mz).
struct EucmModel {
  static constexpr int kNumProjectionParams = 6;
  static constexpr int kNumParams = 6;
  static constexpr const char* kCameraModel = "eucm";
  static constexpr const char* kDistortionModel = "none";

  static std::array<const char*, kNumParams> ParamNames() {
    return {"alpha", "beta", "fu", "fv", "pu", "pv"};
  }

  static bool CheckParams(const double* params, std::string* why) {
    if (!camera_internal::CheckFinite(params, kNumParams, why) ||
        !camera_internal::CheckFocal(params[2], params[3], why))
      return false;
    if (!(params[0] >= 0.0 && params[0] <= 1.0) || !(params[1] > 0.0)) {
      if (why)
        *why = "eucm needs alpha in [0, 1] and beta > 0, got alpha " +
               camera_internal::Num(params[0]) + ", beta " + camera_internal::Num(params[1]);
      return false;
    }
    return true;
  }

  // beta > 0 strictly; the solver bound keeps it at least 1e-8 (basalt clamps at sqrt(eps)).
  static void ParamBounds(double* lower, double* upper) {
    FreeBounds(kNumParams, lower, upper);
    lower[0] = 0.0;  // alpha
    upper[0] = 1.0;
    lower[1] = 1e-8;  // beta
  }

  template <typename T>
  static bool Project(const T* params, const Eigen::Matrix<T, 3, 1>& p_C,
                      Eigen::Matrix<T, 2, 1>* uv, JacobianPtr<T, 2, 3> J_uv_p = nullptr,
                      JacobianPtr<T, 2, kNumParams> J_uv_params = nullptr) {
    if (!IsFinitePoint(p_C))
      return false;
    using std::sqrt;
    const T& alpha = params[0];
    const T& beta = params[1];
    const T& x = p_C.x();
    const T& y = p_C.y();
    const T& z = p_C.z();
    const T r2 = x * x + y * y;
    const T rho_sq = beta * r2 + z * z;
    if (!(rho_sq > T(0)))
      return false;
    const T rho = sqrt(rho_sq);
    const T w = alpha > T(0.5) ? (T(1) - alpha) / alpha : alpha / (T(1) - alpha);
    if (!(z > -w * rho))
      return false;
    const T den = alpha * rho + (T(1) - alpha) * z;
    if (!(den > T(0)))
      return false;
    Eigen::Matrix<T, 1, 3> J_den_p = Eigen::Matrix<T, 1, 3>::Zero();
    Eigen::Matrix<T, 1, 2> J_den_alpha_beta = Eigen::Matrix<T, 1, 2>::Zero();
    if (J_uv_p) {
      // d rho/d p = (beta x, beta y, z)/rho;  d den/d p = alpha d rho/d p + (1 - alpha) e_z.
      J_den_p << alpha * beta * x / rho, alpha * beta * y / rho, alpha * z / rho + T(1) - alpha;
    }
    if (J_uv_params) {
      // d den/d alpha = rho - z;  d den/d beta = alpha r2 / (2 rho).
      J_den_alpha_beta << rho - z, alpha * r2 / (T(2) * rho);
    }
    camera_internal::ProjectOverDenominator(params, p_C, den, J_den_p, J_den_alpha_beta, uv, J_uv_p,
                                            J_uv_params);
    return true;
  }

  static bool Unproject(const double* params, const Eigen::Vector2d& uv, Eigen::Vector3d* ray_C) {
    const double alpha = params[0];
    const double beta = params[1];
    const double mx = (uv(0) - params[4]) / params[2];
    const double my = (uv(1) - params[5]) / params[3];
    const double r2 = mx * mx + my * my;
    const double disc = 1.0 - (2.0 * alpha - 1.0) * beta * r2;
    if (!(disc >= 0.0))
      return false;
    const double mz = (1.0 - beta * alpha * alpha * r2) / (alpha * std::sqrt(disc) + 1.0 - alpha);
    *ray_C = Eigen::Vector3d(mx, my, mz).normalized();
    return ReprojectsOnto<EucmModel>(params, *ray_C, uv);
  }
};

}  // namespace ctcal
