// Pieces the inertial residuals share: where an IMU's intrinsic blocks sit in a residual's block
// list (only the blocks its model has, in the contract's order Dw, Da, Tg, q_rotation), the
// whitening of a raw IMU sample, and a raw inertial sample.
#pragma once

#include <Eigen/Core>
#include <array>
#include <stdexcept>
#include <string>
#include <vector>

#include "ctcal/calibrator/residuals/residual_support.h"
#include "ctcal/sensors/imu_intrinsics.h"
#include "ctcal/sensors/inertial_noise.h"
#include "ctcal/spline/rd_spline.h"

namespace ctcal {

// One raw sample of an IMU (gyroscope rad/s, accelerometer m/s^2) on the sensor's own clock.
struct ImuMeasurement {
  Eigen::Vector3d w_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_m = Eigen::Vector3d::Zero();
};

// Inverse standard deviations of one raw sample's white noise: the noise is additive on the raw
// reading, so r = W (z_m - z_pred) with W = diag(1/sigma_g I3, 1/sigma_a I3) is ~N(0, I_6).
struct ImuWhitening {
  double inv_sigma_gyro = 1.0;
  double inv_sigma_accel = 1.0;

  static ImuWhitening Of(const InertialNoise& noise) {
    return ImuWhitening{1.0 / noise.GyroSampleSigma(), 1.0 / noise.AccelSampleSigma()};
  }
  Eigen::Matrix<double, 6, 1> Diagonal() const {
    Eigen::Matrix<double, 6, 1> d;
    d << Eigen::Vector3d::Constant(inv_sigma_gyro), Eigen::Vector3d::Constant(inv_sigma_accel);
    return d;
  }
};

// What one IMU-sample residual needs besides its parameter blocks.
struct ImuSampleSetup {
  ImuModelLayout layout;    // the sensor's intrinsic model
  ImuMeasurement z;         // the raw sample
  ImuWhitening W;           // its noise
  SegmentClock clock;       // the sample on its trajectory segment
  SegmentClock bias_clock;  // the sample on its bias-spline segment
};

// Indices of an IMU's intrinsic blocks in a residual's block list, -1 where the model has none.
struct ImuIntrinsicSlots {
  int Dw = -1;
  int Da = -1;
  int Tg = -1;
  int q_rotation = -1;
  int count = 0;

  static ImuIntrinsicSlots Of(const ImuModelLayout& L, int first) {
    ImuIntrinsicSlots s;
    int next = first;
    if (L.Dw != MatrixForm::kAbsent)
      s.Dw = next++;
    if (L.Da != MatrixForm::kAbsent)
      s.Da = next++;
    if (L.Tg != MatrixForm::kAbsent)
      s.Tg = next++;
    if (L.HasRotation())
      s.q_rotation = next++;
    s.count = next - first;
    return s;
  }

  template <typename T>
  ImuBlocks<T> Pointers(T const* const* p) const {
    ImuBlocks<T> b;
    b.Dw = Dw >= 0 ? p[Dw] : nullptr;
    b.Da = Da >= 0 ? p[Da] : nullptr;
    b.Tg = Tg >= 0 ? p[Tg] : nullptr;
    b.q_rotation = q_rotation >= 0 ? p[q_rotation] : nullptr;
    return b;
  }

  // Sizes of the present blocks, in order.
  static void AppendSizes(const ImuModelLayout& L, std::vector<int>* sizes) {
    for (const MatrixForm f : {L.Dw, L.Da, L.Tg}) {
      if (f != MatrixForm::kAbsent)
        sizes->push_back(StoredSize(f));
    }
    if (L.HasRotation())
      sizes->push_back(4);
  }

  // The present blocks of `intrinsics`, in order.
  static void AppendBlocks(ImuIntrinsics* intrinsics, std::vector<double*>* blocks) {
    for (double* b :
         {intrinsics->Dw(), intrinsics->Da(), intrinsics->Tg(), intrinsics->q_rotation()}) {
      if (b != nullptr)
        blocks->push_back(b);
    }
  }
};

// The part of an IMU residual after the kinematics: the bias splines and the intrinsic model.
// Given the true inputs [w_I; a_I] at the sample, it predicts the raw sample
//   z_pred = ImuRawFromTrue(L, intrinsics, w_I, a_I, b_g(t), b_a(t)),  r = W (z_m - z_pred),
// with b_g, b_a the gyro / accel bias splines of order Nb (blocks bg_first .., ba_first ..) at the
// sample's stamp on the sensor's own clock (bias_clock: the bias is a property of the sensor, and
// it changes far too slowly for a time offset to matter, so it is not shifted by one).
// Jacobians: bias knot i enters with its spline weight beta_i, d r / d bg_i = -beta_i W [I; 0],
// d r / d ba_i = -beta_i W [0; I]; intrinsic blocks: -W J_out_block (imu_intrinsics.h). The caller
// chains J_r_in = -W J_out_in (6 x 6, with respect to [w_I; a_I]) into its kinematics.
template <int Nb>
struct ImuSensorPart {
  const ImuModelLayout* L;
  const ImuIntrinsicSlots* slots;
  int bg_first;
  int ba_first;
  const SegmentClock* bias_clock;
  const ImuWhitening* W;
  const ImuMeasurement* z;

  template <typename T>
  void Residual(T const* const* p, const Vec3T<T>& w_I, const Vec3T<T>& a_I, T* residuals) const {
    const T u = T(bias_clock->U());
    const T inv_dt = T(bias_clock->inv_dt);
    const Vec3T<T> b_g = RdSpline<3, Nb>::template EvaluateSegment<T>(p + bg_first, u, inv_dt, 0);
    const Vec3T<T> b_a = RdSpline<3, Nb>::template EvaluateSegment<T>(p + ba_first, u, inv_dt, 0);
    Vec3T<T> w_m, a_m;
    ImuRawFromTrue<T>(*L, slots->template Pointers<T>(p), w_I, a_I, b_g, b_a, &w_m, &a_m);
    for (int i = 0; i < 3; ++i) {
      residuals[i] = (T(z->w_m(i)) - w_m(i)) * T(W->inv_sigma_gyro);
      residuals[3 + i] = (T(z->a_m(i)) - a_m(i)) * T(W->inv_sigma_accel);
    }
  }

  // Doubles: the residual, the Jacobians of the bias and intrinsic blocks, and J_r_in.
  void Evaluate(double const* const* p, const Eigen::Vector3d& w_I, const Eigen::Vector3d& a_I,
                double* residuals, double** jacobians, Eigen::Matrix<double, 6, 6>* J_r_in) const {
    using namespace residual_internal;
    std::array<double, Nb> beta;
    const double u = bias_clock->U();
    const Eigen::Vector3d b_g = RdSpline<3, Nb>::template EvaluateSegment<double>(
        p + bg_first, u, bias_clock->inv_dt, 0, &beta);
    const Eigen::Vector3d b_a =
        RdSpline<3, Nb>::template EvaluateSegment<double>(p + ba_first, u, bias_clock->inv_dt, 0);

    Eigen::Matrix<double, 6, 6> J_out_in;
    ImuMatrixJacobian J_out_Dw, J_out_Da, J_out_Tg;
    Eigen::Matrix<double, 6, 3> J_out_rotation;
    ImuJacobians J;
    if (jacobians != nullptr) {
      J.J_out_in = &J_out_in;
      J.J_out_Dw = Wanted(jacobians, slots->Dw) ? &J_out_Dw : nullptr;
      J.J_out_Da = Wanted(jacobians, slots->Da) ? &J_out_Da : nullptr;
      J.J_out_Tg = Wanted(jacobians, slots->Tg) ? &J_out_Tg : nullptr;
      J.J_out_rotation = Wanted(jacobians, slots->q_rotation) ? &J_out_rotation : nullptr;
    }
    Eigen::Vector3d w_m, a_m;
    ImuRawFromTrue(*L, slots->template Pointers<double>(p), w_I, a_I, b_g, b_a, &w_m, &a_m, J);
    Eigen::Map<Eigen::Matrix<double, 6, 1>> r(residuals);
    r.head<3>() = (z->w_m - w_m) * W->inv_sigma_gyro;
    r.tail<3>() = (z->a_m - a_m) * W->inv_sigma_accel;
    if (jacobians == nullptr)
      return;

    const Eigen::Matrix<double, 6, 1> minus_w = -W->Diagonal();
    *J_r_in = minus_w.asDiagonal() * J_out_in;
    for (int i = 0; i < Nb; ++i) {
      if (jacobians[bg_first + i] != nullptr) {
        JacobianMap<6, 3> J_bg(jacobians[bg_first + i]);
        J_bg.setZero();
        J_bg.topRows<3>().diagonal().setConstant(-beta[i] * W->inv_sigma_gyro);
      }
      if (jacobians[ba_first + i] != nullptr) {
        JacobianMap<6, 3> J_ba(jacobians[ba_first + i]);
        J_ba.setZero();
        J_ba.bottomRows<3>().diagonal().setConstant(-beta[i] * W->inv_sigma_accel);
      }
    }
    const auto matrix_block = [&](int slot, const ImuMatrixJacobian& J_out) {
      if (Wanted(jacobians, slot))
        DynamicJacobian<6>(jacobians[slot], J_out.cols()) = minus_w.asDiagonal() * J_out;
    };
    matrix_block(slots->Dw, J_out_Dw);
    matrix_block(slots->Da, J_out_Da);
    matrix_block(slots->Tg, J_out_Tg);
    if (Wanted(jacobians, slots->q_rotation)) {
      LiftLeftRotation<6>(Eigen::Matrix<double, 6, 3>(minus_w.asDiagonal() * J_out_rotation),
                          p[slots->q_rotation], jacobians[slots->q_rotation]);
    }
  }
};

}  // namespace ctcal
