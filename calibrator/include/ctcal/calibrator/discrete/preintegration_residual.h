// The base IMU preintegration residual between keyframes i and j of the discrete MVIS
// formulation (report eq. 35-37; Forster et al. 2017 eq. 45).
//
// States per keyframe: q_W_B (x, y, z, w on So3LeftManifold), p_W_B, v_W (d/dt p_W_B), b_g, b_a
// (held constant over the interval; their change is a separate random-walk residual); gravity
// g_W (3-vector; the caller fixes its norm with a sphere manifold or holds it constant).
// From preintegration.h, R_i^T R_j = dR, R_i^T (v_j - v_i - g dt) = dv,
// R_i^T (p_j - p_i - v_i dt - g dt^2 / 2) = dp, so
//   r_R = Log(dR^T R_i^T R_j)                          (right-perturbation tangent of dR)
//   r_v = R_i^T (v_j - v_i - g dt) - dv
//   r_p = R_i^T (p_j - p_i - v_i dt - g dt^2 / 2) - dp
// in the error-state order of the propagated covariance, whitened by its square-root information
// S (S r has identity covariance to first order, E |S r|^2 = 9).
//
// Jacobians: Jet automatic differentiation (both factors). The bias-linearised factor evaluates
// 9 x 26 Jets of a closed form, cheap; the re-integrating one runs IntegrateDeltas on Jets over
// every sample of the interval, which is what eq. 37 costs by design.
#pragma once

#include <ceres/autodiff_cost_function.h>
#include <ceres/dynamic_autodiff_cost_function.h>

#include <memory>

#include "ctcal/calibrator/discrete/preintegration.h"
#include "ctcal/calibrator/discrete/split_integration.h"

namespace ctcal::discrete {

template <typename T>
Eigen::Matrix<T, 9, 1> PreintegrationError(const PreintegratedDeltas<T>& d, double dt,
                                           const Vec3T<T>& g_W, const QuatT<T>& q_W_Bi,
                                           const Vec3T<T>& p_i, const Vec3T<T>& v_i,
                                           const QuatT<T>& q_W_Bj, const Vec3T<T>& p_j,
                                           const Vec3T<T>& v_j) {
  const QuatT<T> q_Bi_W = q_W_Bi.conjugate();
  const T dt_t(dt);
  Eigen::Matrix<T, 9, 1> r;
  r.template head<3>() = LogSO3<T>(d.dR.conjugate() * (q_Bi_W * q_W_Bj));
  r.template segment<3>(3) = q_Bi_W * Vec3T<T>(v_j - v_i - g_W * dt_t) - d.dv;
  r.template tail<3>() = q_Bi_W * Vec3T<T>(p_j - p_i - v_i * dt_t - g_W * T(0.5 * dt * dt)) - d.dp;
  return r;
}

// Intrinsics fixed (eq. 36): deltas corrected to first order in the bias change from the
// preintegration's linearisation point. Blocks: q_i(4) p_i v_i b_g_i b_a_i q_j(4) p_j v_j g_W.
// Re-linearise (Preintegration::Reintegrate) when |b - b_bar| grows large.
class PreintegrationFactor {
 public:
  explicit PreintegrationFactor(std::shared_ptr<const Preintegration> pre) : pre_(std::move(pre)) {}

  template <typename T>
  bool operator()(const T* q_i, const T* p_i, const T* v_i, const T* bg_i, const T* ba_i,
                  const T* q_j, const T* p_j, const T* v_j, const T* g_W, T* residual) const {
    const PreintegratedDeltas<T> d =
        pre_->Corrected<T>(Eigen::Map<const Vec3T<T>>(bg_i), Eigen::Map<const Vec3T<T>>(ba_i));
    const Eigen::Matrix<T, 9, 1> r =
        PreintegrationError<T>(d, pre_->dt(), Eigen::Map<const Vec3T<T>>(g_W),
                               Eigen::Map<const QuatT<T>>(q_i), Eigen::Map<const Vec3T<T>>(p_i),
                               Eigen::Map<const Vec3T<T>>(v_i), Eigen::Map<const QuatT<T>>(q_j),
                               Eigen::Map<const Vec3T<T>>(p_j), Eigen::Map<const Vec3T<T>>(v_j));
    Eigen::Map<Eigen::Matrix<T, 9, 1>> out(residual);
    out = pre_->sqrt_information().cast<T>() * r;
    return true;
  }

  // Defined in preintegration_residual.cpp (the Jet instantiation compiled once).
  static ceres::CostFunction* Create(std::shared_ptr<const Preintegration> pre);

 private:
  std::shared_ptr<const Preintegration> pre_;
};

// Intrinsics estimated (eq. 37): the deltas are re-integrated from the raw samples for the
// current intrinsics and biases at every evaluation. Blocks: the nine of PreintegrationFactor,
// then the intrinsics blocks the model has, in the order D_w, D_a, T_g, rotation quaternion (as
// ImuIntrinsics exposes them; sizes from its *Size()). The whitening is the preintegration's
// (its covariance changes with the intrinsics only through the near-identity D and small T_g).
class ReintegrationFactor {
 public:
  static constexpr int kStride = 4;

  ReintegrationFactor(std::shared_ptr<const Preintegration> pre, const ImuIntrinsics& intrinsics)
      : pre_(std::move(pre)), layout_(intrinsics.layout()) {}

  template <typename T>
  bool operator()(T const* const* x, T* residual) const {
    return Error<T>(x, Deltas<T>(x), residual);
  }

  // The deltas re-integrated with the current intrinsics and biases (blocks 3, 4, 9...).
  template <typename T>
  PreintegratedDeltas<T> Deltas(T const* const* x) const {
    ImuBlocks<T> blocks;
    int k = 9;
    if (layout_.Dw != MatrixForm::kAbsent)
      blocks.Dw = x[k++];
    if (layout_.Da != MatrixForm::kAbsent)
      blocks.Da = x[k++];
    if (layout_.Tg != MatrixForm::kAbsent)
      blocks.Tg = x[k++];
    if (layout_.HasRotation())
      blocks.q_rotation = x[k++];
    return IntegrateDeltas<T>(pre_->readings(), layout_, blocks, Eigen::Map<const Vec3T<T>>(x[3]),
                              Eigen::Map<const Vec3T<T>>(x[4]));
  }

  // The error of the states given the deltas (blocks 0-2, 5-8).
  template <typename T>
  bool Error(T const* const* x, const PreintegratedDeltas<T>& d, T* residual) const {
    const Eigen::Matrix<T, 9, 1> r =
        PreintegrationError<T>(d, pre_->dt(), Eigen::Map<const Vec3T<T>>(x[8]),
                               Eigen::Map<const QuatT<T>>(x[0]), Eigen::Map<const Vec3T<T>>(x[1]),
                               Eigen::Map<const Vec3T<T>>(x[2]), Eigen::Map<const QuatT<T>>(x[5]),
                               Eigen::Map<const Vec3T<T>>(x[6]), Eigen::Map<const Vec3T<T>>(x[7]));
    Eigen::Map<Eigen::Matrix<T, 9, 1>> out(residual);
    out = pre_->sqrt_information().cast<T>() * r;
    return true;
  }

  // The block sizes in the order above.
  static std::vector<int> BlockSizes(const ImuIntrinsics& intrinsics) {
    std::vector<int> sizes{4, 3, 3, 3, 3, 4, 3, 3, 3};
    for (int size : {intrinsics.DwSize(), intrinsics.DaSize(), intrinsics.TgSize()})
      if (size > 0)
        sizes.push_back(size);
    if (intrinsics.layout().HasRotation())
      sizes.push_back(4);
    return sizes;
  }

  // One Jet pass over every block (the reference of CreateSplit); defined in
  // preintegration_residual.cpp.
  static ceres::CostFunction* Create(std::shared_ptr<const Preintegration> pre,
                                     const ImuIntrinsics& intrinsics);

  // The same residual, the re-integration differentiated only with respect to the biases and
  // intrinsics (split_integration.h).
  static ceres::CostFunction* CreateSplit(std::shared_ptr<const Preintegration> pre,
                                          const ImuIntrinsics& intrinsics);

 private:
  std::shared_ptr<const Preintegration> pre_;
  ImuModelLayout layout_;
};

inline ceres::CostFunction* ReintegrationFactor::CreateSplit(
    std::shared_ptr<const Preintegration> pre, const ImuIntrinsics& intrinsics) {
  const std::vector<int> sizes = BlockSizes(intrinsics);
  std::vector<bool> integration(sizes.size(), false);
  integration[3] = integration[4] = true;
  for (std::size_t b = 9; b < sizes.size(); ++b)
    integration[b] = true;
  return new SplitIntegrationCost<ReintegrationFactor>(
      std::make_shared<const ReintegrationFactor>(std::move(pre), intrinsics), sizes,
      std::move(integration), 9);
}

}  // namespace ctcal::discrete
