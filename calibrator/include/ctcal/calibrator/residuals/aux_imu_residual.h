// Residual of one raw sample of an auxiliary IMU S, rigidly mounted at T_B_S on the body.
//
// Model (SPEC sections 1-3). The sample stamped t_S on the sensor's clock happened at base-clock
// time t = t_S + time_offset. A point rigidly attached to B at r = t_B_S has world acceleration
// a_W + R_W_B (alpha_B x r + w_B x (w_B x r)), so, in S's frame,
//   w_S = R_B_S^T w_B(t),
//   a_S = R_B_S^T A,   A = f_B + alpha_B x r + w_B x (w_B x r),   f_B = R_W_B^T (a_W - g_W),
//   z_pred = ImuRawFromTrue(intrinsics of S, w_S, a_S, b_g, b_a),  r_6 = W (z_m - z_pred).
// Biases, intrinsics and the whitening W: ImuSensorPart (inertial_support.h); r_6 ~ N(0, I_6).
//
// Jacobians, with J_r_in = -W J_out_in (6 x 6 w.r.t. [w_S; a_S]) and M = R_B_S^T:
//   knots:  [M J_w; M J_A],  J_A = J_f - [r]x J_alpha + D J_w,
//           D = d(w x (w x r))/dw = (w.r) I + w r^T - 2 r w^T;
//   g_W:    [0; -M R_W_B^T]  (ambient; Ceres applies SphereManifold);
//   q_B_S (R_B_S = Exp(d) R_hat, so R_B_S^T v -> R_B_S^T (v + [v]x d)):  [M [w_B]x; M [A]x];
//   t_B_S:  [0; M ([alpha_B]x + [w_B]x [w_B]x)];
//   time_offset: d/dt of the inputs, [M alpha_B; M dA/dt],
//           dA/dt = df_B/dt + dalpha_B x r + alpha_B x (w_B x r) + w_B x (alpha_B x r),
//           df_B/dt = -w_B x f_B + R_W_B^T jerk_W (Se3Kinematics::SpecificForceRate);
// each multiplied by J_r_in on the left.
#pragma once

#include <ceres/ceres.h>

#include <vector>

#include "ctcal/calibrator/residuals/inertial_support.h"
#include "ctcal/calibrator/residuals/residual_support.h"

namespace ctcal {

template <int N, Se3Representation Rep, int Nb>
class AuxImuResidual {
 public:
  using Spline = Se3Spline<N, Rep>;
  using Setup = ImuSampleSetup;
  static constexpr int kNumResiduals = 6;
  // Block order of the contract: traj, g_W, q_B_S, t_B_S, time_offset, bg (Nb), ba (Nb),
  // Dw, Da, Tg, q_rotation (present).
  static constexpr int kNumTrajBlocks = Spline::kNumBlocks;
  static constexpr int kG_W = kNumTrajBlocks;
  static constexpr int kQ_B_S = kG_W + 1;
  static constexpr int kT_B_S = kQ_B_S + 1;
  static constexpr int kTimeOffset = kT_B_S + 1;
  static constexpr int kBg = kTimeOffset + 1;
  static constexpr int kBa = kBg + Nb;
  static constexpr int kIntrinsics = kBa + Nb;

  struct Parameters {
    std::vector<double*> traj;
    double* g_W = nullptr;
    double* q_B_S = nullptr;
    double* t_B_S = nullptr;
    double* time_offset = nullptr;
    std::vector<double*> bg;
    std::vector<double*> ba;
    ImuIntrinsics* intrinsics = nullptr;
  };

  static std::vector<double*> Blocks(const Parameters& p) {
    using residual_internal::CheckCount;
    CheckCount("AuxImuResidual", "trajectory", p.traj.size(), kNumTrajBlocks);
    CheckCount("AuxImuResidual", "gyro bias", p.bg.size(), Nb);
    CheckCount("AuxImuResidual", "accel bias", p.ba.size(), Nb);
    // Reserved up front: no reallocation, and GCC 12's -Warray-bounds false positive on
    // push_back after a copy-construction stays away.
    std::vector<double*> blocks;
    blocks.reserve(kNumTrajBlocks + 4 + 2 * Nb + 4);
    blocks.insert(blocks.end(), p.traj.begin(), p.traj.end());
    blocks.insert(blocks.end(), {p.g_W, p.q_B_S, p.t_B_S, p.time_offset});
    blocks.insert(blocks.end(), p.bg.begin(), p.bg.end());
    blocks.insert(blocks.end(), p.ba.begin(), p.ba.end());
    ImuIntrinsicSlots::AppendBlocks(p.intrinsics, &blocks);
    return blocks;
  }

  static std::vector<int> BlockSizes(const ImuModelLayout& L) {
    std::vector<int> sizes;
    for (int b = 0; b < kNumTrajBlocks; ++b)
      sizes.push_back(Spline::AmbientSize(b));
    sizes.insert(sizes.end(), {3, 4, 3, 1});
    sizes.insert(sizes.end(), 2 * Nb, 3);
    ImuIntrinsicSlots::AppendSizes(L, &sizes);
    return sizes;
  }

  // (a) The templated functor (autodiff path).
  struct Functor {
    Setup s;
    ImuIntrinsicSlots slots;

    explicit Functor(const Setup& setup)
        : s(setup), slots(ImuIntrinsicSlots::Of(setup.layout, kIntrinsics)) {}

    template <typename T>
    bool operator()(T const* const* p, T* residuals) const {
      Se3Kinematics<T> kin;
      Spline::template EvaluateSegment<T>(p, s.clock.U(p[kTimeOffset][0]), T(s.clock.inv_dt), 2,
                                          nullptr, &kin);
      const Vec3T<T> f_B = kin.SpecificForce(Eigen::Map<const Vec3T<T>>(p[kG_W]));
      const Mat3T<T> R_B_S = Eigen::Map<const QuatT<T>>(p[kQ_B_S]).toRotationMatrix();
      const Eigen::Map<const Vec3T<T>> r(p[kT_B_S]);
      const Vec3T<T> A = f_B + kin.alpha_B.cross(r) + kin.w_B.cross(kin.w_B.cross(r));
      Part().Residual(p, Vec3T<T>(R_B_S.transpose() * kin.w_B), Vec3T<T>(R_B_S.transpose() * A),
                      residuals);
      return true;
    }

    ImuSensorPart<Nb> Part() const {
      return {&s.layout, &slots, kBg, kBa, &s.bias_clock, &s.W, &s.z};
    }
  };

  // (b) The analytic cost function.
  class Analytic final : public ceres::CostFunction {
   public:
    explicit Analytic(const Setup& setup) : f_(setup) {
      set_num_residuals(kNumResiduals);
      *mutable_parameter_block_sizes() = BlockSizes(setup.layout);
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
      const bool want_traj = AnyWanted(jacobians, 0, kNumTrajBlocks);
      const bool want_time = Wanted(jacobians, kTimeOffset);
      const Eigen::Vector3d g_W = Eigen::Map<const Eigen::Vector3d>(p[kG_W]);
      Se3Kinematics<double> kin;
      Block J_w_knots, J_alpha_knots, J_f_knots;
      typename Spline::template Jacobians<double> J_kin;
      J_kin.J_w_knots = &J_w_knots;
      J_kin.J_alpha_knots = &J_alpha_knots;
      J_kin.J_f_knots = &J_f_knots;
      Spline::template EvaluateSegment<double>(p, f.s.clock.U(p[kTimeOffset][0]), f.s.clock.inv_dt,
                                               want_time ? 3 : 2, &g_W, &kin,
                                               want_traj ? &J_kin : nullptr);

      const Eigen::Matrix3d M =
          Eigen::Map<const Eigen::Quaterniond>(p[kQ_B_S]).toRotationMatrix().transpose();
      const Eigen::Vector3d r = Eigen::Map<const Eigen::Vector3d>(p[kT_B_S]);
      const Eigen::Vector3d& w = kin.w_B;
      const Eigen::Vector3d& alpha = kin.alpha_B;
      const Eigen::Vector3d f_B = kin.SpecificForce(g_W);
      const Eigen::Vector3d A = f_B + alpha.cross(r) + w.cross(w.cross(r));

      Eigen::Matrix<double, 6, 6> J_r_in;
      f.Part().Evaluate(p, M * w, M * A, residuals, jacobians, &J_r_in);
      if (jacobians == nullptr)
        return true;
      const Eigen::Matrix<double, 6, 3> J_r_w = J_r_in.leftCols<3>() * M;
      const Eigen::Matrix<double, 6, 3> J_r_A = J_r_in.rightCols<3>() * M;

      if (want_traj) {
        const Eigen::Matrix3d D =
            w.dot(r) * Eigen::Matrix3d::Identity() + w * r.transpose() - 2.0 * r * w.transpose();
        const Block J_A_knots = J_f_knots - Hat<double>(r) * J_alpha_knots + D * J_w_knots;
        const Eigen::Matrix<double, 6, 6 * N> J_r_knots = J_r_w * J_w_knots + J_r_A * J_A_knots;
        LiftTrajectoryJacobian<N, Rep, 6>(J_r_knots, p, jacobians);
      }
      if (jacobians[kG_W] != nullptr)
        Jacobian<6, 3>(jacobians[kG_W]) = -J_r_A * kin.R_W_B.transpose();
      if (jacobians[kQ_B_S] != nullptr) {
        const Eigen::Matrix<double, 6, 3> J_r_d = J_r_w * Hat<double>(w) + J_r_A * Hat<double>(A);
        LiftLeftRotation<6>(J_r_d, p[kQ_B_S], jacobians[kQ_B_S]);
      }
      if (jacobians[kT_B_S] != nullptr) {
        const Eigen::Matrix3d W_hat = Hat<double>(w);
        Jacobian<6, 3>(jacobians[kT_B_S]) = J_r_A * (Hat<double>(alpha) + W_hat * W_hat);
      }
      if (want_time) {
        const Eigen::Vector3d dA_dt = kin.SpecificForceRate(g_W) + kin.dalpha_B.cross(r) +
                                      alpha.cross(w.cross(r)) + w.cross(alpha.cross(r));
        Jacobian<6, 1>(jacobians[kTimeOffset]) = J_r_w * alpha + J_r_A * dA_dt;
      }
      return true;
    }

   private:
    Functor f_;
  };

  static ceres::CostFunction* MakeAutoDiff(const Setup& setup) {
    return MakeDynamicAutoDiff(new Functor(setup), BlockSizes(setup.layout), kNumResiduals);
  }
};

template <int N, Se3Representation Rep, int Nb>
ceres::CostFunction* MakeAuxImuResidual(bool analytic, const ImuSampleSetup& setup) {
  using R = AuxImuResidual<N, Rep, Nb>;
  if (analytic)
    return new typename R::Analytic(setup);
  return R::MakeAutoDiff(setup);
}

}  // namespace ctcal
