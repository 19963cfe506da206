// SO(3) in the conventions of SPEC section 1 and 7: Hamilton unit quaternions (Eigen's), rotation
// vectors in radians of the full rotation angle. Every function is templated on the scalar so the
// identical maths runs on double and on ceres::Jet (autodiff path of the calibrator).
//
// Jacobian names follow J_out_in. Right and left Jacobians of SO(3):
//   Exp(phi + dphi) ~= Exp(phi) * Exp(Jr(phi) * dphi) ~= Exp(Jl(phi) * dphi) * Exp(phi),
//   Jl(phi) = Jr(-phi).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace ctcal {

template <typename T>
using Vec3T = Eigen::Matrix<T, 3, 1>;
template <typename T>
using Mat3T = Eigen::Matrix<T, 3, 3>;
template <typename T>
using QuatT = Eigen::Quaternion<T>;

// Below this squared angle the closed forms lose precision (and would divide by zero for Jets
// at exactly 0), so Taylor series are used. 1e-10 rad^2 keeps the truncation error < 1e-16.
inline constexpr double kSo3SmallAngle2 = 1e-10;

template <typename T>
Mat3T<T> Hat(const Vec3T<T>& w) {
  Mat3T<T> W;
  W << T(0), -w.z(), w.y(), w.z(), T(0), -w.x(), -w.y(), w.x(), T(0);
  return W;
}

template <typename T>
Vec3T<T> Vee(const Mat3T<T>& W) {
  return Vec3T<T>(W(2, 1), W(0, 2), W(1, 0));
}

// Exp: rotation vector -> unit quaternion.
template <typename T>
QuatT<T> ExpSO3(const Vec3T<T>& phi) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T theta2 = phi.squaredNorm();
  if (theta2 < T(kSo3SmallAngle2)) {
    // cos(t/2) ~= 1 - t^2/8, sin(t/2)/t ~= 1/2 - t^2/48.
    const T k = T(0.5) - theta2 / T(48);
    return QuatT<T>(T(1) - theta2 / T(8), k * phi.x(), k * phi.y(), k * phi.z());
  }
  const T theta = sqrt(theta2);
  const T k = sin(theta / T(2)) / theta;
  return QuatT<T>(cos(theta / T(2)), k * phi.x(), k * phi.y(), k * phi.z());
}

// Log: unit quaternion -> rotation vector with angle in [0, pi].
template <typename T>
Vec3T<T> LogSO3(const QuatT<T>& q_in) {
  using std::atan2;
  using std::sqrt;
  // q and -q are the same rotation; the positive-w representative gives the angle in [0, pi].
  const QuatT<T> q = q_in.w() < T(0) ? QuatT<T>(-q_in.coeffs()) : q_in;
  const Vec3T<T> v = q.vec();
  const T n2 = v.squaredNorm();
  if (n2 < T(kSo3SmallAngle2)) {
    // 2 atan(n/w)/n ~= 2/w (1 - n^2/(3 w^2)).
    const T w2 = q.w() * q.w();
    return (T(2) / q.w() * (T(1) - n2 / (T(3) * w2))) * v;
  }
  const T n = sqrt(n2);
  return (T(2) * atan2(n, q.w()) / n) * v;
}

template <typename T>
Mat3T<T> RightJacobianSO3(const Vec3T<T>& phi) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T theta2 = phi.squaredNorm();
  const Mat3T<T> Phi = Hat(phi);
  if (theta2 < T(kSo3SmallAngle2)) {
    return Mat3T<T>::Identity() - T(0.5) * Phi + (T(1) / T(6)) * Phi * Phi;
  }
  const T theta = sqrt(theta2);
  // (1 - cos t)/t^2 written as 2 (sin(t/2)/t)^2: no cancellation at small angles.
  const T half_sinc = sin(theta / T(2)) / theta;
  const T a = T(2) * half_sinc * half_sinc;
  const T b = (theta - sin(theta)) / (theta2 * theta);
  return Mat3T<T>::Identity() - a * Phi + b * Phi * Phi;
}

template <typename T>
Mat3T<T> RightJacobianInvSO3(const Vec3T<T>& phi) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T theta2 = phi.squaredNorm();
  const Mat3T<T> Phi = Hat(phi);
  if (theta2 < T(kSo3SmallAngle2)) {
    return Mat3T<T>::Identity() + T(0.5) * Phi + (T(1) / T(12)) * Phi * Phi;
  }
  const T theta = sqrt(theta2);
  const T c = T(1) / theta2 - (T(1) + cos(theta)) / (T(2) * theta * sin(theta));
  return Mat3T<T>::Identity() + T(0.5) * Phi + c * Phi * Phi;
}

template <typename T>
Mat3T<T> LeftJacobianSO3(const Vec3T<T>& phi) {
  return RightJacobianSO3<T>(-phi);
}

template <typename T>
Mat3T<T> LeftJacobianInvSO3(const Vec3T<T>& phi) {
  return RightJacobianInvSO3<T>(-phi);
}

// The SPEC section 7 error of an estimate against a reference: Log(R_est * R_ref^T), the left
// perturbation expressed in the rotation's output frame.
template <typename T>
Vec3T<T> RotationError(const QuatT<T>& q_est, const QuatT<T>& q_ref) {
  return LogSO3<T>(q_est * q_ref.conjugate());
}

}  // namespace ctcal
