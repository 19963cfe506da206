// Ceres manifold for a rotation stored as an Eigen quaternion (coefficients x, y, z, w) with the
// left perturbation of SPEC section 7: R = Exp(delta) * R_hat, delta in the output frame, full
// rotation angle. Ceres' own quaternion manifolds perturb by half the angle on the other side,
// which would make every reported rotation sigma off by a factor of two.
#pragma once

#include <ceres/manifold.h>

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

}  // namespace ctcal
