#include "ctcal/sensors/imu_intrinsics.h"

#include <stdexcept>

namespace ctcal {

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

// Columns of d(M x)/d(stored entries of M) for a matrix block, placed in rows [row0, row0+3):
// entry k at (r, c) contributes  left.col(r) * x(c).
void FillMatrixColumns(MatrixForm f, const Matrix3d& left, const Vector3d& x, int row0,
                       ImuMatrixJacobian* J) {
  J->setZero(6, StoredSize(f));
  for (int k = 0; k < StoredSize(f); ++k)
    J->block<3, 1>(row0, k) = left.col(StoredRow(f, k)) * x(StoredCol(f, k));
}

Matrix3d RotationOf(const ImuModelLayout& L, ImuRotation wanted, const ImuBlocks<double>& p) {
  return imu_detail::RotationOf<double>(L.rotation, wanted, p.q_rotation);
}

}  // namespace

ImuModelLayout ImuModelLayout::Of(ImuModel model, GSensitivity g_sensitivity) {
  ImuModelLayout L;
  L.model = model;
  L.g_sensitivity = g_sensitivity;
  switch (model) {
    case ImuModel::kNone:
      L.Dw = L.Da = MatrixForm::kAbsent;
      L.rotation = ImuRotation::kNone;
      break;
    case ImuModel::kImu1:
      L.Dw = L.Da = MatrixForm::kUpper;
      L.rotation = ImuRotation::kR_I_w;
      break;
    case ImuModel::kImu2:
      L.Dw = L.Da = MatrixForm::kUpper;
      L.rotation = ImuRotation::kR_I_a;
      break;
    case ImuModel::kImu3:
      L.Dw = MatrixForm::kFull;
      L.Da = MatrixForm::kUpper;
      L.rotation = ImuRotation::kNone;
      break;
    case ImuModel::kImu4:
      L.Dw = MatrixForm::kUpper;
      L.Da = MatrixForm::kFull;
      L.rotation = ImuRotation::kNone;
      break;
  }
  L.Tg = g_sensitivity == GSensitivity::kNone
             ? MatrixForm::kAbsent
             : (g_sensitivity == GSensitivity::kUpper ? MatrixForm::kUpper : MatrixForm::kFull);
  return L;
}

void ImuRawFromTrue(const ImuModelLayout& L, const ImuBlocks<double>& p, const Vector3d& w_I,
                    const Vector3d& a_I, const Vector3d& b_g, const Vector3d& b_a, Vector3d* w_m,
                    Vector3d* a_m, const ImuJacobians& J) {
  const Matrix3d R_w_I = RotationOf(L, ImuRotation::kR_I_w, p).transpose();
  const Matrix3d R_a_I = RotationOf(L, ImuRotation::kR_I_a, p).transpose();
  const Matrix3d T_w =
      ScaleMatrixInverse(L.Dw, MatrixFromStored<double>(L.Dw, p.Dw, Matrix3d::Identity()));
  const Matrix3d T_a =
      ScaleMatrixInverse(L.Da, MatrixFromStored<double>(L.Da, p.Da, Matrix3d::Identity()));
  const Matrix3d T_g = MatrixFromStored<double>(L.Tg, p.Tg, Matrix3d::Zero());
  const Vector3d v_w = T_w * (R_w_I * w_I);
  const Vector3d v_a = T_a * (R_a_I * a_I);
  *w_m = v_w + T_g * a_I + b_g;
  *a_m = v_a + b_a;

  if (J.J_out_Dw)
    FillMatrixColumns(L.Dw, -T_w, v_w, 0, J.J_out_Dw);
  if (J.J_out_Da)
    FillMatrixColumns(L.Da, -T_a, v_a, 3, J.J_out_Da);
  if (J.J_out_Tg)
    FillMatrixColumns(L.Tg, Matrix3d::Identity(), a_I, 0, J.J_out_Tg);
  if (J.J_out_rotation) {
    J.J_out_rotation->setZero();
    if (L.rotation == ImuRotation::kR_I_w)
      J.J_out_rotation->topRows<3>() = T_w * R_w_I * Hat<double>(w_I);
    else if (L.rotation == ImuRotation::kR_I_a)
      J.J_out_rotation->bottomRows<3>() = T_a * R_a_I * Hat<double>(a_I);
  }
  if (J.J_out_bg) {
    J.J_out_bg->setZero();
    J.J_out_bg->topRows<3>().setIdentity();
  }
  if (J.J_out_ba) {
    J.J_out_ba->setZero();
    J.J_out_ba->bottomRows<3>().setIdentity();
  }
  if (J.J_out_in) {
    J.J_out_in->setZero();
    J.J_out_in->topLeftCorner<3, 3>() = T_w * R_w_I;
    J.J_out_in->topRightCorner<3, 3>() = T_g;
    J.J_out_in->bottomRightCorner<3, 3>() = T_a * R_a_I;
  }
}

void ImuTrueFromRaw(const ImuModelLayout& L, const ImuBlocks<double>& p, const Vector3d& w_m,
                    const Vector3d& a_m, const Vector3d& b_g, const Vector3d& b_a, Vector3d* w_I,
                    Vector3d* a_I, const ImuJacobians& J) {
  const Matrix3d R_I_w = RotationOf(L, ImuRotation::kR_I_w, p);
  const Matrix3d R_I_a = RotationOf(L, ImuRotation::kR_I_a, p);
  const Matrix3d D_w = MatrixFromStored<double>(L.Dw, p.Dw, Matrix3d::Identity());
  const Matrix3d D_a = MatrixFromStored<double>(L.Da, p.Da, Matrix3d::Identity());
  const Matrix3d T_g = MatrixFromStored<double>(L.Tg, p.Tg, Matrix3d::Zero());
  const Matrix3d G_a = R_I_a * D_a;
  const Matrix3d G_w = R_I_w * D_w;
  const Vector3d y_a = a_m - b_a;
  const Vector3d a = G_a * y_a;
  const Vector3d y_w = w_m - b_g - T_g * a;
  const Vector3d w = G_w * y_w;
  // d w_I / d a_I: the g-sensitivity carries every a_I dependence into w_I.
  const Matrix3d K = -G_w * T_g;

  if (J.J_out_Da) {
    FillMatrixColumns(L.Da, R_I_a, y_a, 3, J.J_out_Da);
    J.J_out_Da->topRows<3>() = K * J.J_out_Da->bottomRows<3>();
  }
  if (J.J_out_Dw)
    FillMatrixColumns(L.Dw, R_I_w, y_w, 0, J.J_out_Dw);
  if (J.J_out_Tg)
    FillMatrixColumns(L.Tg, -G_w, a, 0, J.J_out_Tg);
  if (J.J_out_rotation) {
    J.J_out_rotation->setZero();
    if (L.rotation == ImuRotation::kR_I_w) {
      J.J_out_rotation->topRows<3>() = -Hat<double>(w);
    } else if (L.rotation == ImuRotation::kR_I_a) {
      J.J_out_rotation->bottomRows<3>() = -Hat<double>(a);
      J.J_out_rotation->topRows<3>() = K * J.J_out_rotation->bottomRows<3>();
    }
  }
  if (J.J_out_bg) {
    J.J_out_bg->setZero();
    J.J_out_bg->topRows<3>() = -G_w;
  }
  if (J.J_out_ba) {
    J.J_out_ba->bottomRows<3>() = -G_a;
    J.J_out_ba->topRows<3>() = -K * G_a;
  }
  if (J.J_out_in) {
    J.J_out_in->setZero();
    J.J_out_in->topLeftCorner<3, 3>() = G_w;
    J.J_out_in->topRightCorner<3, 3>() = K * G_a;
    J.J_out_in->bottomRightCorner<3, 3>() = G_a;
  }
  *w_I = w;
  *a_I = a;
}

ImuIntrinsics::ImuIntrinsics(ImuModel model, GSensitivity g_sensitivity)
    : layout_(ImuModelLayout::Of(model, g_sensitivity)) {
  StoreMatrix(layout_.Dw, Matrix3d::Identity(), Dw_.data());
  StoreMatrix(layout_.Da, Matrix3d::Identity(), Da_.data());
}

ImuIntrinsics ImuIntrinsics::FromStored(ImuModel model, GSensitivity g_sensitivity,
                                        const StoredImuIntrinsics& stored) {
  ImuIntrinsics x(model, g_sensitivity);
  const ImuModelLayout& L = x.layout_;
  const std::string model_words = "model " + ToString(model);
  auto absent_error = [&](const std::string& key, const std::string& why) {
    return std::invalid_argument(key + ": " + why + " has no " + key);
  };
  if (!stored.Dw.empty()) {
    if (L.Dw == MatrixForm::kAbsent)
      throw absent_error("Dw", model_words);
    x.SetD_w(CheckedMatrixFromStored(L.Dw, stored.Dw, "Dw"));
  }
  if (!stored.Da.empty()) {
    if (L.Da == MatrixForm::kAbsent)
      throw absent_error("Da", model_words);
    x.SetD_a(CheckedMatrixFromStored(L.Da, stored.Da, "Da"));
  }
  if (!stored.Tg.empty()) {
    if (L.Tg == MatrixForm::kAbsent)
      throw absent_error("Tg", "g_sensitivity none");
    x.SetT_g(CheckedMatrixFromStored(L.Tg, stored.Tg, "Tg"));
  }
  if (stored.rotation) {
    if (!L.HasRotation()) {
      throw std::invalid_argument("R_I_w/R_I_a: " + model_words +
                                  " has no rotation (only imu1 has R_I_w, only imu2 R_I_a)");
    }
    x.SetRotation(*stored.rotation);
  }
  return x;
}

StoredImuIntrinsics ImuIntrinsics::ToStored() const {
  StoredImuIntrinsics s;
  s.Dw = std::vector<double>(Dw_.begin(), Dw_.begin() + DwSize());
  s.Da = std::vector<double>(Da_.begin(), Da_.begin() + DaSize());
  s.Tg = std::vector<double>(Tg_.begin(), Tg_.begin() + TgSize());
  if (layout_.HasRotation())
    s.rotation = Eigen::Map<const Eigen::Quaterniond>(q_.data()).toRotationMatrix();
  return s;
}

ImuBlocks<double> ImuIntrinsics::blocks() const {
  ImuBlocks<double> b;
  b.Dw = layout_.Dw == MatrixForm::kAbsent ? nullptr : Dw_.data();
  b.Da = layout_.Da == MatrixForm::kAbsent ? nullptr : Da_.data();
  b.Tg = layout_.Tg == MatrixForm::kAbsent ? nullptr : Tg_.data();
  b.q_rotation = layout_.HasRotation() ? q_.data() : nullptr;
  return b;
}

Matrix3d ImuIntrinsics::D_w() const {
  return MatrixFromStored<double>(layout_.Dw, Dw_.data(), Matrix3d::Identity());
}
Matrix3d ImuIntrinsics::D_a() const {
  return MatrixFromStored<double>(layout_.Da, Da_.data(), Matrix3d::Identity());
}
Matrix3d ImuIntrinsics::T_g() const {
  return MatrixFromStored<double>(layout_.Tg, Tg_.data(), Matrix3d::Zero());
}
Matrix3d ImuIntrinsics::R_I_w() const {
  return imu_detail::RotationOf<double>(layout_.rotation, ImuRotation::kR_I_w, q_.data());
}
Matrix3d ImuIntrinsics::R_I_a() const {
  return imu_detail::RotationOf<double>(layout_.rotation, ImuRotation::kR_I_a, q_.data());
}

namespace {

void CheckPattern(MatrixForm f, const Matrix3d& M, const Matrix3d& absent, const std::string& key,
                  const ImuModelLayout& L) {
  if (!IsRepresentable(f, M, absent)) {
    const std::string form = f == MatrixForm::kAbsent ? "has none" : "stores it " + DescribeForm(f);
    throw std::invalid_argument(key + ": model " + ToString(L.model) + " with g_sensitivity " +
                                ToString(L.g_sensitivity) + " " + form +
                                "; the given matrix does not fit");
  }
}

}  // namespace

void ImuIntrinsics::SetD_w(const Matrix3d& D_w) {
  CheckPattern(layout_.Dw, D_w, Matrix3d::Identity(), "Dw", layout_);
  if (layout_.Dw == MatrixForm::kAbsent)
    return;
  CheckScaleMatrix(layout_.Dw, D_w, "Dw");
  StoreMatrix(layout_.Dw, D_w, Dw_.data());
}

void ImuIntrinsics::SetD_a(const Matrix3d& D_a) {
  CheckPattern(layout_.Da, D_a, Matrix3d::Identity(), "Da", layout_);
  if (layout_.Da == MatrixForm::kAbsent)
    return;
  CheckScaleMatrix(layout_.Da, D_a, "Da");
  StoreMatrix(layout_.Da, D_a, Da_.data());
}

void ImuIntrinsics::SetT_g(const Matrix3d& T_g) {
  CheckPattern(layout_.Tg, T_g, Matrix3d::Zero(), "Tg", layout_);
  if (!T_g.allFinite())
    throw std::invalid_argument("Tg: has a non-finite entry");
  StoreMatrix(layout_.Tg, T_g, Tg_.data());
}

void ImuIntrinsics::SetRotation(const Matrix3d& R) {
  if (!layout_.HasRotation()) {
    if (R == Matrix3d::Identity())
      return;
    throw std::invalid_argument("R_I_w/R_I_a: model " + ToString(layout_.model) +
                                " has no rotation");
  }
  const Eigen::Quaterniond q = CheckedRotation(R, RotationKey(layout_.model));
  Eigen::Map<Eigen::Quaterniond>(q_.data()) = q;
}

void ImuIntrinsics::RawFromTrue(const Vector3d& w_I, const Vector3d& a_I, const Vector3d& b_g,
                                const Vector3d& b_a, Vector3d* w_m, Vector3d* a_m,
                                const ImuJacobians& J) const {
  ImuRawFromTrue(layout_, blocks(), w_I, a_I, b_g, b_a, w_m, a_m, J);
}

void ImuIntrinsics::TrueFromRaw(const Vector3d& w_m, const Vector3d& a_m, const Vector3d& b_g,
                                const Vector3d& b_a, Vector3d* w_I, Vector3d* a_I,
                                const ImuJacobians& J) const {
  ImuTrueFromRaw(layout_, blocks(), w_m, a_m, b_g, b_a, w_I, a_I, J);
}

}  // namespace ctcal
