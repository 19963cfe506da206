// Priors on calibration parameters (the rig's prior_sigma, SPEC section 7).
//
// RotationPrior, a quaternion block on So3LeftManifold (R = Exp(d) R_hat, full angle):
//   r = S Log(R R0^T),  S = diag(1 / sigma)  (per component, radians, in R's output frame).
//   With phi = Log(R_hat R0^T): Log(Exp(d) Exp(phi)) = phi + Jl^-1(phi) d + O(d^2), so
//   d r / d d = S Jl^-1(phi)  (left Jacobian of SO(3), so3.h). At R = R0 that is S: the prior's
//   tangent is the manifold's, component for component.
// VectorPrior, any Euclidean block (translations, time offsets, intrinsics):
//   r = S (x - x0),  d r / d x = S.
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <stdexcept>
#include <string>

#include "ctcal/calibrator/residuals/residual_support.h"
#include "ctcal/spline/so3.h"

namespace ctcal {

namespace residual_internal {

template <typename Derived>
Eigen::VectorXd InverseSigmas(const Eigen::MatrixBase<Derived>& sigma, const char* who) {
  if (!(sigma.array() > 0.0).all() || !sigma.allFinite())
    throw std::invalid_argument(std::string(who) + ": every sigma must be positive and finite");
  return sigma.cwiseInverse();
}

}  // namespace residual_internal

class RotationPrior {
 public:
  static constexpr int kNumResiduals = 3;

  // (a) The templated functor.
  struct Functor {
    Eigen::Quaterniond q0;
    Eigen::Vector3d inv_sigma;
    template <typename T>
    bool operator()(const T* q, T* residuals) const {
      const QuatT<T> q_err = Eigen::Map<const QuatT<T>>(q) * q0.cast<T>().conjugate();
      const Vec3T<T> phi = LogSO3<T>(q_err);
      for (int i = 0; i < 3; ++i)
        residuals[i] = phi(i) * T(inv_sigma(i));
      return true;
    }
  };

  // (b) The analytic cost function.
  class Analytic final : public ceres::SizedCostFunction<3, 4> {
   public:
    explicit Analytic(const Functor& f) : f_(f) {}
    bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
      const Eigen::Quaterniond q_err =
          Eigen::Map<const Eigen::Quaterniond>(p[0]) * f_.q0.conjugate();
      const Eigen::Vector3d phi = LogSO3<double>(q_err);
      Eigen::Map<Eigen::Vector3d> r(residuals);
      r = f_.inv_sigma.cwiseProduct(phi);
      if (jacobians != nullptr && jacobians[0] != nullptr) {
        const Eigen::Matrix3d J = f_.inv_sigma.asDiagonal() * LeftJacobianInvSO3<double>(phi);
        residual_internal::LiftLeftRotation<3>(J, p[0], jacobians[0]);
      }
      return true;
    }

   private:
    Functor f_;
  };
};

// q0: the prior mean (x, y, z, w); sigma: radians per component (> 0).
inline ceres::CostFunction* MakeRotationPrior(bool analytic, const Eigen::Quaterniond& q0,
                                              const Eigen::Vector3d& sigma) {
  const RotationPrior::Functor f{q0.normalized(),
                                 residual_internal::InverseSigmas(sigma, "RotationPrior")};
  if (analytic)
    return new RotationPrior::Analytic(f);
  return new ceres::AutoDiffCostFunction<RotationPrior::Functor, 3, 4>(
      new RotationPrior::Functor(f));
}

class VectorPrior {
 public:
  // (a) The templated functor (any size: a dynamic cost function).
  struct Functor {
    Eigen::VectorXd x0;
    Eigen::VectorXd inv_sigma;
    template <typename T>
    bool operator()(T const* const* p, T* residuals) const {
      for (Eigen::Index i = 0; i < x0.size(); ++i)
        residuals[i] = (p[0][i] - T(x0(i))) * T(inv_sigma(i));
      return true;
    }
  };

  // (b) The analytic cost function.
  class Analytic final : public ceres::CostFunction {
   public:
    explicit Analytic(const Functor& f) : f_(f) {
      set_num_residuals(static_cast<int>(f.x0.size()));
      mutable_parameter_block_sizes()->push_back(static_cast<int>(f.x0.size()));
    }
    bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
      const Eigen::Index n = f_.x0.size();
      Eigen::Map<Eigen::VectorXd> r(residuals, n);
      r = f_.inv_sigma.cwiseProduct(Eigen::Map<const Eigen::VectorXd>(p[0], n) - f_.x0);
      if (jacobians != nullptr && jacobians[0] != nullptr) {
        Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> J(
            jacobians[0], n, n);
        J.setZero();
        J.diagonal() = f_.inv_sigma;
      }
      return true;
    }

   private:
    Functor f_;
  };
};

inline ceres::CostFunction* MakeVectorPrior(bool analytic, const Eigen::VectorXd& x0,
                                            const Eigen::VectorXd& sigma) {
  if (x0.size() == 0 || sigma.size() != x0.size())
    throw std::invalid_argument("VectorPrior: mean of size " + std::to_string(x0.size()) +
                                " with " + std::to_string(sigma.size()) + " sigmas");
  const VectorPrior::Functor f{x0, residual_internal::InverseSigmas(sigma, "VectorPrior")};
  if (analytic)
    return new VectorPrior::Analytic(f);
  const int size = static_cast<int>(x0.size());
  return MakeDynamicAutoDiff(new VectorPrior::Functor(f), {size}, size);
}

}  // namespace ctcal
