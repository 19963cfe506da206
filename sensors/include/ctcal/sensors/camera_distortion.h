// Lens distortions of SPEC section 4 that act on a 2-D point m of the projection's normalised
// plane (m = (x/z, y/z) for the pinhole, the Mei sphere-shifted plane for omni), as Kalibr's
// aslam_cameras applies them: md = D(m, k). The equidistant (Kannala-Brandt) distortion acts on the
// incidence angle instead and lives with its projection in camera_pinhole.h.
//
// Every function is templated on the scalar (double and ceres::Jet) and returns the Jacobians
// through optional out-pointers (nullptr = not computed), named J_out_in.
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>

namespace ctcal {

// distortion_model: none. md = m.
struct NoDistortion {
  static constexpr int kNumCoeffs = 0;
  static constexpr const char* kName = "none";
  static std::array<const char*, 0> CoeffNames() { return {}; }

  template <typename T>
  static bool Distort(const T* /*k*/, const Eigen::Matrix<T, 2, 1>& m, Eigen::Matrix<T, 2, 1>* md,
                      Eigen::Matrix<T, 2, 2>* J_md_m = nullptr,
                      Eigen::Matrix<T, 2, 0>* /*J_md_k*/ = nullptr) {
    *md = m;
    if (J_md_m)
      J_md_m->setIdentity();
    return true;
  }

  static bool Undistort(const double* /*k*/, const Eigen::Vector2d& md, Eigen::Vector2d* m) {
    *m = md;
    return true;
  }
};

// distortion_model: radtan, coefficients [k1, k2, r1, r2] (OpenCV's k1, k2, p1, p2):
//   r2 = mx^2 + my^2,  s = k1 r2 + k2 r2^2
//   mdx = mx (1 + s) + 2 r1 mx my + r2_ (r2 + 2 mx^2)
//   mdy = my (1 + s) + r1 (r2 + 2 my^2) + 2 r2_ mx my
// (r2_ is the coefficient r2). Validity: the map must not fold over, i.e. det(d md / d m) > 0 at
// the point. Where it is <= 0 (far outside the calibrated field of a strongly barrel-distorted
// lens) two different rays land on the same pixel, an observation there cannot be explained and
// the undistortion would not be unique, so the point is rejected. The test is local: a polynomial
// that turns back and rises again is accepted past its fold, which no physical lens produces
// inside its image.
struct RadTanDistortion {
  static constexpr int kNumCoeffs = 4;
  static constexpr const char* kName = "radtan";
  static std::array<const char*, 4> CoeffNames() { return {"k1", "k2", "r1", "r2"}; }

  template <typename T>
  static bool Distort(const T* k, const Eigen::Matrix<T, 2, 1>& m, Eigen::Matrix<T, 2, 1>* md,
                      Eigen::Matrix<T, 2, 2>* J_md_m = nullptr,
                      Eigen::Matrix<T, 2, 4>* J_md_k = nullptr) {
    const T& k1 = k[0];
    const T& k2 = k[1];
    const T& p1 = k[2];
    const T& p2 = k[3];
    const T x = m.x();
    const T y = m.y();
    const T xx = x * x;
    const T yy = y * y;
    const T xy = x * y;
    const T r2 = xx + yy;
    const T s = k1 * r2 + k2 * r2 * r2;
    (*md)(0) = x * (T(1) + s) + T(2) * p1 * xy + p2 * (r2 + T(2) * xx);
    (*md)(1) = y * (T(1) + s) + p1 * (r2 + T(2) * yy) + T(2) * p2 * xy;

    // ds/dr2 = k1 + 2 k2 r2; d r2 / d m = 2 m.
    const T ds = k1 + T(2) * k2 * r2;
    Eigen::Matrix<T, 2, 2> J;
    J(0, 0) = T(1) + s + T(2) * xx * ds + T(2) * p1 * y + T(6) * p2 * x;
    J(0, 1) = T(2) * xy * ds + T(2) * p1 * x + T(2) * p2 * y;
    J(1, 0) = T(2) * xy * ds + T(2) * p1 * x + T(2) * p2 * y;
    J(1, 1) = T(1) + s + T(2) * yy * ds + T(6) * p1 * y + T(2) * p2 * x;
    if (J_md_m)
      *J_md_m = J;
    if (J_md_k) {
      (*J_md_k) << x * r2, x * r2 * r2, T(2) * xy, r2 + T(2) * xx,  //
          y * r2, y * r2 * r2, r2 + T(2) * yy, T(2) * xy;
    }
    return J.determinant() > T(0);
  }

  // Inverts Distort by Newton's method on md - D(m) = 0 (2x2, so Newton = Gauss-Newton), started
  // at m = md. Converged when the residual is below 1e-13 * max(1, |md|) (< 1e-9 px for any
  // focal length below 1e4 px); fails after 50 iterations, on a singular Jacobian or when the
  // solution lies in the folded region.
  static bool Undistort(const double* k, const Eigen::Vector2d& md, Eigen::Vector2d* m) {
    const double tol = 1e-13 * std::max(1.0, md.norm());
    Eigen::Vector2d x = md;
    for (int it = 0; it < 50; ++it) {
      Eigen::Vector2d d;
      Eigen::Matrix2d J;
      Distort(k, x, &d, &J);
      const Eigen::Vector2d e = d - md;
      if (e.norm() <= tol) {
        *m = x;
        return J.determinant() > 0.0;
      }
      const double det = J.determinant();
      if (!(std::abs(det) > 1e-12))
        return false;
      x -= J.inverse() * e;
      if (!x.allFinite())
        return false;
    }
    return false;
  }
};

}  // namespace ctcal
