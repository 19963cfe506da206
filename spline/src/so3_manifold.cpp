#include "ctcal/spline/so3_manifold.h"

#include "ctcal/spline/so3.h"

namespace ctcal {

bool So3LeftManifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  const Eigen::Map<const Eigen::Quaterniond> q(x);
  const Eigen::Map<const Eigen::Vector3d> d(delta);
  Eigen::Map<Eigen::Quaterniond> out(x_plus_delta);
  out = (ExpSO3<double>(d) * q).normalized();
  return true;
}

bool So3LeftManifold::PlusJacobian(const double* x, double* jacobian) const {
  const Eigen::Map<const Eigen::Quaterniond> q(x);
  Eigen::Map<Eigen::Matrix<double, 4, 3, Eigen::RowMajor>> J(jacobian);
  J.topRows<3>() = 0.5 * (q.w() * Eigen::Matrix3d::Identity() - Hat<double>(q.vec()));
  J.row(3) = -0.5 * q.vec().transpose();
  return true;
}

bool So3LeftManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  const Eigen::Map<const Eigen::Quaterniond> qy(y);
  const Eigen::Map<const Eigen::Quaterniond> qx(x);
  Eigen::Map<Eigen::Vector3d> out(y_minus_x);
  out = LogSO3<double>(qy * qx.conjugate());
  return true;
}

bool So3LeftManifold::MinusJacobian(const double* x, double* jacobian) const {
  const Eigen::Map<const Eigen::Quaterniond> q(x);
  Eigen::Map<Eigen::Matrix<double, 3, 4, Eigen::RowMajor>> J(jacobian);
  J.leftCols<3>() = 2.0 * (q.w() * Eigen::Matrix3d::Identity() + Hat<double>(q.vec()));
  J.col(3) = -2.0 * q.vec();
  return true;
}

}  // namespace ctcal
