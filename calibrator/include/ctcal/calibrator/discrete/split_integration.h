// Jacobians of a re-integrating preintegration factor in two automatic-differentiation passes, so
// that the integration over the samples is differentiated only with respect to the blocks it
// reads (intrinsics, biases), not with respect to every block of the factor.
//
// A factor r(x) = e(x_s, d(x_i)) splits its blocks into x_i, read only by the deltas
// d = (dR, dv, dp) integrated from the raw samples (report eq. 37: intrinsics and biases), and
// x_s, read only by the error of the states given the deltas (keyframe states, interpolated poses,
// extrinsics, time offsets, gravity). Perturbing the deltas on the right,
//   dR = dR_hat Exp(delta_R),  dv = dv_hat + delta_v,  dp = dp_hat + delta_p,
// the chain rule gives
//   d r / d x_s = d e / d x_s                       (pass 2, the deltas held at d_hat),
//   d r / d x_i = d e / d delta * d delta / d x_i    (pass 2's 9 delta columns x pass 1),
// with pass 1 the deltas' own tangent at the current point,
//   delta = [2 vec(dR_hat^-1 dR(x_i)),  dv(x_i),  dp(x_i)]
// (2 vec(.) has the rotation vector's derivative at the identity). The Jet passes of the
// integration drop from (|x_s| + |x_i|) / stride to |x_i| / stride; e is cheap. The Jacobian is
// the one-pass Jet Jacobian up to rounding (tests/calibrator/discrete/test_discrete_residuals.cpp).
//
// Functor requirements (AuxImuFunctor, AuxGyroFunctor, ReintegrationFactor):
//   template <T> PreintegratedDeltas<T> Deltas(T const* const* x) const;     reads x_i only
//   template <T> bool Error(T const* const* x, const PreintegratedDeltas<T>& d, T* r) const;
//                                                                             reads x_s only
#pragma once

#include <ceres/ceres.h>
#include <ceres/dynamic_autodiff_cost_function.h>

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "ctcal/calibrator/discrete/preintegration.h"
#include "ctcal/spline/bspline_basis.h"

namespace ctcal::discrete {

template <class Functor, int kStride = 8>
class SplitIntegrationCost final : public ceres::CostFunction {
 public:
  // block_sizes: the factor's blocks; integration[b]: whether block b is read by the deltas only.
  SplitIntegrationCost(std::shared_ptr<const Functor> f, const std::vector<int>& block_sizes,
                       std::vector<bool> integration, int num_residuals)
      : f_(std::move(f)), integration_(std::move(integration)) {
    set_num_residuals(num_residuals);
    *mutable_parameter_block_sizes() = block_sizes;
    tangent_ = std::make_unique<ceres::DynamicAutoDiffCostFunction<DeltaTangent, kStride>>(
        new DeltaTangent{f_});
    error_ = std::make_unique<ceres::DynamicAutoDiffCostFunction<ErrorOfDelta, kStride>>(
        new ErrorOfDelta{f_, static_cast<int>(block_sizes.size())});
    for (const int size : block_sizes) {
      tangent_->AddParameterBlock(size);
      error_->AddParameterBlock(size);
    }
    error_->AddParameterBlock(10);  // d_hat: dR (x, y, z, w), dv, dp (constant)
    error_->AddParameterBlock(9);   // delta
    tangent_->SetNumResiduals(9);
    error_->SetNumResiduals(num_residuals);
  }

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    const PreintegratedDeltas<double> d = f_->template Deltas<double>(p);
    if (jacobians == nullptr)
      return f_->template Error<double>(p, d, residuals);
    const std::size_t n = parameter_block_sizes().size();
    const int m = num_residuals();
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

    // Pass 2: the error's Jacobians of the state blocks and of delta (at delta = 0).
    double d_hat[10];
    for (int i = 0; i < 4; ++i)
      d_hat[i] = d.dR.coeffs()(i);
    for (int i = 0; i < 3; ++i) {
      d_hat[4 + i] = d.dv(i);
      d_hat[7 + i] = d.dp(i);
    }
    const double delta[9] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    std::vector<const double*> p2(p, p + n);
    p2.push_back(d_hat);
    p2.push_back(delta);
    RowMajor J_r_delta(m, 9);
    std::vector<double*> j2(n + 2, nullptr);
    bool any_integration = false;
    for (std::size_t b = 0; b < n; ++b) {
      if (jacobians[b] == nullptr)
        continue;
      if (integration_[b])
        any_integration = true;
      else
        j2[b] = jacobians[b];
    }
    if (any_integration)
      j2[n + 1] = J_r_delta.data();
    if (!error_->Evaluate(p2.data(), residuals, j2.data()))
      return false;
    if (!any_integration)
      return true;

    // Pass 1: the deltas' tangent with respect to the integration blocks, chained.
    std::vector<RowMajor> J_delta(n);
    std::vector<double*> j1(n, nullptr);
    for (std::size_t b = 0; b < n; ++b) {
      if (jacobians[b] != nullptr && integration_[b]) {
        J_delta[b].resize(9, parameter_block_sizes()[b]);
        j1[b] = J_delta[b].data();
      }
    }
    double tangent[9];
    if (!tangent_->Evaluate(p, tangent, j1.data()))
      return false;
    for (std::size_t b = 0; b < n; ++b) {
      if (j1[b] != nullptr)
        Eigen::Map<RowMajor>(jacobians[b], m, parameter_block_sizes()[b]) = J_r_delta * J_delta[b];
    }
    return true;
  }

 private:
  struct DeltaTangent {
    std::shared_ptr<const Functor> f;
    template <typename T>
    bool operator()(T const* const* x, T* out) const {
      const PreintegratedDeltas<T> d = f->template Deltas<T>(x);
      const QuatT<T> q_hat(T(ScalarPart(d.dR.w())), T(ScalarPart(d.dR.x())),
                           T(ScalarPart(d.dR.y())), T(ScalarPart(d.dR.z())));
      Eigen::Map<Eigen::Matrix<T, 9, 1>> t(out);
      t.template head<3>() = T(2.0) * (q_hat.conjugate() * d.dR).vec();
      t.template segment<3>(3) = d.dv;
      t.template tail<3>() = d.dp;
      return true;
    }
  };

  struct ErrorOfDelta {
    std::shared_ptr<const Functor> f;
    int n = 0;  // the factor's blocks; then d_hat, delta
    template <typename T>
    bool operator()(T const* const* x, T* residuals) const {
      const T* d_hat = x[n];
      const T* delta = x[n + 1];
      PreintegratedDeltas<T> d;
      d.dR = Eigen::Map<const QuatT<T>>(d_hat) *
             ExpSO3<T>(Vec3T<T>(Eigen::Map<const Vec3T<T>>(delta)));
      d.dv = Eigen::Map<const Vec3T<T>>(d_hat + 4) + Eigen::Map<const Vec3T<T>>(delta + 3);
      d.dp = Eigen::Map<const Vec3T<T>>(d_hat + 7) + Eigen::Map<const Vec3T<T>>(delta + 6);
      return f->template Error<T>(x, d, residuals);
    }
  };

  std::shared_ptr<const Functor> f_;
  std::vector<bool> integration_;
  std::unique_ptr<ceres::DynamicAutoDiffCostFunction<DeltaTangent, kStride>> tangent_;
  std::unique_ptr<ceres::DynamicAutoDiffCostFunction<ErrorOfDelta, kStride>> error_;
};

}  // namespace ctcal::discrete
