#include "ctcal/spline/so3_manifold.h"

#include "ctcal/spline/se3.h"

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

namespace {

using RowMajor43 = Eigen::Matrix<double, 4, 3, Eigen::RowMajor>;

RowMajor43 So3RightPlusJacobian(const Eigen::Quaterniond& q) {
  RowMajor43 J;
  J.topRows<3>() = 0.5 * (q.w() * Eigen::Matrix3d::Identity() + Hat<double>(q.vec()));
  J.row(3) = -0.5 * q.vec().transpose();
  return J;
}

Eigen::Matrix<double, 3, 4, Eigen::RowMajor> So3RightMinusJacobian(const Eigen::Quaterniond& q) {
  Eigen::Matrix<double, 3, 4, Eigen::RowMajor> J;
  J.leftCols<3>() = 2.0 * (q.w() * Eigen::Matrix3d::Identity() - Hat<double>(q.vec()));
  J.col(3) = -2.0 * q.vec();
  return J;
}

}  // namespace

bool So3RightManifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  const Eigen::Map<const Eigen::Quaterniond> q(x);
  const Eigen::Map<const Eigen::Vector3d> d(delta);
  Eigen::Map<Eigen::Quaterniond> out(x_plus_delta);
  out = (q * ExpSO3<double>(d)).normalized();
  return true;
}

bool So3RightManifold::PlusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<RowMajor43> J(jacobian);
  J = So3RightPlusJacobian(Eigen::Map<const Eigen::Quaterniond>(x));
  return true;
}

bool So3RightManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  const Eigen::Map<const Eigen::Quaterniond> qy(y);
  const Eigen::Map<const Eigen::Quaterniond> qx(x);
  Eigen::Map<Eigen::Vector3d> out(y_minus_x);
  out = LogSO3<double>(qx.conjugate() * qy);
  return true;
}

bool So3RightManifold::MinusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 3, 4, Eigen::RowMajor>> J(jacobian);
  J = MinusJacobianAt(x);
  return true;
}

Eigen::Matrix<double, 3, 4, Eigen::RowMajor> So3RightManifold::MinusJacobianAt(const double* x) {
  return So3RightMinusJacobian(Eigen::Map<const Eigen::Quaterniond>(x));
}

bool Se3RightManifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  const Eigen::Map<const Eigen::Quaterniond> q(x);
  const Eigen::Map<const Eigen::Vector3d> t(x + 4);
  const Eigen::Map<const Vec6T<double>> xi(delta);
  const PoseT<double> d = ExpSE3<double>(xi);
  Eigen::Map<Eigen::Quaterniond> q_out(x_plus_delta);
  Eigen::Map<Eigen::Vector3d> t_out(x_plus_delta + 4);
  // Rotation through the quaternion (not d.R) so that Plus(x, 0) reproduces x exactly.
  const Eigen::Vector3d t_new = t + q * d.t;
  q_out = (q * ExpSO3<double>(xi.tail<3>())).normalized();
  t_out = t_new;
  return true;
}

bool Se3RightManifold::PlusJacobian(const double* x, double* jacobian) const {
  const Eigen::Map<const Eigen::Quaterniond> q(x);
  Eigen::Map<Eigen::Matrix<double, 7, 6, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.block<4, 3>(0, 3) = So3RightPlusJacobian(q);
  J.block<3, 3>(4, 0) = q.toRotationMatrix();
  return true;
}

bool Se3RightManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  const Eigen::Map<const Eigen::Quaterniond> qy(y);
  const Eigen::Map<const Eigen::Quaterniond> qx(x);
  const Eigen::Map<const Eigen::Vector3d> ty(y + 4);
  const Eigen::Map<const Eigen::Vector3d> tx(x + 4);
  const Eigen::Quaterniond q_xy = qx.conjugate() * qy;
  const Eigen::Vector3d phi = LogSO3<double>(q_xy);
  Eigen::Map<Vec6T<double>> out(y_minus_x);
  out.head<3>() = LeftJacobianInvSO3<double>(phi) * (qx.conjugate() * (ty - tx));
  out.tail<3>() = phi;
  return true;
}

bool Se3RightManifold::MinusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> J(jacobian);
  J = MinusJacobianAt(x);
  return true;
}

Eigen::Matrix<double, 6, 7, Eigen::RowMajor> Se3RightManifold::MinusJacobianAt(const double* x) {
  const Eigen::Map<const Eigen::Quaterniond> q(x);
  Eigen::Matrix<double, 6, 7, Eigen::RowMajor> J;
  J.setZero();
  J.block<3, 3>(0, 4) = q.toRotationMatrix().transpose();
  J.block<3, 4>(3, 0) = So3RightMinusJacobian(q);
  return J;
}

void LiftToAmbient(const ceres::Manifold* manifold, const double* x,
                   const Eigen::Ref<const Eigen::MatrixXd>& J_tangent, double* J_ambient) {
  using RowMajorX = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const Eigen::Index rows = J_tangent.rows();
  if (manifold == nullptr) {
    Eigen::Map<RowMajorX> out(J_ambient, rows, J_tangent.cols());
    out = J_tangent;
    return;
  }
  RowMajorX M(manifold->TangentSize(), manifold->AmbientSize());
  manifold->MinusJacobian(x, M.data());
  Eigen::Map<RowMajorX> out(J_ambient, rows, manifold->AmbientSize());
  out = J_tangent * M;
}

}  // namespace ctcal
