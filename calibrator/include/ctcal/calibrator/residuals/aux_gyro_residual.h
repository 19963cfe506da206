// Residual of one raw sample of an auxiliary gyroscope-only sensor S, mounted with R_B_S.
//
// Model (SPEC sections 1-3). The sample stamped t_S on the sensor's clock happened at base-clock
// time t = t_S + time_offset; a rigid body has one angular velocity, so no lever arm enters:
//   w_S = R_B_S^T w_B(t),   w_pred = GyroRawFromTrue(model, D_w, w_S, b_g(t_S)),
//   r = (w_m - w_pred) / sigma_g   ~ N(0, I_3)   (sigma_g = InertialNoise::GyroSampleSigma()).
// The bias spline b_g (order Nb) is read at the stamp on the sensor's own clock (see
// ImuSensorPart in inertial_support.h for why the time offset does not shift it).
//
// Jacobians, with J_r_in = -J_out_in / sigma_g = -T_w / sigma_g (w.r.t. w_S) and M = R_B_S^T:
//   knots:        J_r_in M J_w;
//   q_B_S (R_B_S = Exp(d) R_hat):  J_r_in M [w_B]x;
//   time_offset:  J_r_in M alpha_B;
//   bg knot i:    -beta_i I / sigma_g  (beta_i its spline weight);
//   Dw:           -J_out_Dw / sigma_g  (gyro_intrinsics.h).
#pragma once

#include <ceres/ceres.h>

#include <array>
#include <vector>

#include "ctcal/calibrator/residuals/residual_support.h"
#include "ctcal/sensors/gyro_intrinsics.h"
#include "ctcal/spline/rd_spline.h"

namespace ctcal {

struct GyroSampleSetup {
  GyroModel model = GyroModel::kUpper;
  Eigen::Vector3d w_m = Eigen::Vector3d::Zero();  // the raw sample
  double inv_sigma = 1.0;                         // 1 / GyroSampleSigma()
  SegmentClock clock;                             // the sample on its trajectory segment
  SegmentClock bias_clock;                        // the sample on its bias-spline segment
};

template <int N, Se3Representation Rep, int Nb>
class AuxGyroResidual {
 public:
  using Spline = Se3Spline<N, Rep>;
  using Setup = GyroSampleSetup;
  static constexpr int kNumResiduals = 3;
  // Block order of the contract: traj, q_B_S, time_offset, bg (Nb), Dw (if the model has one).
  static constexpr int kNumTrajBlocks = Spline::kNumBlocks;
  static constexpr int kQ_B_S = kNumTrajBlocks;
  static constexpr int kTimeOffset = kQ_B_S + 1;
  static constexpr int kBg = kTimeOffset + 1;
  static constexpr int kDw = kBg + Nb;

  struct Parameters {
    std::vector<double*> traj;
    double* q_B_S = nullptr;
    double* time_offset = nullptr;
    std::vector<double*> bg;
    GyroIntrinsics* intrinsics = nullptr;
  };

  static std::vector<double*> Blocks(const Parameters& p) {
    using residual_internal::CheckCount;
    CheckCount("AuxGyroResidual", "trajectory", p.traj.size(), kNumTrajBlocks);
    CheckCount("AuxGyroResidual", "gyro bias", p.bg.size(), Nb);
    // Reserved up front: no reallocation, and GCC 12's -Warray-bounds false positive on
    // push_back after a copy-construction stays away.
    std::vector<double*> blocks;
    blocks.reserve(kNumTrajBlocks + 2 + Nb + 1);
    blocks.insert(blocks.end(), p.traj.begin(), p.traj.end());
    blocks.insert(blocks.end(), {p.q_B_S, p.time_offset});
    blocks.insert(blocks.end(), p.bg.begin(), p.bg.end());
    if (p.intrinsics->Dw() != nullptr)
      blocks.push_back(p.intrinsics->Dw());
    return blocks;
  }

  static std::vector<int> BlockSizes(GyroModel model) {
    std::vector<int> sizes;
    for (int b = 0; b < kNumTrajBlocks; ++b)
      sizes.push_back(Spline::AmbientSize(b));
    sizes.insert(sizes.end(), {4, 1});
    sizes.insert(sizes.end(), Nb, 3);
    if (GyroDwForm(model) != MatrixForm::kAbsent)
      sizes.push_back(StoredSize(GyroDwForm(model)));
    return sizes;
  }

  // (a) The templated functor (autodiff path).
  struct Functor {
    Setup s;

    template <typename T>
    bool operator()(T const* const* p, T* residuals) const {
      Se3Kinematics<T> kin;
      Spline::template EvaluateSegment<T>(p, s.clock.U(p[kTimeOffset][0]), T(s.clock.inv_dt), 1,
                                          nullptr, &kin);
      const Mat3T<T> R_B_S = Eigen::Map<const QuatT<T>>(p[kQ_B_S]).toRotationMatrix();
      const Vec3T<T> b_g = RdSpline<3, Nb>::template EvaluateSegment<T>(
          p + kBg, T(s.bias_clock.U()), T(s.bias_clock.inv_dt), 0);
      const T* Dw = HasDw() ? p[kDw] : nullptr;
      const Vec3T<T> w_pred =
          GyroRawFromTrue<T>(s.model, Dw, Vec3T<T>(R_B_S.transpose() * kin.w_B), b_g);
      for (int i = 0; i < 3; ++i)
        residuals[i] = (T(s.w_m(i)) - w_pred(i)) * T(s.inv_sigma);
      return true;
    }

    bool HasDw() const { return GyroDwForm(s.model) != MatrixForm::kAbsent; }
  };

  // (b) The analytic cost function.
  class Analytic final : public ceres::CostFunction {
   public:
    explicit Analytic(const Setup& setup) : f_{setup} {
      set_num_residuals(kNumResiduals);
      *mutable_parameter_block_sizes() = BlockSizes(setup.model);
    }

    bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
      return EvaluateSample(f_, p, residuals, jacobians);
    }

    // One sample at the analytic price: this cost function's evaluation, also called per sample by
    // the compressed blocks (inertial_block_residual.h), which keep only the Functor of a sample.
    static bool EvaluateSample(const Functor& f, double const* const* p, double* residuals,
                               double** jacobians) {
      using namespace residual_internal;
      using Block = typename Spline::template Jacobians<double>::Block;
      const Setup& s = f.s;
      const bool want_traj = AnyWanted(jacobians, 0, kNumTrajBlocks);
      const bool want_time = Wanted(jacobians, kTimeOffset);
      Se3Kinematics<double> kin;
      Block J_w_knots;
      typename Spline::template Jacobians<double> J_kin;
      J_kin.J_w_knots = &J_w_knots;
      Spline::template EvaluateSegment<double>(p, s.clock.U(p[kTimeOffset][0]), s.clock.inv_dt,
                                               want_time ? 2 : 1, nullptr, &kin,
                                               want_traj ? &J_kin : nullptr);
      const Eigen::Matrix3d M =
          Eigen::Map<const Eigen::Quaterniond>(p[kQ_B_S]).toRotationMatrix().transpose();
      std::array<double, Nb> beta;
      const Eigen::Vector3d b_g = RdSpline<3, Nb>::template EvaluateSegment<double>(
          p + kBg, s.bias_clock.U(), s.bias_clock.inv_dt, 0, &beta);

      const int kDwSlot = f.HasDw() ? kDw : -1;
      GyroMatrixJacobian J_out_Dw;
      Eigen::Matrix3d J_out_in;
      GyroJacobians J;
      if (jacobians != nullptr) {
        J.J_out_in = &J_out_in;
        J.J_out_Dw = Wanted(jacobians, kDwSlot) ? &J_out_Dw : nullptr;
      }
      const double* Dw = f.HasDw() ? p[kDw] : nullptr;
      const Eigen::Vector3d w_pred = GyroRawFromTrue(s.model, Dw, M * kin.w_B, b_g, J);
      Eigen::Map<Eigen::Vector3d> r(residuals);
      r = (s.w_m - w_pred) * s.inv_sigma;
      if (jacobians == nullptr)
        return true;

      const Eigen::Matrix3d J_r_wB = -s.inv_sigma * J_out_in * M;
      if (want_traj) {
        const Eigen::Matrix<double, 3, 6 * N> J_r_knots = J_r_wB * J_w_knots;
        LiftTrajectoryJacobian<N, Rep, 3>(J_r_knots, p, jacobians);
      }
      if (jacobians[kQ_B_S] != nullptr) {
        LiftLeftRotation<3>(Eigen::Matrix3d(J_r_wB * Hat<double>(kin.w_B)), p[kQ_B_S],
                            jacobians[kQ_B_S]);
      }
      if (want_time)
        Jacobian<3, 1>(jacobians[kTimeOffset]) = J_r_wB * kin.alpha_B;
      for (int i = 0; i < Nb; ++i) {
        if (jacobians[kBg + i] != nullptr)
          Jacobian<3, 3>(jacobians[kBg + i]) = -beta[i] * s.inv_sigma * Eigen::Matrix3d::Identity();
      }
      if (Wanted(jacobians, kDwSlot))
        DynamicJacobian<3>(jacobians[kDw], J_out_Dw.cols()) = -s.inv_sigma * J_out_Dw;
      return true;
    }

   private:
    Functor f_;
  };

  static ceres::CostFunction* MakeAutoDiff(const Setup& setup) {
    return MakeDynamicAutoDiff(new Functor{setup}, BlockSizes(setup.model), kNumResiduals);
  }
};

template <int N, Se3Representation Rep, int Nb>
ceres::CostFunction* MakeAuxGyroResidual(bool analytic, const GyroSampleSetup& setup) {
  using R = AuxGyroResidual<N, Rep, Nb>;
  if (analytic)
    return new typename R::Analytic(setup);
  return R::MakeAutoDiff(setup);
}

}  // namespace ctcal
