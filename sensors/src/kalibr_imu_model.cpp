#include "ctcal/sensors/kalibr_imu_model.h"

#include <Eigen/QR>
#include <cmath>
#include <stdexcept>

namespace ctcal {

using Eigen::Matrix3d;

void RotationUpperFactor(const Matrix3d& X, Matrix3d* Q, Matrix3d* U) {
  const Eigen::HouseholderQR<Matrix3d> qr(X);
  const Matrix3d R = qr.matrixQR().triangularView<Eigen::Upper>();
  const Matrix3d Q0 = qr.householderQ();
  // Householder QR leaves the signs of R's diagonal free; flipping row i of R and column i of Q
  // makes the diagonal positive, which makes the factorisation unique and Q a rotation when
  // det X > 0.
  Eigen::Vector3d s;
  for (int i = 0; i < 3; ++i)
    s(i) = R(i, i) < 0.0 ? -1.0 : 1.0;
  *Q = Q0 * s.asDiagonal();
  *U = s.asDiagonal() * R;
}

void RotationLowerFactor(const Matrix3d& X, Matrix3d* Q, Matrix3d* L) {
  // With P the order-reversing permutation, P X P = Q' U gives X = (P Q' P)(P U P), and P U P is
  // lower-triangular.
  Matrix3d P = Matrix3d::Zero();
  P(0, 2) = P(1, 1) = P(2, 0) = 1.0;
  Matrix3d Qp, U;
  RotationUpperFactor(P * X * P, &Qp, &U);
  *Q = P * Qp * P;
  *L = P * U * P;
}

namespace {

Matrix3d CheckedKalibrRotation(const Matrix3d& C, const std::string& key) {
  return CheckedRotation(C, key).toRotationMatrix();
}

// Zero the strictly lower part of T_g if it is zero to rounding, else the upper form cannot hold
// it.
Matrix3d UpperOrThrow(const Matrix3d& T_g) {
  const double tol = 1e-12 * std::max(1.0, T_g.cwiseAbs().maxCoeff());
  if (std::abs(T_g(1, 0)) > tol || std::abs(T_g(2, 0)) > tol || std::abs(T_g(2, 1)) > tol) {
    throw std::invalid_argument(
        "gyroscopes.A: in our frame I the g-sensitivity A C_gyro_i R_i_I is not upper-triangular; "
        "import with g_sensitivity full");
  }
  return T_g.triangularView<Eigen::Upper>();
}

}  // namespace

KalibrImuImport FromKalibrScaleMisalignment(const KalibrScaleMisalignment& k, ImuModel model,
                                            GSensitivity g_sensitivity) {
  CheckScaleMatrix(MatrixForm::kFull, k.M_gyro, "gyroscopes.M");
  CheckScaleMatrix(MatrixForm::kFull, k.M_accel, "accelerometers.M");
  if (!k.A_gyro.allFinite())
    throw std::invalid_argument("gyroscopes.A: has a non-finite entry");
  const Matrix3d C_gyro_i = CheckedKalibrRotation(k.C_gyro_i, "gyroscopes.C_gyro_i");

  // Raw -> Kalibr's frame i.
  const Matrix3d X_a = k.M_accel.inverse();
  const Matrix3d X_w = C_gyro_i.transpose() * k.M_gyro.inverse();

  KalibrImuImport out{ImuIntrinsics(model, g_sensitivity), Matrix3d::Identity()};
  ImuIntrinsics& x = out.intrinsics;
  Matrix3d R_i_I = Matrix3d::Identity(), Q, U;
  switch (model) {
    case ImuModel::kNone: {
      const double tol = 1e-12;
      if (!X_a.isApprox(Matrix3d::Identity(), tol) || !X_w.isApprox(Matrix3d::Identity(), tol)) {
        throw std::invalid_argument(
            "model none: Kalibr's gyroscopes.M, gyroscopes.C_gyro_i and accelerometers.M are not "
            "the identity; import into imu1..imu4");
      }
      break;
    }
    case ImuModel::kImu1:
      RotationUpperFactor(X_a, &R_i_I, &U);
      x.SetD_a(U);
      RotationUpperFactor(R_i_I.transpose() * X_w, &Q, &U);
      x.SetRotation(Q);
      x.SetD_w(U);
      break;
    case ImuModel::kImu2:
      RotationUpperFactor(X_w, &R_i_I, &U);
      x.SetD_w(U);
      RotationUpperFactor(R_i_I.transpose() * X_a, &Q, &U);
      x.SetRotation(Q);
      x.SetD_a(U);
      break;
    case ImuModel::kImu3:
      RotationUpperFactor(X_a, &R_i_I, &U);
      x.SetD_a(U);
      x.SetD_w(R_i_I.transpose() * X_w);
      break;
    case ImuModel::kImu4:
      RotationUpperFactor(X_w, &R_i_I, &U);
      x.SetD_w(U);
      x.SetD_a(R_i_I.transpose() * X_a);
      break;
  }
  out.R_I_i = R_i_I.transpose();

  const Matrix3d T_g = k.A_gyro * C_gyro_i * R_i_I;
  switch (g_sensitivity) {
    case GSensitivity::kNone:
      if (!k.A_gyro.isZero(0.0)) {
        throw std::invalid_argument(
            "gyroscopes.A: is not zero, so g_sensitivity none cannot hold it; import with "
            "g_sensitivity full");
      }
      break;
    case GSensitivity::kUpper:
      x.SetT_g(UpperOrThrow(T_g));
      break;
    case GSensitivity::kFull:
      x.SetT_g(T_g);
      break;
  }
  return out;
}

KalibrImuImport FromKalibrScaleMisalignment(const Matrix3d& M_gyro, const Matrix3d& A_gyro,
                                            const Matrix3d& C_gyro_i, const Matrix3d& M_accel,
                                            ImuModel model, GSensitivity g_sensitivity) {
  KalibrScaleMisalignment k;
  k.M_gyro = M_gyro;
  k.A_gyro = A_gyro;
  k.C_gyro_i = C_gyro_i;
  k.M_accel = M_accel;
  return FromKalibrScaleMisalignment(k, model, g_sensitivity);
}

KalibrScaleMisalignment ToKalibrScaleMisalignment(const ImuIntrinsics& x, Matrix3d* R_i_I_out) {
  // Raw -> our frame I.
  const Matrix3d X_a = x.R_I_a() * x.D_a();
  const Matrix3d X_w = x.R_I_w() * x.D_w();
  Matrix3d Q, L;
  // Kalibr's frame i makes R_i_I X_a lower-triangular: X_a = R_I_i M_a^-1.
  RotationLowerFactor(X_a, &Q, &L);
  const Matrix3d R_i_I = Q.transpose();
  KalibrScaleMisalignment k;
  k.M_accel = L.triangularView<Eigen::Lower>().solve(Matrix3d::Identity());
  // C_gyro_i^T M_g^-1 = R_i_I X_w.
  RotationLowerFactor(R_i_I * X_w, &Q, &L);
  k.C_gyro_i = Q.transpose();
  k.M_gyro = L.triangularView<Eigen::Lower>().solve(Matrix3d::Identity());
  // T_g a_I = A C_gyro_i a_i with a_i = R_i_I a_I.
  k.A_gyro = x.T_g() * R_i_I.transpose() * k.C_gyro_i.transpose();
  if (R_i_I_out)
    *R_i_I_out = R_i_I;
  return k;
}

}  // namespace ctcal
