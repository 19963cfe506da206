// SE(3) for the joint cumulative pose spline: Exp/Log, adjoints and the right/left Jacobians,
// templated on the scalar (double and ceres::Jet).
//
// A pose T_X_Y = (R, t) maps p_X = R p_Y + t. Tangent vectors are xi = [rho; phi] (translation part
// first, as Barfoot, "State Estimation for Robotics", and Sophus), with
//   Exp(xi) = (ExpSO3(phi), Jl(phi) rho),
//   Ad(T) = [R, [t]x R; 0, R],  ad(xi) = [[phi]x, [rho]x; 0, [phi]x],
//   Exp(xi + dxi) ~= Exp(xi) Exp(Jr(xi) dxi) ~= Exp(Jl(xi) dxi) Exp(xi),  Jl(xi) = Jr(-xi),
//   Jl(xi) = [Jl(phi), Q(rho, phi); 0, Jl(phi)]   (Q: Barfoot eq. 7.86).
#pragma once

#include "ctcal/spline/so3.h"

namespace ctcal {

template <typename T>
using Vec6T = Eigen::Matrix<T, 6, 1>;
template <typename T>
using Mat6T = Eigen::Matrix<T, 6, 6>;

// Rotation-matrix Exp (Rodrigues), cheaper than going through a quaternion when the matrix is used.
template <typename T>
Mat3T<T> ExpSO3Matrix(const Vec3T<T>& phi) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T theta2 = phi.squaredNorm();
  const Mat3T<T> Phi = Hat(phi);
  if (theta2 < T(kSo3SmallAngle2)) {
    return Mat3T<T>::Identity() + Phi + T(0.5) * Phi * Phi;
  }
  const T theta = sqrt(theta2);
  return Mat3T<T>::Identity() + (sin(theta) / theta) * Phi +
         ((T(1) - cos(theta)) / theta2) * Phi * Phi;
}

template <typename T>
struct PoseT {
  Mat3T<T> R = Mat3T<T>::Identity();
  Vec3T<T> t = Vec3T<T>::Zero();

  PoseT operator*(const PoseT& o) const { return PoseT{R * o.R, R * o.t + t}; }
  PoseT Inverse() const {
    const Mat3T<T> Rt = R.transpose();
    return PoseT{Rt, -(Rt * t)};
  }
};

namespace internal {

// Q(rho, phi) of Barfoot eq. 7.86, the off-diagonal block of the SE(3) left Jacobian. Its scalar
// coefficients cancel catastrophically at small angles, so below theta = 0.1 their Taylor series
// (three terms, truncation < 1e-13 relative) replace the closed forms.
template <typename T>
Mat3T<T> Se3Q(const Vec3T<T>& rho, const Vec3T<T>& phi) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T theta2 = phi.squaredNorm();
  // Q = 1/2 [rho]x + c1 (PR + RP + PRP) + c2 (PPR + RPP - 3 PRP) + c3 (PRPP + PPRP), P = [phi]x,
  // R = [rho]x: c1 = (t - sin t)/t^3, c2 = (t^2 + 2 cos t - 2)/(2 t^4),
  // c3 = (2 t - 3 sin t + t cos t)/(2 t^5).
  T c1, c2, c3;
  if (theta2 < T(1e-2)) {
    const T theta4 = theta2 * theta2;
    c1 = T(1.0 / 6) - theta2 / T(120) + theta4 / T(5040);
    c2 = T(1.0 / 24) - theta2 / T(720) + theta4 / T(40320);
    c3 = T(1.0 / 120) - theta2 / T(2520) + theta4 / T(120960);
  } else {
    const T theta = sqrt(theta2);
    const T s = sin(theta);
    const T c = cos(theta);
    c1 = (theta - s) / (theta2 * theta);
    c2 = (theta2 + T(2) * c - T(2)) / (T(2) * theta2 * theta2);
    c3 = (T(2) * theta - T(3) * s + theta * c) / (T(2) * theta2 * theta2 * theta);
  }
  const Mat3T<T> P = Hat(phi);
  const Mat3T<T> Rh = Hat(rho);
  const Mat3T<T> PR = P * Rh;
  const Mat3T<T> RP = Rh * P;
  const Mat3T<T> PRP = PR * P;
  return T(0.5) * Rh + c1 * (PR + RP + PRP) + c2 * (P * PR + RP * P - T(3) * PRP) +
         c3 * (PRP * P + P * PRP);
}

// [A, B; 0, A]: the shape of SE(3)'s adjoints and Jacobians in the [rho; phi] order.
template <typename T>
Mat6T<T> UpperBlockTriangular(const Mat3T<T>& A, const Mat3T<T>& B) {
  Mat6T<T> M;
  M.template topLeftCorner<3, 3>() = A;
  M.template topRightCorner<3, 3>() = B;
  M.template bottomLeftCorner<3, 3>().setZero();
  M.template bottomRightCorner<3, 3>() = A;
  return M;
}

}  // namespace internal

template <typename T>
PoseT<T> ExpSE3(const Vec6T<T>& xi) {
  const Vec3T<T> rho = xi.template head<3>();
  const Vec3T<T> phi = xi.template tail<3>();
  return PoseT<T>{ExpSO3Matrix<T>(phi), LeftJacobianSO3<T>(phi) * rho};
}

template <typename T>
Vec6T<T> LogSE3(const PoseT<T>& pose) {
  const Eigen::Quaternion<T> q(pose.R);
  const Vec3T<T> phi = LogSO3<T>(q);
  Vec6T<T> xi;
  xi.template head<3>() = LeftJacobianInvSO3<T>(phi) * pose.t;
  xi.template tail<3>() = phi;
  return xi;
}

template <typename T>
Mat6T<T> AdjointSE3(const PoseT<T>& pose) {
  return internal::UpperBlockTriangular<T>(pose.R, Hat<T>(pose.t) * pose.R);
}

// ad(xi) y = [xi, y], the Lie bracket: for SO(3) the cross product.
template <typename T>
Mat6T<T> SmallAdjointSE3(const Vec6T<T>& xi) {
  return internal::UpperBlockTriangular<T>(Hat<T>(xi.template tail<3>()),
                                           Hat<T>(xi.template head<3>()));
}

template <typename T>
Mat6T<T> LeftJacobianSE3(const Vec6T<T>& xi) {
  const Vec3T<T> phi = xi.template tail<3>();
  return internal::UpperBlockTriangular<T>(LeftJacobianSO3<T>(phi),
                                           internal::Se3Q<T>(xi.template head<3>(), phi));
}

template <typename T>
Mat6T<T> LeftJacobianInvSE3(const Vec6T<T>& xi) {
  const Vec3T<T> phi = xi.template tail<3>();
  const Mat3T<T> Jl_inv = LeftJacobianInvSO3<T>(phi);
  return internal::UpperBlockTriangular<T>(
      Jl_inv, -Jl_inv * internal::Se3Q<T>(xi.template head<3>(), phi) * Jl_inv);
}

template <typename T>
Mat6T<T> RightJacobianSE3(const Vec6T<T>& xi) {
  return LeftJacobianSE3<T>(-xi);
}

template <typename T>
Mat6T<T> RightJacobianInvSE3(const Vec6T<T>& xi) {
  return LeftJacobianInvSE3<T>(-xi);
}

}  // namespace ctcal
