// Intrinsic model of a gyroscope-only sensor (SPEC section 3, `type: gyro`): the gyroscope part
// of an IMU without rotation and without g-sensitivity,
//   w_m = T_w w_G + b_g + n_g,     w_G = D_w (w_m - b_g),     T_w = D_w^-1,
// with D_w the identity (model none), upper-triangular 6 (upper) or full 9 (full). The sensor's
// frame G is the one its D_w fixes: with `upper`, G's z axis is the triad's z axis and its y axis
// lies in the triad's y-z plane; with `full`, D_w absorbs any rotation, so G is whatever frame
// T_B_S says, and the calibrator must not estimate T_B_S's rotation as well.
#pragma once

#include <Eigen/Core>
#include <array>
#include <vector>

#include "ctcal/sensors/model_names.h"
#include "ctcal/sensors/stored_matrix.h"
#include "ctcal/spline/so3.h"

namespace ctcal {

inline MatrixForm GyroDwForm(GyroModel m) {
  return m == GyroModel::kNone ? MatrixForm::kAbsent
                               : (m == GyroModel::kUpper ? MatrixForm::kUpper : MatrixForm::kFull);
}

// True -> raw, any scalar (Dw may be nullptr for model none). T_w w_G is a solve with D_w.
template <typename T>
Vec3T<T> GyroRawFromTrue(GyroModel m, const T* Dw, const Vec3T<T>& w_G, const Vec3T<T>& b_g) {
  const MatrixForm f = GyroDwForm(m);
  const Mat3T<T> D_w = MatrixFromStored<T>(f, Dw, Mat3T<T>::Identity());
  if (f == MatrixForm::kAbsent)
    return w_G + b_g;
  if (f == MatrixForm::kUpper)
    return Vec3T<T>(D_w.template triangularView<Eigen::Upper>().solve(w_G)) + b_g;
  return D_w.inverse() * w_G + b_g;
}

// Raw -> true, any scalar.
template <typename T>
Vec3T<T> GyroTrueFromRaw(GyroModel m, const T* Dw, const Vec3T<T>& w_m, const Vec3T<T>& b_g) {
  return MatrixFromStored<T>(GyroDwForm(m), Dw, Mat3T<T>::Identity()) * (w_m - b_g);
}

using GyroMatrixJacobian = Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor, 3, 9>;

// Optional outputs, nullptr = not computed; J_out_in is with respect to the function's input.
struct GyroJacobians {
  GyroMatrixJacobian* J_out_Dw = nullptr;  // 3 x 0/6/9, one column per stored entry
  Eigen::Matrix3d* J_out_bg = nullptr;
  Eigen::Matrix3d* J_out_in = nullptr;
};

// Doubles with analytic Jacobians (v = T_w w_G):
//   raw from true:  D_w entry (r,c): -T_w e_r v_c  (dT_w = -T_w dD_w T_w);  b_g: I;  w_G: T_w.
//   true from raw:  D_w entry (r,c): e_r (w_m - b_g)_c;  b_g: -D_w;  w_m: D_w.
Eigen::Vector3d GyroRawFromTrue(GyroModel m, const double* Dw, const Eigen::Vector3d& w_G,
                                const Eigen::Vector3d& b_g, const GyroJacobians& J);
Eigen::Vector3d GyroTrueFromRaw(GyroModel m, const double* Dw, const Eigen::Vector3d& w_m,
                                const Eigen::Vector3d& b_g, const GyroJacobians& J);

// One gyroscope-only sensor's intrinsics: its model and the D_w block Ceres optimises in place.
class GyroIntrinsics {
 public:
  explicit GyroIntrinsics(GyroModel model = GyroModel::kUpper);

  // From the rig file's `Dw` (empty = absent = identity). Throws std::invalid_argument starting
  // with "Dw": given for model none, wrong count, non-finite, singular or reflecting.
  static GyroIntrinsics FromStored(GyroModel model, const std::vector<double>& Dw);
  std::vector<double> ToStored() const;  // empty for model none

  GyroModel model() const { return model_; }
  double* Dw() { return model_ == GyroModel::kNone ? nullptr : Dw_.data(); }
  const double* Dw() const { return model_ == GyroModel::kNone ? nullptr : Dw_.data(); }
  int DwSize() const { return StoredSize(GyroDwForm(model_)); }
  Eigen::Matrix3d D_w() const;
  void SetD_w(const Eigen::Matrix3d& D_w);  // throws like FromStored, or if the pattern differs

  Eigen::Vector3d RawFromTrue(const Eigen::Vector3d& w_G, const Eigen::Vector3d& b_g,
                              const GyroJacobians& J = {}) const {
    return GyroRawFromTrue(model_, Dw(), w_G, b_g, J);
  }
  Eigen::Vector3d TrueFromRaw(const Eigen::Vector3d& w_m, const Eigen::Vector3d& b_g,
                              const GyroJacobians& J = {}) const {
    return GyroTrueFromRaw(model_, Dw(), w_m, b_g, J);
  }

 private:
  GyroModel model_;
  std::array<double, 9> Dw_{};
};

}  // namespace ctcal
