// The two Lie groups the cumulative spline runs on, behind one small traits interface so that the
// spline recursions and their Jacobians are written once (cumulative_lie_segment.h).
//
// Knot storage (Ceres parameter blocks) and perturbation: RIGHT, X = X_hat * Exp(delta).
//   So3Group: 4 doubles, Eigen quaternion order x, y, z, w; delta in the knot's own (body) frame.
//   Se3Group: 7 doubles, quaternion x, y, z, w then translation; delta = [rho; phi] (se3.h).
// The right perturbation makes d_j = Log(X_{j-1}^-1 X_j) depend on the knots through Jr^-1 and
// Jl^-1 of d_j only, without any knot's adjoint (docs/spline.md); So3RightManifold and
// Se3RightManifold (so3_manifold.h) are the matching Ceres manifolds.
#pragma once

#include "ctcal/spline/se3.h"

namespace ctcal {

template <typename T>
struct So3Group {
  static constexpr int kDof = 3;
  static constexpr int kAmbientSize = 4;
  using Element = Mat3T<T>;
  using Tangent = Vec3T<T>;
  using Matrix = Mat3T<T>;

  static Element FromParameters(const T* x) {
    return Eigen::Map<const QuatT<T>>(x).toRotationMatrix();
  }
  // Log(X_a^-1 X_b) straight from the stored quaternions.
  static Tangent LogBetween(const T* a, const T* b) {
    const Eigen::Map<const QuatT<T>> qa(a);
    const Eigen::Map<const QuatT<T>> qb(b);
    return LogSO3<T>(qa.conjugate() * qb);
  }
  static Element Exp(const Tangent& v) { return ExpSO3Matrix<T>(v); }
  static Element Multiply(const Element& a, const Element& b) { return a * b; }
  static Element Inverse(const Element& a) { return a.transpose(); }
  static Matrix Adjoint(const Element& a) { return a; }
  static Matrix SmallAdjoint(const Tangent& v) { return Hat<T>(v); }
  static Matrix RightJacobian(const Tangent& v) { return RightJacobianSO3<T>(v); }
  static Matrix RightJacobianInv(const Tangent& v) { return RightJacobianInvSO3<T>(v); }
};

template <typename T>
struct Se3Group {
  static constexpr int kDof = 6;
  static constexpr int kAmbientSize = 7;
  using Element = PoseT<T>;
  using Tangent = Vec6T<T>;
  using Matrix = Mat6T<T>;

  static Element FromParameters(const T* x) {
    return Element{Eigen::Map<const QuatT<T>>(x).toRotationMatrix(),
                   Eigen::Map<const Vec3T<T>>(x + 4)};
  }
  static Tangent LogBetween(const T* a, const T* b) {
    const Eigen::Map<const QuatT<T>> qa(a);
    const Eigen::Map<const QuatT<T>> qb(b);
    const Eigen::Map<const Vec3T<T>> ta(a + 4);
    const Eigen::Map<const Vec3T<T>> tb(b + 4);
    const QuatT<T> q_ab = qa.conjugate() * qb;
    const Vec3T<T> phi = LogSO3<T>(q_ab);
    Tangent xi;
    xi.template head<3>() = LeftJacobianInvSO3<T>(phi) * (qa.conjugate() * (tb - ta));
    xi.template tail<3>() = phi;
    return xi;
  }
  static Element Exp(const Tangent& v) { return ExpSE3<T>(v); }
  static Element Multiply(const Element& a, const Element& b) { return a * b; }
  static Element Inverse(const Element& a) { return a.Inverse(); }
  static Matrix Adjoint(const Element& a) { return AdjointSE3<T>(a); }
  static Matrix SmallAdjoint(const Tangent& v) { return SmallAdjointSE3<T>(v); }
  static Matrix RightJacobian(const Tangent& v) { return RightJacobianSE3<T>(v); }
  static Matrix RightJacobianInv(const Tangent& v) { return RightJacobianInvSE3<T>(v); }
};

}  // namespace ctcal
