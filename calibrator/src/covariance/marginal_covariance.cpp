#include "ctcal/calibrator/marginal_covariance.h"

#include <ceres/cost_function.h>
#include <ceres/crs_matrix.h>

#include <Eigen/CholmodSupport>
#include <Eigen/Eigenvalues>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <future>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include "../solver/normal_equations.h"
#include "../solver/parameter_order.h"

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
  const std::vector<double*> all_blocks = ParameterBlocksInResidualOrder(problem);
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
  out.information = MarginalizeNuisance(normal.get(), &out.nuisance_damping);
  return out;
}

void AddCalibrationInformation(ceres::Problem& problem, const std::vector<CalibrationBlock>& calib,
                               const std::vector<ceres::ResidualBlockId>& residual_blocks,
                               MarginalInformation* info, double weight) {
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
  info->information += weight * Eigen::MatrixXd(SparseColMajor(J.transpose()) * J);
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
  // A null direction through a lens model's projection parameter (Mei's xi, the double sphere's
  // xi and alpha, EUCM's alpha and beta, loading above the threshold) carries the camera's other
  // intrinsics with it, even with loadings below the threshold: the projection parameter trades
  // with the focal length and the distortion (xi with f and k1), its guess is good to one decimal,
  // and the estimate sits along the direction wherever the guess put it, which the pseudo-inverse
  // leaves out of the sigmas. Omni-radtan's k2 loads 0.06-0.07 on the xi-k1-focal direction and
  // sat at 4-10.8 "sigma" (docs/initialisation.md). Such an intrinsic is undetermined when a
  // drift of kProjectionNullDrift unit-scaled steps along the direction moves it by more than its
  // sigma (seeds 38 and 58 drifted 83 and 160: xi 0.074 and 0.136 off). Other null directions
  // keep the loading rule alone: a yaw's gauges and a pinhole camera's weakly seen distortion
  // load 0.003-0.03 on well-determined parameters (a principal point, an aux gyro's scale).
  constexpr double kProjectionNullDrift = 200.0;
  // The camera of an intrinsic parameter ("" for others) and whether it is a projection
  // parameter (every model's intrinsics end with fu, fv, pu, pv).
  std::map<std::string, int> intrinsics_of;
  const auto parse = [&](int i, int* index) -> std::string {
    const std::string& name = info.names[static_cast<std::size_t>(i)];
    const std::size_t dot = name.find('.');
    if (dot == std::string::npos)
      return "";
    if (name.compare(dot, 12, ".intrinsics[") == 0) {
      *index = std::atoi(name.c_str() + dot + 12);
      return name.substr(0, dot);
    }
    *index = -1;
    return name.compare(dot, 19, ".distortion_coeffs[") == 0 ? name.substr(0, dot) : "";
  };
  for (int i = 0; i < c; ++i) {
    int index = -1;
    const std::string camera = parse(i, &index);
    if (!camera.empty() && index >= 0)
      intrinsics_of[camera] = std::max(intrinsics_of[camera], index + 1);
  }
  for (const int k : out.null_directions) {
    std::set<std::string> lenses;
    for (int i = 0; i < c; ++i) {
      int index = -1;
      const std::string camera = parse(i, &index);
      if (!camera.empty() && index >= 0 && index < intrinsics_of[camera] - 4 &&
          std::abs(out.scaled_eigenvectors(i, k)) > options.loading_threshold)
        lenses.insert(camera);
    }
    for (int i = 0; i < c && !lenses.empty(); ++i) {
      int index = -1;
      const double shift = kProjectionNullDrift * out.scaled_eigenvectors(i, k);
      if (lenses.count(parse(i, &index)) > 0 && shift * shift > scaled_cov(i, i))
        out.undetermined[static_cast<std::size_t>(i)] = true;
    }
  }
  out.covariance = unit.asDiagonal() * scaled_cov * unit.asDiagonal();
  for (int i = 0; i < c; ++i) {
    out.sigma(i) = out.undetermined[i] ? std::numeric_limits<double>::infinity()
                                       : std::sqrt(std::max(out.covariance(i, i), 0.0));
  }
  return out;
}

}  // namespace ctcal
