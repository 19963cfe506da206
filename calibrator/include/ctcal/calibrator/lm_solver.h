// Levenberg-Marquardt on a ceres::Problem with the normal equations assembled on several threads.
//
// Ceres 2.1's SPARSE_NORMAL_CHOLESKY forms J^T J on one thread (InnerProductComputer), redoes its
// symbolic product at every Solve, and stores the whole Jacobian first (once more to append the LM
// diagonal). The spline calibration's J^T J is a band (the trajectory knots) with a dense border
// (the calibration blocks, coupled to every residual): here every residual block's J_b^T J_b and
// J_b^T r_b go straight into a fixed pattern of that shape on `num_threads` threads (no Jacobian
// is stored), and the step solves
//
//   [A_nn  H_nc] [d_n]   [-g_n]      A = H + diag(D) / radius,
//   [H_cn  A_cc] [d_c] = [-g_c]      D = diag(H) clamped to [min_lm_diagonal, max_lm_diagonal]
//
// by the Schur complement on the border: A_nn = L L^T (CHOLMOD, its symbolic analysis once per
// solve), S = A_cc - H_cn A_nn^-1 H_nc (dense, the border's size), d_c = S^-1 (-g_c + H_cn
// A_nn^-1 g_n), d_n = -A_nn^-1 (g_n + H_nc d_c). The damping, step acceptance, trust-region update
// and stop rules are Ceres' LEVENBERG_MARQUARDT ones without Jacobi scaling (so Ceres and this
// solver take the same steps up to rounding), on the problem's own residual blocks, manifolds
// (the Jacobians lifted by Manifold::PlusJacobian, steps applied by Manifold::Plus), parameter
// bounds (projected after Plus, as Ceres' ParameterBlock::Plus does) and loss functions (Triggs'
// correction, as Ceres' Corrector). The values live in the parameter blocks' memory throughout,
// the iteration callbacks see Ceres' IterationSummary (its gradient norms, unlike Ceres', of the
// point before an accepted step: J^T J is assembled at the start of the next iteration, none when
// a callback or the iteration limit ends the solve after the step).
#pragma once

#include <ceres/problem.h>
#include <ceres/solver.h>

#include <cstddef>
#include <memory>
#include <vector>

#include "ctcal/calibrator/marginal_covariance.h"

namespace ctcal {

// What the solves of one problem's shape share (the robust and final solve of a spline
// calibration, and its covariance): the nuisance columns' order, and the factorisation's
// ordering and symbolic analysis of that pattern, computed once; the factor itself stays
// allocated from solve to solve (the covariance frees it). Opaque (lm_solver.cpp).
class NuisanceFactorisation;
std::shared_ptr<NuisanceFactorisation> MakeNuisanceFactorisation();

// One solve, and then the border's marginal information at its final point (the covariance's, from
// the normal equations the last iteration assembled instead of another pass over the Jacobian).
class LevenbergMarquardt {
 public:
  // The problem's structure is read here: it must not change until the solver is destroyed.
  // `point_callback`: the problem's ceres::EvaluationCallback, if it has one (a ceres::Problem
  // does not expose it): called before every evaluation pass as Ceres would call it, with the
  // point already in the parameter blocks' memory (residuals such as the inertial row groups
  // identify the evaluation point by its calls).
  // `shared` (MakeNuisanceFactorisation): kept by the caller across the solves of problems of
  // one shape. A solve whose nuisance blocks are the last one's takes their column order (the
  // demo's final solve, rebuilt after the outlier gate, listed 354 of its 4429 knot blocks in
  // another order), so the factorisation's analysis carries over. Null: the solver's own.
  LevenbergMarquardt(const ceres::Solver::Options& options, const std::vector<double*>& border,
                     ceres::Problem* problem, ceres::EvaluationCallback* point_callback = nullptr,
                     std::shared_ptr<NuisanceFactorisation> shared = nullptr);
  ~LevenbergMarquardt();
  LevenbergMarquardt(const LevenbergMarquardt&) = delete;
  LevenbergMarquardt& operator=(const LevenbergMarquardt&) = delete;

  // As SolveLevenbergMarquardt. Afterwards only the normal equations at the final point are kept.
  void Solve(ceres::Solver::Summary* summary);

  // Solve() also stops, at the point it is at, once the Gauss-Newton step's predicted decrease
  // of the border alone, 1/2 d_c^T S d_c with S = H_cc - H_cn H_nn^-1 H_nc (the nuisance
  // re-optimised along the step), is below `cost_change` (> 0; 0, the default: off): the border
  // is then within sqrt(2 cost_change) of its converged value in its marginal metric, each of
  // its scalars within that many of its marginal sigmas, whatever the nuisance still crawls.
  // Judged only on a step whose damping is negligible (trust region radius >= 1e6); never
  // without a border.
  void StopOnBorderDecrease(double cost_change);

  // The border blocks the normal equations hold: those of `border` that are free and read by a
  // residual block, in its order.
  const std::vector<double*>& Border() const;

  // What the solver holds for its normal equations (H on every thread and the step's dense
  // border columns), and what a Jacobian of the problem's residual blocks holds (Ceres stores one;
  // this solver does not): for a caller choosing the solver by memory.
  std::size_t NormalEquationsBytes() const;
  std::size_t JacobianBytes() const;
  // What ceres::Solve (SPARSE_NORMAL_CHOLESKY) holds for the same problem besides the common
  // factorisation: the Jacobian and J^T J, each in compressed rows.
  std::size_t CeresBytes() const;

  // After Solve (one that ended by a tolerance, not by a callback or the iteration limit right
  // after a step: the normal equations there were never assembled): the information of the
  // Border() blocks at the final point with every other free
  // block marginalised, H_cc - H_cn H_nn^-1 H_nc of H = J^T J of every residual block (priors
  // included), as ComputeMarginalInformation computes it (information, nuisance_dimension,
  // nuisance_damping; names and units are the caller's). Once: it takes the normal equations over.
  // Throws std::logic_error before Solve, std::runtime_error when H_nn cannot be factored.
  MarginalInformation MarginalizeToBorder();

  class Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

// Solves `problem` as ceres::Solve would with `options` (TRUST_REGION, LEVENBERG_MARQUARDT,
// jacobi_scaling = false; the linear solver settings are ignored), the parameter blocks `border`
// (those of the problem among them, free ones only) as the dense border of the normal equations.
// Fills the summary's costs, iterations, termination type, message, counts and times. Throws
// std::invalid_argument for options it does not implement.
void SolveLevenbergMarquardt(const ceres::Solver::Options& options,
                             const std::vector<double*>& border, ceres::Problem* problem,
                             ceres::Solver::Summary* summary,
                             ceres::EvaluationCallback* point_callback = nullptr);

}  // namespace ctcal
