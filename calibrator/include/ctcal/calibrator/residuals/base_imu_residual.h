// Residual of one raw sample of the base IMU, the sensor whose frame B the trajectory describes.
//
// Model (SPEC sections 1, 3). The base IMU defines both the body frame and the reference clock, so
// its sample at stamp t is explained by the trajectory at t itself (no offset, no lever arm):
//   w_I = w_B(t),   a_I = f_B(t) = R_W_B^T (a_W - g_W)        (specific force),
//   z_pred = ImuRawFromTrue(intrinsics, w_I, a_I, b_g(t), b_a(t)),   r = W (z_m - z_pred),
// W = diag(I3 / sigma_g, I3 / sigma_a) with the per-sample white-noise sigmas (inertial_noise.h),
// so r ~ N(0, I_6). Biases and intrinsics: ImuSensorPart (inertial_support.h).
//
// Jacobians, with J_r_in = -W J_out_in the 6 x 6 Jacobian with respect to [w_I; a_I]:
//   knots:  J_r_in [J_w; J_f]        (spline Jacobians of w_B and of the specific force),
//   g_W:    J_r_in [0; -R_W_B^T]     (ambient, 3 columns; Ceres applies SphereManifold),
//   biases and intrinsics: ImuSensorPart.
#pragma once

#include <ceres/ceres.h>

#include <vector>

#include "ctcal/calibrator/residuals/inertial_support.h"
#include "ctcal/calibrator/residuals/residual_support.h"

namespace ctcal {

template <int N, Se3Representation Rep, int Nb>
class BaseImuResidual {
 public:
  using Spline = Se3Spline<N, Rep>;
  static constexpr int kNumResiduals = 6;
  // Block order of the contract: traj, g_W, bg (Nb), ba (Nb), Dw, Da, Tg, q_rotation (present).
  static constexpr int kNumTrajBlocks = Spline::kNumBlocks;
  static constexpr int kG_W = kNumTrajBlocks;
  static constexpr int kBg = kG_W + 1;
  static constexpr int kBa = kBg + Nb;
  static constexpr int kIntrinsics = kBa + Nb;

  struct Parameters {
    std::vector<double*> traj;  // Spline::SegmentBlocks(first_index)
    double* g_W = nullptr;
    std::vector<double*> bg;  // Nb gyro bias knots of the segment
    std::vector<double*> ba;  // Nb accel bias knots of the segment
    ImuIntrinsics* intrinsics = nullptr;
  };

  static std::vector<double*> Blocks(const Parameters& p) {
    using residual_internal::CheckCount;
    CheckCount("BaseImuResidual", "trajectory", p.traj.size(), kNumTrajBlocks);
    CheckCount("BaseImuResidual", "gyro bias", p.bg.size(), Nb);
    CheckCount("BaseImuResidual", "accel bias", p.ba.size(), Nb);
    // Reserved up front: no reallocation, and GCC 12's -Warray-bounds false positive on
    // push_back after a copy-construction stays away.
    std::vector<double*> blocks;
    blocks.reserve(kNumTrajBlocks + 1 + 2 * Nb + 4);
    blocks.insert(blocks.end(), p.traj.begin(), p.traj.end());
    blocks.push_back(p.g_W);
    blocks.insert(blocks.end(), p.bg.begin(), p.bg.end());
    blocks.insert(blocks.end(), p.ba.begin(), p.ba.end());
    ImuIntrinsicSlots::AppendBlocks(p.intrinsics, &blocks);
    return blocks;
  }

  static std::vector<int> BlockSizes(const ImuModelLayout& L) {
    std::vector<int> sizes;
    for (int b = 0; b < kNumTrajBlocks; ++b)
      sizes.push_back(Spline::AmbientSize(b));
    sizes.push_back(3);
    sizes.insert(sizes.end(), 2 * Nb, 3);
    ImuIntrinsicSlots::AppendSizes(L, &sizes);
    return sizes;
  }

  using Setup = ImuSampleSetup;

  // (a) The templated functor (autodiff path).
  struct Functor {
    Setup s;
    ImuIntrinsicSlots slots;

    explicit Functor(const Setup& setup)
        : s(setup), slots(ImuIntrinsicSlots::Of(setup.layout, kIntrinsics)) {}

    template <typename T>
    bool operator()(T const* const* p, T* residuals) const {
      Se3Kinematics<T> kin;
      Spline::template EvaluateSegment<T>(p, T(s.clock.U()), T(s.clock.inv_dt), 2, nullptr, &kin);
      const Vec3T<T> a_I = kin.SpecificForce(Eigen::Map<const Vec3T<T>>(p[kG_W]));
      Part().Residual(p, kin.w_B, a_I, residuals);
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
      const Eigen::Vector3d g_W = Eigen::Map<const Eigen::Vector3d>(p[kG_W]);
      Se3Kinematics<double> kin;
      Block J_w_knots, J_f_knots;
      typename Spline::template Jacobians<double> J_kin;
      J_kin.J_w_knots = &J_w_knots;
      J_kin.J_f_knots = &J_f_knots;
      Spline::template EvaluateSegment<double>(p, f.s.clock.U(), f.s.clock.inv_dt, 2, &g_W, &kin,
                                               want_traj ? &J_kin : nullptr);
      Eigen::Matrix<double, 6, 6> J_r_in;
      f.Part().Evaluate(p, kin.w_B, kin.SpecificForce(g_W), residuals, jacobians, &J_r_in);
      if (jacobians == nullptr)
        return true;
      if (want_traj) {
        const Eigen::Matrix<double, 6, 6 * N> J_r_knots =
            J_r_in.leftCols<3>() * J_w_knots + J_r_in.rightCols<3>() * J_f_knots;
        LiftTrajectoryJacobian<N, Rep, 6>(J_r_knots, p, jacobians);
      }
      if (jacobians[kG_W] != nullptr)
        Jacobian<6, 3>(jacobians[kG_W]) = -J_r_in.rightCols<3>() * kin.R_W_B.transpose();
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
ceres::CostFunction* MakeBaseImuResidual(bool analytic, const ImuSampleSetup& setup) {
  using R = BaseImuResidual<N, Rep, Nb>;
  if (analytic)
    return new typename R::Analytic(setup);
  return R::MakeAutoDiff(setup);
}

}  // namespace ctcal
