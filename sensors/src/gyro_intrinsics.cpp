#include "ctcal/sensors/gyro_intrinsics.h"

#include <stdexcept>

namespace ctcal {

using Eigen::Matrix3d;
using Eigen::Vector3d;

Vector3d GyroRawFromTrue(GyroModel m, const double* Dw, const Vector3d& w_G, const Vector3d& b_g,
                         const GyroJacobians& J) {
  const MatrixForm f = GyroDwForm(m);
  const Matrix3d D_w = MatrixFromStored<double>(f, Dw, Matrix3d::Identity());
  const Matrix3d T_w = ScaleMatrixInverse(f, D_w);
  const Vector3d v = T_w * w_G;
  if (J.J_out_Dw) {
    J.J_out_Dw->setZero(3, StoredSize(f));
    for (int k = 0; k < StoredSize(f); ++k)
      J.J_out_Dw->col(k) = -T_w.col(StoredRow(f, k)) * v(StoredCol(f, k));
  }
  if (J.J_out_bg)
    J.J_out_bg->setIdentity();
  if (J.J_out_in)
    *J.J_out_in = T_w;
  return v + b_g;
}

Vector3d GyroTrueFromRaw(GyroModel m, const double* Dw, const Vector3d& w_m, const Vector3d& b_g,
                         const GyroJacobians& J) {
  const MatrixForm f = GyroDwForm(m);
  const Matrix3d D_w = MatrixFromStored<double>(f, Dw, Matrix3d::Identity());
  const Vector3d y = w_m - b_g;
  if (J.J_out_Dw) {
    J.J_out_Dw->setZero(3, StoredSize(f));
    for (int k = 0; k < StoredSize(f); ++k)
      (*J.J_out_Dw)(StoredRow(f, k), k) = y(StoredCol(f, k));
  }
  if (J.J_out_bg)
    *J.J_out_bg = -D_w;
  if (J.J_out_in)
    *J.J_out_in = D_w;
  return D_w * y;
}

GyroIntrinsics::GyroIntrinsics(GyroModel model) : model_(model) {
  StoreMatrix(GyroDwForm(model_), Matrix3d::Identity(), Dw_.data());
}

GyroIntrinsics GyroIntrinsics::FromStored(GyroModel model, const std::vector<double>& Dw) {
  GyroIntrinsics g(model);
  if (Dw.empty())
    return g;
  if (model == GyroModel::kNone)
    throw std::invalid_argument("Dw: gyroscope model none has no Dw (use upper or full)");
  g.SetD_w(CheckedMatrixFromStored(GyroDwForm(model), Dw, "Dw"));
  return g;
}

std::vector<double> GyroIntrinsics::ToStored() const {
  return std::vector<double>(Dw_.begin(), Dw_.begin() + DwSize());
}

Matrix3d GyroIntrinsics::D_w() const {
  return MatrixFromStored<double>(GyroDwForm(model_), Dw_.data(), Matrix3d::Identity());
}

void GyroIntrinsics::SetD_w(const Matrix3d& D_w) {
  const MatrixForm f = GyroDwForm(model_);
  if (!IsRepresentable(f, D_w, Matrix3d::Identity())) {
    throw std::invalid_argument(
        "Dw: gyroscope model " + ToString(model_) +
        (f == MatrixForm::kAbsent ? " has no Dw" : " stores it " + DescribeForm(f)) +
        "; the given matrix does not fit");
  }
  if (f == MatrixForm::kAbsent)
    return;
  CheckScaleMatrix(f, D_w, "Dw");
  StoreMatrix(f, D_w, Dw_.data());
}

}  // namespace ctcal
