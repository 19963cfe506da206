#include "intrinsics_refinement.h"

#include <ceres/manifold.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>

#include "corner_reprojection.h"

namespace ctcal {

namespace {

// Ceres' defaults, which the refinement ran with (intrinsics_refinement.h).
constexpr double kInitialRadius = 1e4;
constexpr double kMaxRadius = 1e16;
constexpr double kMinRadius = 1e-32;
constexpr double kMinDiagonal = 1e-6;
constexpr double kMaxDiagonal = 1e32;
constexpr double kMinRelativeDecrease = 1e-3;
constexpr double kFunctionTolerance = 1e-6;
constexpr double kParameterTolerance = 1e-8;
constexpr double kGradientTolerance = 1e-10;
constexpr int kMaxConsecutiveInvalidSteps = 5;

template <class Model>
class Refinement {
 public:
  static constexpr int P = Model::kNumParams;
  using VecP = Eigen::Matrix<double, P, 1>;
  using MatP = Eigen::Matrix<double, P, P>;
  using Mat6 = Eigen::Matrix<double, 6, 6>;
  using Vec6 = Eigen::Matrix<double, 6, 1>;
  using MatP6 = Eigen::Matrix<double, P, 6>;
  using Residual = CornerReprojection<Model>;

  Refinement(const std::vector<CornerRef>& corners, std::size_t num_views, double cauchy_px,
             int free_params)
      : corners_(corners), free_(free_params), b_(cauchy_px * cauchy_px), c_(1.0 / b_) {
    plus_jacobians_.resize(num_views);
    C_.resize(num_views);
    B_.resize(num_views);
    gv_.resize(num_views);
  }

  // 1/2 sum rho(|r|^2) at (params, views); false where a corner does not project.
  bool Cost(const VecP& params, const std::vector<ViewState>& views, double* cost) const {
    double sum = 0.0;
    for (std::size_t k = 0; k < corners_.size(); ++k) {
      const CornerRef& c = corners_[k];
      const ViewState& v = views[static_cast<std::size_t>(c.view)];
      Eigen::Vector2d r;
      if (!Residual::Compute(params.data(), v.q_C_W, v.t_C_W, c.p_W, c.uv, r.data(), nullptr,
                             nullptr, nullptr))
        return false;
      sum += Rho(r.squaredNorm());
    }
    *cost = 0.5 * sum;
    return true;
  }

  // The corrected normal equations' blocks at (params, views) and the cost there.
  bool Linearise(const VecP& params, const std::vector<ViewState>& views, double* cost) {
    A_.setZero();
    gp_.setZero();
    for (std::size_t v = 0; v < views.size(); ++v) {
      kQuaternion.PlusJacobian(views[v].q_C_W.coeffs().data(), plus_jacobians_[v].data());
      C_[v].setZero();
      B_[v].setZero();
      gv_[v].setZero();
    }
    double sum = 0.0;
    Eigen::Matrix<double, 2, P, Eigen::RowMajor> J_params;
    Eigen::Matrix<double, 2, 4, Eigen::RowMajor> J_q;
    Eigen::Matrix<double, 2, 3, Eigen::RowMajor> J_t;
    Eigen::Matrix<double, 2, 6> J_pose;
    for (std::size_t k = 0; k < corners_.size(); ++k) {
      const CornerRef& c = corners_[k];
      const std::size_t v = static_cast<std::size_t>(c.view);
      const ViewState& view = views[v];
      Eigen::Vector2d r;
      if (!Residual::Compute(params.data(), view.q_C_W, view.t_C_W, c.p_W, c.uv, r.data(),
                             J_params.data(), J_q.data(), J_t.data()))
        return false;
      const double s = r.squaredNorm();
      sum += Rho(s);
      // rho'(s): the corrector's sqrt(rho') on residual and Jacobian, squared.
      const double w = 1.0 / (1.0 + s * c_);
      J_pose.leftCols<3>() = J_q * plus_jacobians_[v];
      J_pose.rightCols<3>() = J_t;
      const Eigen::Matrix<double, P, 2> wJp = w * J_params.transpose();
      const Eigen::Matrix<double, 6, 2> wJv = w * J_pose.transpose();
      A_.noalias() += wJp * J_params;
      B_[v].noalias() += wJp * J_pose;
      C_[v].noalias() += wJv * J_pose;
      gp_.noalias() += wJp * r;
      gv_[v].noalias() += wJv * r;
    }
    *cost = 0.5 * sum;
    return true;
  }

  // The Cauchy loss rho(s) = a^2 log(1 + s / a^2) of a corner's squared error s.
  double Rho(double s) const { return b_ * std::log(1.0 + s * c_); }

  // Ceres' quaternion manifold (coefficients x, y, z, w), which the refinement used there:
  // Plus(q, d) = [sin|d| d/|d|, cos|d|] q.
  static inline const ceres::EigenQuaternionManifold kQuaternion{};

  double GradientMaxNorm() const {
    double m = 0.0;
    for (int i = 0; i < free_; ++i)
      m = std::max(m, std::abs(gp_[i]));
    for (const Vec6& g : gv_)
      m = std::max(m, g.cwiseAbs().maxCoeff());
    return m;
  }

  // The damped step by the Schur complement on the views, and the linear model's cost decrease
  // -(g . delta + 1/2 delta^T J^T J delta). False where a factorisation fails.
  bool Step(double radius, VecP* dp, std::vector<Vec6>* dv, double* model_decrease) const {
    const double mu = 1.0 / radius;
    const auto damped = [mu](double d) {
      return d + mu * std::min(std::max(d, kMinDiagonal), kMaxDiagonal);
    };
    const std::size_t n = C_.size();
    // The free parameters' blocks as dynamic-size copies (at most 9 x 9).
    const Eigen::MatrixXd A = A_.topLeftCorner(free_, free_);
    const Eigen::VectorXd g = gp_.topRows(free_);
    Eigen::MatrixXd S = A;
    for (int i = 0; i < free_; ++i)
      S(i, i) = damped(A(i, i));
    Eigen::VectorXd rhs = -g;
    std::vector<Eigen::LDLT<Mat6>> C_inv(n);
    std::vector<Eigen::Matrix<double, 6, Eigen::Dynamic>> CinvBt(n);
    for (std::size_t v = 0; v < n; ++v) {
      Mat6 C = C_[v];
      for (int i = 0; i < 6; ++i)
        C(i, i) = damped(C_[v](i, i));
      C_inv[v].compute(C);
      if (C_inv[v].info() != Eigen::Success)
        return false;
      const Eigen::Matrix<double, Eigen::Dynamic, 6> Bf = B_[v].topRows(free_);
      CinvBt[v] = C_inv[v].solve(Bf.transpose());
      S.noalias() -= Bf * CinvBt[v];
      rhs.noalias() += CinvBt[v].transpose() * gv_[v];
    }
    const Eigen::LDLT<Eigen::MatrixXd> S_ldlt(S);
    if (S_ldlt.info() != Eigen::Success)
      return false;
    const Eigen::VectorXd d = S_ldlt.solve(rhs);
    dp->setZero();
    for (int i = 0; i < free_; ++i)
      (*dp)[i] = d[i];
    dv->resize(n);
    double g_delta = g.dot(d);
    double quad = d.dot(A * d);
    for (std::size_t v = 0; v < n; ++v) {
      Vec6& e = (*dv)[v];
      e = -C_inv[v].solve(gv_[v]) - CinvBt[v] * d;
      g_delta += gv_[v].dot(e);
      const Eigen::Matrix<double, Eigen::Dynamic, 6> Bf = B_[v].topRows(free_);
      quad += 2.0 * d.dot(Bf * e) + e.dot(C_[v] * e);
    }
    *model_decrease = -(g_delta + 0.5 * quad);
    return dp->allFinite() &&
           std::all_of(dv->begin(), dv->end(), [](const Vec6& step) { return step.allFinite(); });
  }

 private:
  const std::vector<CornerRef>& corners_;
  int free_;
  double b_, c_;  // Cauchy: a^2 and 1 / a^2 of scale a
  // Each view's PlusJacobian (4 x 3, row-major) at the linearisation point.
  std::vector<Eigen::Matrix<double, 4, 3, Eigen::RowMajor>> plus_jacobians_;
  MatP A_;
  VecP gp_;
  std::vector<Mat6> C_;
  std::vector<MatP6> B_;
  std::vector<Vec6> gv_;
};

template <class Model>
IntrinsicsRefinementSummary Refine(Eigen::VectorXd* params_io, const Eigen::VectorXd& lower,
                                   const Eigen::VectorXd& upper, std::vector<ViewState>* views,
                                   const std::vector<CornerRef>& corners,
                                   const IntrinsicsRefinementOptions& options) {
  using R = Refinement<Model>;
  constexpr int P = R::P;
  const int free = options.first_held_param >= 0 ? std::min(options.first_held_param, P) : P;
  IntrinsicsRefinementSummary summary;
  R refinement(corners, views->size(), options.cauchy_px, free);
  typename R::VecP x = *params_io;
  double cost = 0.0;
  if (!refinement.Linearise(x, *views, &cost))
    return summary;
  summary.initial_cost = cost;
  summary.usable = true;
  double radius = kInitialRadius;
  double decrease_factor = 2.0;
  int invalid_steps = 0;
  typename R::VecP dp;
  std::vector<typename R::Vec6> dv;
  std::vector<ViewState> candidate_views(views->size());
  // Already at a stationary point (Ceres' gradient tolerance at the start).
  const bool stationary = refinement.GradientMaxNorm() <= kGradientTolerance;
  while (!stationary && summary.iterations < options.max_iterations) {
    ++summary.iterations;
    double model_decrease = 0.0;
    if (!refinement.Step(radius, &dp, &dv, &model_decrease) || !(model_decrease > 0.0)) {
      // Ceres' invalid step: a smaller trust region, a limited number of times in a row.
      if (++invalid_steps > kMaxConsecutiveInvalidSteps) {
        summary.usable = false;
        break;
      }
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      if (radius < kMinRadius)
        break;
      continue;
    }
    invalid_steps = 0;
    // Parameter tolerance: the step against the state's (ambient) norm.
    double step_sq = dp.squaredNorm(), x_sq = x.squaredNorm();
    for (std::size_t v = 0; v < views->size(); ++v) {
      step_sq += dv[v].squaredNorm();
      x_sq += (*views)[v].q_C_W.coeffs().squaredNorm() + (*views)[v].t_C_W.squaredNorm();
    }
    if (std::sqrt(step_sq) <= kParameterTolerance * (std::sqrt(x_sq) + kParameterTolerance))
      break;
    typename R::VecP x_new = x + dp;
    for (int i = 0; i < P; ++i)
      x_new[i] = std::min(std::max(x_new[i], lower[i]), upper[i]);
    for (std::size_t v = 0; v < views->size(); ++v) {
      R::kQuaternion.Plus((*views)[v].q_C_W.coeffs().data(), dv[v].data(),
                          candidate_views[v].q_C_W.coeffs().data());
      candidate_views[v].t_C_W = (*views)[v].t_C_W + dv[v].template tail<3>();
    }
    double new_cost = std::numeric_limits<double>::max();
    if (!refinement.Cost(x_new, candidate_views, &new_cost))
      new_cost = std::numeric_limits<double>::max();
    // Function tolerance: a change this small ends the solve without taking the step.
    if (std::abs(cost - new_cost) <= kFunctionTolerance * cost)
      break;
    const double relative_decrease = (cost - new_cost) / model_decrease;
    if (relative_decrease > kMinRelativeDecrease) {
      x = x_new;
      views->swap(candidate_views);
      radius =
          std::min(kMaxRadius,
                   radius / std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * relative_decrease - 1.0, 3)));
      decrease_factor = 2.0;
      if (!refinement.Linearise(x, *views, &cost)) {
        summary.usable = false;  // cannot happen: Cost() just evaluated this point
        break;
      }
      if (refinement.GradientMaxNorm() <= kGradientTolerance)
        break;
    } else {
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      if (radius < kMinRadius)
        break;
    }
  }
  summary.final_cost = cost;
  *params_io = x;
  return summary;
}

}  // namespace

IntrinsicsRefinementSummary RefineIntrinsicsAndPoses(CameraModelType type, Eigen::VectorXd* params,
                                                     const Eigen::VectorXd& lower,
                                                     const Eigen::VectorXd& upper,
                                                     std::vector<ViewState>* views,
                                                     const std::vector<CornerRef>& corners,
                                                     const IntrinsicsRefinementOptions& options) {
  return VisitCameraModel(type, [&](auto model) {
    return Refine<decltype(model)>(params, lower, upper, views, corners, options);
  });
}

}  // namespace ctcal
