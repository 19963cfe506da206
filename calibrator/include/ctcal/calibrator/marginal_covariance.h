// The uncertainty of the calibration parameters with the trajectory (and every other nuisance
// state) marginalised out, and the directions the data leave undetermined.
//
// Why not ceres::Covariance: its SPARSE_QR path fails on rank-deficient problems, and a degenerate
// motion makes the calibration rank-deficient by design; we want sigma = inf in exactly the null
// directions and finite sigmas everywhere else, plus the directions themselves for the
// observability report.
//
//   H = J^T J (whitened Jacobian at the solution, tangent space of every manifold)
//     = [H_nn H_nc; H_cn H_cc]       n: nuisance blocks, c: calibration blocks
//   S = H_cc - H_cn H_nn^-1 H_nc     (Schur complement, H_nn factored with CHOLMOD)
//
// S is the information of the calibration parameters alone. It is compared across parameters of
// different units after scaling by a physical unit per parameter (1 deg, 1 cm, 1 ms, 1 px, 1e-3),
// so that "small eigenvalue" means the same for a rotation and a focal length.
#pragma once

#include <ceres/problem.h>

#include <Eigen/Core>
#include <string>
#include <vector>

namespace ctcal {

// A calibration quantity as Ceres sees it: one parameter block, one name and one comparison unit
// per tangent dimension.
struct CalibrationBlock {
  double* values = nullptr;
  std::vector<std::string> names;
  std::vector<double> unit;
};

struct MarginalInformation {
  Eigen::MatrixXd information;  // tangent-space information of the calibration blocks
  std::vector<std::string> names;
  Eigen::VectorXd unit;
  int nuisance_dimension = 0;
  // Relative diagonal damping that had to be added to H_nn to factor it (0 when it was positive
  // definite); non-zero means some nuisance state was not determined by the data.
  double nuisance_damping = 0.0;
};

// Builds J^T J of `residual_blocks` (all residual blocks of the problem when empty) at the current
// parameter values and marginalises every non-constant parameter block that is not in `calib`.
// Calibration blocks that are constant in the problem are skipped (they are not estimated).
// Throws std::runtime_error when the problem cannot be evaluated (non-finite residuals).
// threads > 1: the Jacobian's chunks are evaluated and multiplied on two threads (same result).
MarginalInformation ComputeMarginalInformation(
    ceres::Problem& problem, const std::vector<CalibrationBlock>& calib,
    const std::vector<ceres::ResidualBlockId>& residual_blocks = {}, int threads = 1);

// Adds J^T J of `residual_blocks` that depend on calibration blocks only (the priors) to
// info->information. Since such terms touch H_cc alone, the Schur complement of data + priors is
// the data's plus theirs: one factorisation of H_nn serves both (throws std::runtime_error when
// the residuals cannot be evaluated, std::logic_error when one touches a nuisance block).
// weight -1 takes them out of an information that holds them.
void AddCalibrationInformation(ceres::Problem& problem, const std::vector<CalibrationBlock>& calib,
                               const std::vector<ceres::ResidualBlockId>& residual_blocks,
                               MarginalInformation* info, double weight = 1.0);

struct CalibrationCovariance {
  Eigen::MatrixXd covariance;  // tangent space; pseudo-inverse on the determined subspace
  Eigen::VectorXd sigma;       // sqrt(diag(covariance)); +inf where undetermined
  std::vector<bool> undetermined;
  // Eigen-decomposition of the unit-scaled information (ascending eigenvalues, unit-norm columns).
  Eigen::VectorXd scaled_eigenvalues;
  Eigen::MatrixXd scaled_eigenvectors;
  std::vector<int> null_directions;  // column indices of scaled_eigenvectors
};

struct CovarianceOptions {
  // An eigenvalue below this fraction of the largest is a null direction.
  double null_relative_threshold = 1e-9;
  // A parameter whose loading (component of the unit null eigenvector) exceeds this is
  // undetermined.
  double loading_threshold = 0.1;
};

// Inverts the information on its determined subspace and marks the undetermined parameters.
CalibrationCovariance InvertInformation(const MarginalInformation& info,
                                        const CovarianceOptions& options = {});

}  // namespace ctcal
