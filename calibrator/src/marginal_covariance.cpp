#include "ctcal/calibrator/marginal_covariance.h"

#include <ceres/cost_function.h>
#include <ceres/crs_matrix.h>

#include <Eigen/CholmodSupport>
#include <Eigen/Eigenvalues>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <future>
#include <limits>
#include <memory>
#include <stdexcept>
#include <unordered_map>
#include <unordered_set>

#include "normal_equations.h"

namespace ctcal {
namespace {

using SparseRowMajor = Eigen::SparseMatrix<double, Eigen::RowMajor, int>;
using SparseColMajor = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

SparseRowMajor ToEigen(const ceres::CRSMatrix& crs) {
  return Eigen::Map<const SparseRowMajor>(crs.num_rows, crs.num_cols,
                                          static_cast<int>(crs.values.size()), crs.rows.data(),
                                          crs.cols.data(), crs.values.data());
}

}  // namespace

MarginalInformation ComputeMarginalInformation(
    ceres::Problem& problem, const std::vector<CalibrationBlock>& calib,
    const std::vector<ceres::ResidualBlockId>& residual_blocks, int threads) {
  MarginalInformation out;
  std::unordered_set<const double*> calib_set;
  std::vector<double*> calib_blocks;
  std::vector<double> units;
  for (const CalibrationBlock& b : calib) {
    if (!problem.HasParameterBlock(b.values) || problem.IsParameterBlockConstant(b.values)) {
      continue;
    }
    const int dim = problem.ParameterBlockTangentSize(b.values);
    if (static_cast<int>(b.names.size()) != dim || static_cast<int>(b.unit.size()) != dim) {
      throw std::logic_error("calibration block '" + (b.names.empty() ? "?" : b.names[0]) +
                             "': names/units do not match its tangent size " + std::to_string(dim));
    }
    calib_set.insert(b.values);
    calib_blocks.push_back(b.values);
    out.names.insert(out.names.end(), b.names.begin(), b.names.end());
    units.insert(units.end(), b.unit.begin(), b.unit.end());
  }
  out.unit = Eigen::Map<const Eigen::VectorXd>(units.data(), static_cast<int>(units.size()));

  // Nuisance columns first, calibration last, so the Schur complement is the bottom-right block.
  std::vector<double*> all_blocks;
  problem.GetParameterBlocks(&all_blocks);
  ceres::Problem::EvaluateOptions eval;
  for (double* block : all_blocks) {
    if (calib_set.count(block) || problem.IsParameterBlockConstant(block))
      continue;
    eval.parameter_blocks.push_back(block);
    out.nuisance_dimension += problem.ParameterBlockTangentSize(block);
  }
  const int nuisance_blocks = static_cast<int>(eval.parameter_blocks.size());
  eval.parameter_blocks.insert(eval.parameter_blocks.end(), calib_blocks.begin(),
                               calib_blocks.end());
  std::vector<ceres::ResidualBlockId> all_residuals = residual_blocks;
  if (all_residuals.empty())
    problem.GetResidualBlocks(&all_residuals);

  // The pattern of H_nn from the parameter blocks of every residual block.
  std::unordered_map<const double*, int> column_block;
  std::vector<int> tangent;
  for (double* block : eval.parameter_blocks) {
    column_block.emplace(block, static_cast<int>(tangent.size()));
    tangent.push_back(problem.ParameterBlockTangentSize(block));
  }
  std::unique_ptr<NormalEquations> normal;
  {
    std::vector<std::vector<int>> blocks_of(all_residuals.size());
    std::vector<double*> blocks;
    for (std::size_t r = 0; r < all_residuals.size(); ++r) {
      problem.GetParameterBlocksForResidualBlock(all_residuals[r], &blocks);
      for (const double* b : blocks) {
        const auto it = column_block.find(b);
        if (it != column_block.end())
          blocks_of[r].push_back(it->second);
      }
    }
    normal = std::make_unique<NormalEquations>(tangent, nuisance_blocks, blocks_of);
  }

  // H accumulated over chunks of residual blocks: the whole Jacobian of a long recording would
  // hold hundreds of MB at once. A chunk holds at most kChunkValues Jacobian values (16 MB;
  // ~2000 camera-frame or 5000 IMU-sample blocks, ~150 compressed inertial blocks of 1 kHz data).
  const int n = out.nuisance_dimension;
  const int c = static_cast<int>(units.size());
  // With threads > 1 a chunk's J^T J is summed on a second thread while the next chunk is
  // evaluated (Problem::Evaluate is not re-entrant): the same sums in the same order, and at most
  // two chunks' Jacobians alive.
  constexpr std::size_t kChunkValues = std::size_t{1} << 21;
  const auto jacobian_values = [&](ceres::ResidualBlockId id) {
    const ceres::CostFunction* f = problem.GetCostFunctionForResidualBlock(id);
    std::size_t cols = 0;
    for (const int size : f->parameter_block_sizes())
      cols += static_cast<std::size_t>(size);
    return cols * static_cast<std::size_t>(f->num_residuals());
  };
  std::future<void> summing;
  for (std::size_t first = 0, last = 0; first < all_residuals.size(); first = last) {
    std::size_t values = 0;
    for (last = first; last < all_residuals.size() && (last == first || values < kChunkValues);
         ++last)
      values += jacobian_values(all_residuals[last]);
    eval.residual_blocks.assign(all_residuals.begin() + static_cast<std::ptrdiff_t>(first),
                                all_residuals.begin() + static_cast<std::ptrdiff_t>(last));
    auto rows = std::make_shared<std::vector<int>>();
    for (std::size_t r = first; r < last; ++r)
      rows->push_back(problem.GetCostFunctionForResidualBlock(all_residuals[r])->num_residuals());
    double cost = 0.0;
    auto crs = std::make_shared<ceres::CRSMatrix>();
    const bool evaluated = problem.Evaluate(eval, &cost, nullptr, nullptr, crs.get());
    if (summing.valid())
      summing.get();
    if (!evaluated || !std::isfinite(cost)) {
      throw std::runtime_error(
          "covariance: the problem cannot be evaluated at the solution "
          "(non-finite residuals or Jacobians)");
    }
    if (crs->num_cols != n + c)
      throw std::logic_error("covariance: unexpected Jacobian width");
    NormalEquations* ne = normal.get();
    if (threads > 1)
      summing = std::async(std::launch::async, [ne, crs, rows] { ne->Add(*crs, *rows); });
    else
      ne->Add(*crs, *rows);
  }
  if (summing.valid())
    summing.get();
  const Eigen::MatrixXd H_cc = normal->H_cc();
  if (n == 0) {
    out.information = H_cc;
    return out;
  }
  // A nuisance state no residual touches (a trajectory or bias knot beyond the samples the data
  // selection kept) has a zero diagonal, hence (H is PSD) a zero row and column: it carries no
  // information and couples to nothing, so it is left out exactly instead of being damped.
  SparseColMajor H_nn;
  Eigen::MatrixXd H_nc;
  {
    SparseColMajor& L = normal->H_nn();
    std::vector<int> keep(static_cast<std::size_t>(n), -1);
    int m = 0;
    for (int i = 0; i < n; ++i) {
      if (L.valuePtr()[L.outerIndexPtr()[i]] > 0.0)  // the diagonal leads its column
        keep[static_cast<std::size_t>(i)] = m++;
    }
    if (m == n) {
      // Every state touched (the usual case): no copy.
      H_nn.swap(L);
      H_nc.swap(normal->H_nc());
    } else {
      std::vector<Eigen::Triplet<double>> entries;
      for (int j = 0; j < n; ++j) {
        if (keep[static_cast<std::size_t>(j)] < 0)
          continue;
        for (SparseColMajor::InnerIterator it(L, j); it; ++it) {
          if (keep[static_cast<std::size_t>(it.row())] >= 0)
            entries.emplace_back(keep[static_cast<std::size_t>(it.row())],
                                 keep[static_cast<std::size_t>(j)], it.value());
        }
      }
      H_nn.resize(m, m);
      H_nn.setFromTriplets(entries.begin(), entries.end());
      H_nc.resize(m, c);
      for (int i = 0; i < n; ++i) {
        if (keep[static_cast<std::size_t>(i)] >= 0)
          H_nc.row(keep[static_cast<std::size_t>(i)]) = normal->H_nc().row(i);
      }
    }
    normal.reset();
  }
  const int m = static_cast<int>(H_nn.rows());

  // A combination of touched nuisance states the data do not determine makes H_nn singular;
  // damping it by a tiny fraction of its scale marginalises it with a flat prior instead of
  // failing, and the amount is reported. Only H_nn's lower triangle is stored (and read).
  double max_diag = 0.0;
  for (int i = 0; i < m; ++i)
    max_diag = std::max(max_diag, H_nn.valuePtr()[H_nn.outerIndexPtr()[i]]);
  Eigen::CholmodSupernodalLLT<SparseColMajor, Eigen::Lower> llt;
  // A failed attempt is handled (and reported) by the damping below; CHOLMOD's own message would
  // only repeat it without context, so it stays silent (print level 0) and info() is checked.
  llt.cholmod().print = 0;
  llt.compute(H_nn);
  for (const double relative : {1e-12, 1e-9, 1e-6}) {
    if (llt.info() == Eigen::Success)
      break;
    SparseColMajor damped = H_nn;
    for (int i = 0; i < m; ++i)
      damped.valuePtr()[damped.outerIndexPtr()[i]] += relative * std::max(max_diag, 1.0);
    llt.compute(damped);
    out.nuisance_damping = relative;
  }
  if (llt.info() != Eigen::Success)
    throw std::runtime_error("covariance: the nuisance information cannot be factored");
  H_nn = SparseColMajor();  // the factor holds what the solve needs
  const Eigen::MatrixXd X = llt.solve(H_nc);
  out.information = H_cc - H_nc.transpose() * X;
  out.information = 0.5 * (out.information + out.information.transpose()).eval();
  return out;
}

void AddCalibrationInformation(ceres::Problem& problem, const std::vector<CalibrationBlock>& calib,
                               const std::vector<ceres::ResidualBlockId>& residual_blocks,
                               MarginalInformation* info) {
  if (residual_blocks.empty())
    return;
  ceres::Problem::EvaluateOptions eval;
  std::unordered_set<const double*> calib_set;
  for (const CalibrationBlock& b : calib) {
    if (problem.HasParameterBlock(b.values) && !problem.IsParameterBlockConstant(b.values)) {
      eval.parameter_blocks.push_back(b.values);
      calib_set.insert(b.values);
    }
  }
  for (const ceres::ResidualBlockId id : residual_blocks) {
    std::vector<double*> blocks;
    problem.GetParameterBlocksForResidualBlock(id, &blocks);
    for (double* b : blocks) {
      if (!calib_set.count(b) && !problem.IsParameterBlockConstant(b))
        throw std::logic_error("covariance: a prior touches a nuisance block");
    }
  }
  eval.residual_blocks = residual_blocks;
  double cost = 0.0;
  ceres::CRSMatrix crs;
  if (!problem.Evaluate(eval, &cost, nullptr, nullptr, &crs) || !std::isfinite(cost))
    throw std::runtime_error("covariance: the priors cannot be evaluated at the solution");
  const int c = static_cast<int>(info->information.rows());
  if (crs.num_cols != c)
    throw std::logic_error("covariance: prior Jacobian width differs from the information");
  const SparseRowMajor J = ToEigen(crs);
  info->information += Eigen::MatrixXd(SparseColMajor(J.transpose()) * J);
}

CalibrationCovariance InvertInformation(const MarginalInformation& info,
                                        const CovarianceOptions& options) {
  const int c = static_cast<int>(info.information.rows());
  CalibrationCovariance out;
  out.covariance = Eigen::MatrixXd::Zero(c, c);
  out.sigma = Eigen::VectorXd::Zero(c);
  out.undetermined.assign(c, false);
  if (c == 0)
    return out;

  const Eigen::VectorXd& unit = info.unit;
  const Eigen::MatrixXd scaled = unit.asDiagonal() * info.information * unit.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(scaled);
  out.scaled_eigenvalues = eig.eigenvalues();
  out.scaled_eigenvectors = eig.eigenvectors();
  const double largest = std::max(out.scaled_eigenvalues.maxCoeff(), 0.0);

  Eigen::MatrixXd scaled_cov = Eigen::MatrixXd::Zero(c, c);
  for (int k = 0; k < c; ++k) {
    const double lambda = out.scaled_eigenvalues(k);
    const Eigen::VectorXd v = out.scaled_eigenvectors.col(k);
    if (!(lambda > options.null_relative_threshold * largest) || largest == 0.0) {
      out.null_directions.push_back(k);
      for (int i = 0; i < c; ++i) {
        if (std::abs(v(i)) > options.loading_threshold)
          out.undetermined[i] = true;
      }
      continue;
    }
    scaled_cov += (1.0 / lambda) * v * v.transpose();
  }
  out.covariance = unit.asDiagonal() * scaled_cov * unit.asDiagonal();
  for (int i = 0; i < c; ++i) {
    out.sigma(i) = out.undetermined[i] ? std::numeric_limits<double>::infinity()
                                       : std::sqrt(std::max(out.covariance(i, i), 0.0));
  }
  return out;
}

}  // namespace ctcal
