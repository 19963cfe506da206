// Intrinsic models of an IMU (SPEC section 3): the measurement model true -> raw and the
// correction raw -> true, templated on the scalar (double, ceres::Jet), plus analytic Jacobians.
//
// Raw readings of a sensor with inertial frame I:
//   w_m = T_w R_w_I w_I + T_g a_I + b_g + n_g,     a_m = T_a R_a_I a_I + b_a + n_a,
// with the calibrated states D_w = T_w^-1, D_a = T_a^-1, T_g and one of R_I_w / R_I_a:
//   w_I = R_I_w D_w (w_m - b_g - T_g a_I),          a_I = R_I_a D_a (a_m - b_a).
//
//   model | D_w      | D_a      | rotation | frame I
//   none  | identity | identity | -        | gyroscope (= accelerometer)
//   imu1  | upper 6  | upper 6  | R_I_w    | accelerometer (D_a upper fixes it)
//   imu2  | upper 6  | upper 6  | R_I_a    | gyroscope (D_w upper fixes it)
//   imu3  | full 9   | upper 6  | -        | accelerometer
//   imu4  | upper 6  | full 9   | -        | gyroscope
// and T_g absent / upper 6 / full 9 by g_sensitivity. Stored forms: stored_matrix.h.
//
// Parameter blocks, exactly as the calibrator hands them to Ceres: D_w, D_a, T_g as their stored
// arrays (tangent = the stored entries themselves), the rotation as a unit quaternion x, y, z, w
// on So3LeftManifold (R = Exp(d) R_hat, d in frame I, full angle; tangent = d).
//
// Evaluations stack the gyroscope and the accelerometer into one 6-vector out = [w; a], so each
// Jacobian has 6 rows: rows 0-2 the angular rate, rows 3-5 the specific force.
// Jacobians are with respect to the tangent of each block. A Ceres CostFunction that wants the
// ambient (4-column) Jacobian of the quaternion uses J_tangent * So3LeftManifold::MinusJacobian(q)
// (LiftToAmbient in spline/so3_manifold.h), which Ceres' PlusJacobian maps back to J_tangent.
//
// The calibrator's inertial residual is r = W (z_m - ImuRawFromTrue(...)) with W = 1/sigma_d of
// the raw white noise (inertial_noise.h): the noise is additive on the raw reading, so the
// residual is whitened exactly there, and its Jacobians are -W times the ones below.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <optional>
#include <vector>

#include "ctcal/sensors/model_names.h"
#include "ctcal/sensors/stored_matrix.h"
#include "ctcal/spline/so3.h"

namespace ctcal {

// Which rotation a model estimates.
enum class ImuRotation { kNone, kR_I_w, kR_I_a };

// The blocks a model has and their forms (the SPEC section 3 table as data).
struct ImuModelLayout {
  ImuModel model = ImuModel::kImu2;
  GSensitivity g_sensitivity = GSensitivity::kNone;
  MatrixForm Dw = MatrixForm::kUpper;
  MatrixForm Da = MatrixForm::kUpper;
  MatrixForm Tg = MatrixForm::kAbsent;
  ImuRotation rotation = ImuRotation::kR_I_a;

  static ImuModelLayout Of(ImuModel model, GSensitivity g_sensitivity);
  bool HasRotation() const { return rotation != ImuRotation::kNone; }
};

// Pointers to the parameter blocks (nullptr for a block the model does not have; the quaternion
// is x, y, z, w and must be of unit norm, as So3LeftManifold keeps it).
template <typename T>
struct ImuBlocks {
  const T* Dw = nullptr;
  const T* Da = nullptr;
  const T* Tg = nullptr;
  const T* q_rotation = nullptr;
};

namespace imu_detail {

template <typename T>
Mat3T<T> RotationOf(ImuRotation which, ImuRotation wanted, const T* q) {
  if (which != wanted)
    return Mat3T<T>::Identity();
  return Eigen::Map<const QuatT<T>>(q).toRotationMatrix();
}

// D^-1 v. An upper-triangular D is inverted by back substitution (no division other than by its
// positive diagonal); a full one by its adjugate, which also runs on Jets.
template <typename T>
Vec3T<T> SolveScale(MatrixForm f, const Mat3T<T>& D, const Vec3T<T>& v) {
  if (f == MatrixForm::kAbsent)
    return v;
  if (f == MatrixForm::kUpper)
    return D.template triangularView<Eigen::Upper>().solve(v);
  return D.inverse() * v;
}

// The model's matrices at the blocks: identity for an absent scale matrix or rotation, zero for
// an absent T_g.
template <typename T>
struct Matrices {
  Matrices(const ImuModelLayout& L, const ImuBlocks<T>& p)
      : R_I_w(RotationOf<T>(L.rotation, ImuRotation::kR_I_w, p.q_rotation)),
        R_I_a(RotationOf<T>(L.rotation, ImuRotation::kR_I_a, p.q_rotation)),
        D_w(MatrixFromStored<T>(L.Dw, p.Dw, Mat3T<T>::Identity())),
        D_a(MatrixFromStored<T>(L.Da, p.Da, Mat3T<T>::Identity())),
        T_g(MatrixFromStored<T>(L.Tg, p.Tg, Mat3T<T>::Zero())) {}

  Mat3T<T> R_I_w, R_I_a, D_w, D_a, T_g;
};

}  // namespace imu_detail

// Measurement model, true -> raw (noise-free), any scalar. Derivation: the sensor's gyroscope
// triad sees the rate in its own frame, R_w_I w_I (R_w_I = R_I_w^T, identity unless imu1), and
// distorts it by T_w = D_w^-1 (scale, non-orthogonality); the proof mass adds T_g a_I; the bias is
// additive. Likewise a_m = T_a R_a_I a_I + b_a. T_w v is computed as a solve with D, never by
// forming an inverse of a triangular D.
template <typename T>
void ImuRawFromTrue(const ImuModelLayout& L, const ImuBlocks<T>& p, const Vec3T<T>& w_I,
                    const Vec3T<T>& a_I, const Vec3T<T>& b_g, const Vec3T<T>& b_a, Vec3T<T>* w_m,
                    Vec3T<T>* a_m) {
  const imu_detail::Matrices<T> M(L, p);
  *w_m = imu_detail::SolveScale<T>(L.Dw, M.D_w, Vec3T<T>(M.R_I_w.transpose() * w_I)) + M.T_g * a_I +
         b_g;
  *a_m = imu_detail::SolveScale<T>(L.Da, M.D_a, Vec3T<T>(M.R_I_a.transpose() * a_I)) + b_a;
}

// Correction, raw -> true, any scalar: the SPEC's state equations read left to right. The
// specific force is corrected first because the gyroscope's g-sensitivity needs it.
template <typename T>
void ImuTrueFromRaw(const ImuModelLayout& L, const ImuBlocks<T>& p, const Vec3T<T>& w_m,
                    const Vec3T<T>& a_m, const Vec3T<T>& b_g, const Vec3T<T>& b_a, Vec3T<T>* w_I,
                    Vec3T<T>* a_I) {
  const imu_detail::Matrices<T> M(L, p);
  *a_I = M.R_I_a * (M.D_a * (a_m - b_a));
  *w_I = M.R_I_w * (M.D_w * (w_m - b_g - M.T_g * *a_I));
}

// Jacobians of a stacked 6-vector out = [w; a] with respect to a matrix block: one column per
// stored entry (0, 6 or 9 columns; fixed maximum size, so no allocation per call).
using ImuMatrixJacobian = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor, 6, 9>;

// Optional outputs; nullptr = not computed. J_out_in is with respect to the function's input
// [w; a] (the true values for ImuRawFromTrue, the raw ones for ImuTrueFromRaw). J_out_rotation is
// zero for a model without rotation.
struct ImuJacobians {
  ImuMatrixJacobian* J_out_Dw = nullptr;
  ImuMatrixJacobian* J_out_Da = nullptr;
  ImuMatrixJacobian* J_out_Tg = nullptr;
  Eigen::Matrix<double, 6, 3>* J_out_rotation = nullptr;
  Eigen::Matrix<double, 6, 3>* J_out_bg = nullptr;
  Eigen::Matrix<double, 6, 3>* J_out_ba = nullptr;
  Eigen::Matrix<double, 6, 6>* J_out_in = nullptr;
};

// The same two functions on doubles, with analytic Jacobians.
//
// ImuRawFromTrue. Let u_w = R_w_I w_I, v_w = T_w u_w (and u_a, v_a likewise).
//   D_w entry (r,c): dT_w = -T_w dD_w T_w, so d w_m = -T_w e_r (v_w)_c.      (D_a the same on a_m)
//   T_g entry (r,c): d w_m = e_r (a_I)_c.
//   rotation, R_I_w = Exp(d) R_hat: R_w_I w_I = R_hat^T Exp(-d) w_I ~ R_w_I (w_I + [w_I]x d), so
//     d w_m / d d = T_w R_w_I [w_I]x;   R_I_a likewise on a_m with a_I.
//   biases: identity;  inputs: d w_m/d w_I = T_w R_w_I, d w_m/d a_I = T_g, d a_m/d a_I = T_a R_a_I.
void ImuRawFromTrue(const ImuModelLayout& L, const ImuBlocks<double>& p, const Eigen::Vector3d& w_I,
                    const Eigen::Vector3d& a_I, const Eigen::Vector3d& b_g,
                    const Eigen::Vector3d& b_a, Eigen::Vector3d* w_m, Eigen::Vector3d* a_m,
                    const ImuJacobians& J);

// ImuTrueFromRaw. Let y_a = a_m - b_a, G_a = R_I_a D_a, y_w = w_m - b_g - T_g a_I, G_w = R_I_w D_w.
//   a_I = G_a y_a:  D_a entry (r,c): R_I_a e_r (y_a)_c;  R_I_a: Exp(d) R_hat z ~ z - [z]x d, so
//     -[a_I]x;  b_a: -G_a;  a_m: G_a.
//   w_I = G_w y_w:  D_w entry (r,c): R_I_w e_r (y_w)_c;  T_g entry (r,c): -G_w e_r (a_I)_c;
//     R_I_w: -[w_I]x;  b_g: -G_w;  w_m: G_w;  and through a_I: -G_w T_g times every a_I row above.
void ImuTrueFromRaw(const ImuModelLayout& L, const ImuBlocks<double>& p, const Eigen::Vector3d& w_m,
                    const Eigen::Vector3d& a_m, const Eigen::Vector3d& b_g,
                    const Eigen::Vector3d& b_a, Eigen::Vector3d* w_I, Eigen::Vector3d* a_I,
                    const ImuJacobians& J);

// The SPEC stored form of the intrinsics, as the rig file has them. An empty vector / no rotation
// means the key was absent: identity D, zero T_g, identity rotation.
struct StoredImuIntrinsics {
  std::vector<double> Dw;
  std::vector<double> Da;
  std::vector<double> Tg;
  std::optional<Eigen::Matrix3d> rotation;  // R_I_w (imu1) or R_I_a (imu2)
};

// The intrinsics of one IMU: its model and the parameter blocks the calibrator optimises in place
// (the block pointers stay valid for the object's lifetime).
class ImuIntrinsics {
 public:
  // The identity intrinsics of a model: D identity, T_g zero, rotation identity.
  explicit ImuIntrinsics(ImuModel model = ImuModel::kImu2,
                         GSensitivity g_sensitivity = GSensitivity::kNone);

  // From the rig file's stored form. Throws std::invalid_argument whose message starts with the
  // offending key (Dw, Da, Tg, R_I_w, R_I_a): a block the model does not have, a wrong count, a
  // non-finite number, a singular or reflecting D, a rotation that is not one.
  static ImuIntrinsics FromStored(ImuModel model, GSensitivity g_sensitivity,
                                  const StoredImuIntrinsics& stored);
  // Every block the model has (absent ones stay empty). Exact for D_w, D_a, T_g; the rotation is
  // the quaternion's matrix.
  StoredImuIntrinsics ToStored() const;

  const ImuModelLayout& layout() const { return layout_; }
  ImuModel model() const { return layout_.model; }
  GSensitivity g_sensitivity() const { return layout_.g_sensitivity; }

  // Ceres parameter blocks; nullptr when the model does not have the block.
  double* Dw() { return layout_.Dw == MatrixForm::kAbsent ? nullptr : Dw_.data(); }
  double* Da() { return layout_.Da == MatrixForm::kAbsent ? nullptr : Da_.data(); }
  double* Tg() { return layout_.Tg == MatrixForm::kAbsent ? nullptr : Tg_.data(); }
  double* q_rotation() { return layout_.HasRotation() ? q_.data() : nullptr; }
  const double* Dw() const { return blocks().Dw; }
  const double* Da() const { return blocks().Da; }
  const double* Tg() const { return blocks().Tg; }
  const double* q_rotation() const { return blocks().q_rotation; }
  int DwSize() const { return StoredSize(layout_.Dw); }
  int DaSize() const { return StoredSize(layout_.Da); }
  int TgSize() const { return StoredSize(layout_.Tg); }
  ImuBlocks<double> blocks() const;

  // The matrices (identity D / rotation and zero T_g where the model has none).
  Eigen::Matrix3d D_w() const;
  Eigen::Matrix3d D_a() const;
  Eigen::Matrix3d T_g() const;
  Eigen::Matrix3d R_I_w() const;
  Eigen::Matrix3d R_I_a() const;

  // Setters check like FromStored and also that the matrix has the model's zero pattern (e.g. an
  // upper form given a non-zero strictly lower entry, or a D for a model without one: throws).
  void SetD_w(const Eigen::Matrix3d& D_w);
  void SetD_a(const Eigen::Matrix3d& D_a);
  void SetT_g(const Eigen::Matrix3d& T_g);
  void SetRotation(const Eigen::Matrix3d& R);  // R_I_w or R_I_a, whichever the model has

  // Double evaluation with optional Jacobians (see the free functions above).
  void RawFromTrue(const Eigen::Vector3d& w_I, const Eigen::Vector3d& a_I,
                   const Eigen::Vector3d& b_g, const Eigen::Vector3d& b_a, Eigen::Vector3d* w_m,
                   Eigen::Vector3d* a_m, const ImuJacobians& J = {}) const;
  void TrueFromRaw(const Eigen::Vector3d& w_m, const Eigen::Vector3d& a_m,
                   const Eigen::Vector3d& b_g, const Eigen::Vector3d& b_a, Eigen::Vector3d* w_I,
                   Eigen::Vector3d* a_I, const ImuJacobians& J = {}) const;

 private:
  ImuModelLayout layout_;
  std::array<double, 9> Dw_{};
  std::array<double, 9> Da_{};
  std::array<double, 9> Tg_{};
  std::array<double, 4> q_{0.0, 0.0, 0.0, 1.0};
};

}  // namespace ctcal
