// One segment of a uniform cumulative B-spline on a Lie group (So3Group or Se3Group, lie_groups.h):
// value, body velocity / acceleration / jerk, and the analytic Jacobians of the first three with
// respect to the N local knots. Everything else (So3Spline, the joint SE(3) spline) wraps this.
//
// Segment with knots X_0 .. X_{N-1} and cumulative basis lambda_j (bspline_basis.h):
//   d_j = Log(X_{j-1}^-1 X_j),  A_j = Exp(lambda_j d_j),  X(t) = X_0 A_1 ... A_{N-1}.
// Body velocity w = (X^-1 dX/dt)^vee by the O(N) recursion of Sommer et al. (CVPR 2020):
//   w_1 = 0,  w_{j+1} = Ad(A_j^-1) w_j + lambda'_j d_j,                         w = w_N,
//   a_{j+1} = Ad(A_j^-1) a_j + lambda''_j d_j + lambda'_j ad(w_{j+1}) d_j,       acc = a_N,
//   e_{j+1} = Ad(A_j^-1) e_j + lambda'''_j d_j
//             + ad(lambda'_j Ad(A_j^-1) a_j + lambda''_j w_{j+1} + lambda'_j a_{j+1}) d_j,  jerk =
//             e_N.
// Jacobians are with respect to the right perturbation of every knot, X_i = X_i_hat Exp(delta_i),
// and give the right perturbation of the value, X = X_hat Exp(J delta). With P_j =
// A_{j+1}..A_{N-1}:
//   dX/dd_j = Ad(P_j^-1) lambda_j Jr(lambda_j d_j),
//   dw/dd_j = Ad(P_j^-1) W_j,   W_j = lambda_j Ad(A_j^-1) ad(w_j) Jl(lambda_j d_j) + lambda'_j I,
//   da/dd_j = Ad(P_j^-1) (lambda_j Ad(A_j^-1) ad(a_j) Jl(lambda_j d_j) + lambda''_j I
//             + lambda'_j ad(w_{j+1})) + K_j W_j,
//   K_j = S_j - lambda'_j Ad(P_j^-1) ad(d_j),  S_{N-1} = 0,  S_{j-1} = K_j Ad(A_j^-1)  (backward,
//   O(N)), dd_j/ddelta_j = Jr^-1(d_j),  dd_j/ddelta_{j-1} = -Jl^-1(d_j),  dX/ddelta_0 +=
//   Ad(P_0^-1).
// Derivations: docs/spline.md.
#pragma once

#include <array>

#include "ctcal/spline/bspline_basis.h"
#include "ctcal/spline/lie_groups.h"

namespace ctcal {

template <template <typename> class Group, int N>
struct CumulativeLieSegment {
  static_assert(N >= 2, "a B-spline needs order >= 2");

  template <typename T>
  struct Output {
    typename Group<T>::Element value;
    typename Group<T>::Tangent velocity = Group<T>::Tangent::Zero();
    typename Group<T>::Tangent acceleration = Group<T>::Tangent::Zero();
    typename Group<T>::Tangent jerk = Group<T>::Tangent::Zero();
  };

  // One Dof x Dof block per local knot (tangent of the output x tangent of knot i).
  template <typename T>
  using KnotJacobians = std::array<typename Group<T>::Matrix, N>;

  // Optional outputs; nullptr = not computed.
  template <typename T>
  struct Jacobians {
    KnotJacobians<T>* J_value_knots = nullptr;
    KnotJacobians<T>* J_velocity_knots = nullptr;
    KnotJacobians<T>* J_acceleration_knots = nullptr;
  };

  // knots[i] points at the stored parameters of local knot i (Group::kAmbientSize each).
  // max_derivative (0..3): the highest time derivative wanted in `out`; the value is computed when
  // want_value or its Jacobian is requested.
  template <typename T>
  static void Evaluate(const T* const* knots, const T& u, const T& inv_dt, int max_derivative,
                       bool want_value, Output<T>* out, const Jacobians<T>* J = nullptr) {
    using G = Group<T>;
    using Tangent = typename G::Tangent;
    using Matrix = typename G::Matrix;
    using Element = typename G::Element;
    const bool jac_value = J != nullptr && J->J_value_knots != nullptr;
    const bool jac_velocity = J != nullptr && J->J_velocity_knots != nullptr;
    const bool jac_acceleration = J != nullptr && J->J_acceleration_knots != nullptr;
    int order = max_derivative;
    if (jac_velocity && order < 1)
      order = 1;
    if (jac_acceleration && order < 2)
      order = 2;

    std::array<std::array<T, N>, kMaxDerivative + 1> lambda;
    CumulativeBasis<N>::Evaluate(u, inv_dt, order, &lambda);

    // Index 0 of the per-difference arrays is unused: d_j, A_j exist for j = 1 .. N-1.
    std::array<Tangent, N> d;
    std::array<Element, N> A;
    std::array<Matrix, N> Ad_A_inv;
    const bool any_jacobian = jac_value || jac_velocity || jac_acceleration;
    for (int j = 1; j < N; ++j) {
      d[j] = G::LogBetween(knots[j - 1], knots[j]);
      A[j] = G::Exp(lambda[0][j] * d[j]);
      if (order >= 1 || any_jacobian)
        Ad_A_inv[j] = G::Adjoint(G::Inverse(A[j]));
    }

    if (want_value || jac_value) {
      Element X = G::FromParameters(knots[0]);
      for (int j = 1; j < N; ++j)
        X = G::Multiply(X, A[j]);
      out->value = X;
    }

    // Forward recursion; w_pre[j] / a_pre[j] are w_j / a_j (before segment j), w_post[j] = w_{j+1}.
    std::array<Tangent, N> w_pre, a_pre, w_post;
    Tangent w = Tangent::Zero();
    Tangent a = Tangent::Zero();
    Tangent e = Tangent::Zero();
    if (order >= 1) {
      for (int j = 1; j < N; ++j) {
        w_pre[j] = w;
        a_pre[j] = a;
        w = Ad_A_inv[j] * w + lambda[1][j] * d[j];
        w_post[j] = w;
        if (order >= 2) {
          const Tangent a_rotated = Ad_A_inv[j] * a;
          a = a_rotated + lambda[2][j] * d[j] + lambda[1][j] * (G::SmallAdjoint(w) * d[j]);
          if (order >= 3) {
            const Tangent k = lambda[1][j] * a_rotated + lambda[2][j] * w + lambda[1][j] * a;
            e = Ad_A_inv[j] * e + lambda[3][j] * d[j] + G::SmallAdjoint(k) * d[j];
          }
        }
      }
    }
    out->velocity = w;
    out->acceleration = a;
    out->jerk = e;
    if (!any_jacobian)
      return;

    // Ad(P_j^-1), suffix products: P_{N-1} = I, Ad(P_{j-1}^-1) = Ad(P_j^-1) Ad(A_j^-1).
    std::array<Matrix, N> Ad_P_inv;
    Ad_P_inv[N - 1] = Matrix::Identity();
    for (int j = N - 1; j >= 1; --j)
      Ad_P_inv[j - 1] = Ad_P_inv[j] * Ad_A_inv[j];
    std::array<Matrix, N> Jr_inv_d, Jl_inv_d, Jl_lambda_d;
    for (int j = 1; j < N; ++j) {
      Jr_inv_d[j] = G::RightJacobianInv(d[j]);
      Jl_inv_d[j] = G::RightJacobianInv(-d[j]);
      if (jac_velocity || jac_acceleration)
        Jl_lambda_d[j] = G::RightJacobian(-lambda[0][j] * d[j]);
    }

    // J_q_d[j]: Jacobian of quantity q with respect to d_j; the chain to the knots is shared.
    std::array<Matrix, N> J_q_d;
    const auto chain_to_knots = [&](const Matrix* J_q_x0, KnotJacobians<T>* J_q_knots) {
      for (int i = 0; i < N; ++i) {
        Matrix Ji = J_q_x0 != nullptr && i == 0 ? *J_q_x0 : Matrix::Zero();
        if (i >= 1)
          Ji += J_q_d[i] * Jr_inv_d[i];
        if (i + 1 < N)
          Ji -= J_q_d[i + 1] * Jl_inv_d[i + 1];
        (*J_q_knots)[i] = Ji;
      }
    };

    if (jac_value) {
      for (int j = 1; j < N; ++j) {
        J_q_d[j] = Ad_P_inv[j] * (lambda[0][j] * G::RightJacobian(lambda[0][j] * d[j]));
      }
      chain_to_knots(&Ad_P_inv[0], J->J_value_knots);
    }

    std::array<Matrix, N> W;  // d w_{j+1} / d d_j
    if (jac_velocity || jac_acceleration) {
      for (int j = 1; j < N; ++j) {
        W[j] = lambda[0][j] * (Ad_A_inv[j] * G::SmallAdjoint(w_pre[j]) * Jl_lambda_d[j]);
        W[j].diagonal().array() += lambda[1][j];
      }
    }
    if (jac_velocity) {
      for (int j = 1; j < N; ++j)
        J_q_d[j] = Ad_P_inv[j] * W[j];
      chain_to_knots(nullptr, J->J_velocity_knots);
    }
    if (jac_acceleration) {
      Matrix S = Matrix::Zero();
      for (int j = N - 1; j >= 1; --j) {
        const Matrix K = S - lambda[1][j] * (Ad_P_inv[j] * G::SmallAdjoint(d[j]));
        Matrix local = lambda[0][j] * (Ad_A_inv[j] * G::SmallAdjoint(a_pre[j]) * Jl_lambda_d[j]) +
                       lambda[1][j] * G::SmallAdjoint(w_post[j]);
        local.diagonal().array() += lambda[2][j];
        J_q_d[j] = Ad_P_inv[j] * local + K * W[j];
        S = K * Ad_A_inv[j];
      }
      chain_to_knots(nullptr, J->J_acceleration_knots);
    }
  }
};

}  // namespace ctcal
