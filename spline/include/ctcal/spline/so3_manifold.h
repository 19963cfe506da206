// Ceres manifolds for rotations and poses stored as Eigen quaternions (coefficients x, y, z, w),
// full rotation angle. Ceres' own quaternion manifolds perturb by half the angle, which would make
// every reported rotation sigma off by a factor of two.
//   So3LeftManifold:  R = Exp(delta) * R_hat, delta in the output frame (SPEC section 7: every
//                     estimated and reported rotation, e.g. R_B_S).
//   So3RightManifold: R = R_hat * Exp(delta), delta in the body frame (spline knots).
//   Se3RightManifold: 7 doubles [q x, y, z, w, t], T = T_hat * Exp([rho; phi]) (se3.h; joint
//                     SE(3) spline knots).
// The spline's analytic Jacobians are with respect to these tangents. Ceres wants Jacobians with
// respect to the ambient parameters; since MinusJacobian(x) * PlusJacobian(x) = I, a tangent
// Jacobian J_t becomes an ambient one as J_t * MinusJacobian(x) (LiftToAmbient below), which
// Ceres maps back to exactly J_t.
#pragma once

#include <ceres/manifold.h>

#include <Eigen/Core>

namespace ctcal {

class So3LeftManifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 4; }
  int TangentSize() const override { return 3; }

  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  // d Plus(x, delta) / d delta at delta = 0, 4x3 row-major:
  //   rows x,y,z: 0.5 * (w I - [v]x),  row w: -0.5 v^T   (q = (w, v)).
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  // d Minus(y, x) / d y at y = x, 3x4: the pseudo-inverse 2 * [w I + [v]x | -v] of PlusJacobian.
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

class So3RightManifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 4; }
  int TangentSize() const override { return 3; }

  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  // 4x3 row-major: rows x,y,z: 0.5 * (w I + [v]x),  row w: -0.5 v^T.
  bool PlusJacobian(const double* x, double* jacobian) const override;
  // Log(x^-1 * y).
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  // 3x4: 2 * [w I - [v]x | -v].
  bool MinusJacobian(const double* x, double* jacobian) const override;

  static Eigen::Matrix<double, 3, 4, Eigen::RowMajor> MinusJacobianAt(const double* x);
};

class Se3RightManifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 7; }
  int TangentSize() const override { return 6; }

  // (R, t) * Exp([rho; phi]).
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  // 7x6 row-major: quaternion rows = So3RightManifold's on the phi columns, t rows = R on rho.
  bool PlusJacobian(const double* x, double* jacobian) const override;
  // Log(x^-1 * y).
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  // 6x7: rho rows = R^T on t, phi rows = So3RightManifold's on the quaternion.
  bool MinusJacobian(const double* x, double* jacobian) const override;

  static Eigen::Matrix<double, 6, 7, Eigen::RowMajor> MinusJacobianAt(const double* x);
};

// J_ambient (rows x ambient, row-major, Ceres' layout) = J_tangent * MinusJacobian(x) for a block
// with the given manifold; Euclidean blocks (manifold == nullptr) are copied.
void LiftToAmbient(const ceres::Manifold* manifold, const double* x,
                   const Eigen::Ref<const Eigen::MatrixXd>& J_tangent, double* J_ambient);

}  // namespace ctcal
