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

namespace ctcal {
namespace {

using SparseRowMajor = Eigen::SparseMatrix<double, Eigen::RowMajor, int>;
using SparseColMajor = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

SparseRowMajor ToEigen(const ceres::CRSMatrix& crs) {
  return Eigen::Map<const SparseRowMajor>(crs.num_rows, crs.num_cols,
                                          static_cast<int>(crs.values.size()), crs.rows.data(),
                                          crs.cols.data(), crs.values.data());
}

// H = J^T J split as [H_nn H_nc; H_cn H_cc], accumulated in place residual block by residual
// block. H_nn is held as its lower triangle in a sparse pattern fixed once from the residual
// blocks' parameter blocks (columns, then rows, in the order of the parameter blocks), H_nc and
// H_cc densely. Adding a chunk's J^T J to a growing Eigen sparse matrix (`H += Jt J`) held the old
// sum, the new sum and the product at once: three copies of H_nn, the peak of a 10 min 1 kHz run
// (docs/performance.md, step 7). Here every block's J_b^T J_b (dense, rows x cols^2) is scattered
// into the one H_nn.
class NormalEquations {
 public:
  // tangent: tangent size of each column block in column order; the first `nuisance_blocks` are
  // the nuisance states. blocks_of: for every residual block, its column blocks (any order).
  NormalEquations(std::vector<int> tangent, int nuisance_blocks,
                  const std::vector<std::vector<int>>& blocks_of)
      : tangent_(std::move(tangent)), nb_(nuisance_blocks) {
    offset_.resize(tangent_.size() + 1, 0);
    for (std::size_t b = 0; b < tangent_.size(); ++b)
      offset_[b + 1] = offset_[b] + tangent_[b];
    n_ = offset_[static_cast<std::size_t>(nb_)];
    c_ = offset_.back() - n_;
    block_of_col_.resize(static_cast<std::size_t>(offset_.back()));
    for (std::size_t b = 0; b < tangent_.size(); ++b)
      std::fill(block_of_col_.begin() + offset_[b], block_of_col_.begin() + offset_[b + 1],
                static_cast<int>(b));
    // Row blocks below the diagonal block of every nuisance column block.
    below_.resize(static_cast<std::size_t>(nb_));
    for (const std::vector<int>& blocks : blocks_of) {
      for (const int j : blocks) {
        for (const int i : blocks) {
          if (j < nb_ && i < nb_ && i > j)
            below_[static_cast<std::size_t>(j)].push_back(i);
        }
      }
    }
    below_start_.resize(static_cast<std::size_t>(nb_));
    std::int64_t nnz = 0;
    for (int j = 0; j < nb_; ++j) {
      std::vector<int>& rows = below_[static_cast<std::size_t>(j)];
      std::sort(rows.begin(), rows.end());
      rows.erase(std::unique(rows.begin(), rows.end()), rows.end());
      rows.shrink_to_fit();
      std::vector<int>& start = below_start_[static_cast<std::size_t>(j)];
      start.resize(rows.size());
      int below = 0;
      for (std::size_t k = 0; k < rows.size(); ++k) {
        start[k] = below;
        below += tangent_[static_cast<std::size_t>(rows[k])];
      }
      const int t = tangent_[static_cast<std::size_t>(j)];
      nnz += static_cast<std::int64_t>(t) * below + t * (t + 1) / 2;
    }
    if (nnz > std::numeric_limits<int>::max())
      throw std::runtime_error("covariance: the nuisance information has too many entries");
    // Column q of block j: the rows q..t-1 of block j (its diagonal first), then every block below.
    H_nn_.resize(n_, n_);
    H_nn_.resizeNonZeros(static_cast<Eigen::Index>(nnz));
    int* outer = H_nn_.outerIndexPtr();
    int* inner = H_nn_.innerIndexPtr();
    int k = 0;
    for (int j = 0; j < nb_; ++j) {
      const int t = tangent_[static_cast<std::size_t>(j)];
      const int off = offset_[static_cast<std::size_t>(j)];
      for (int q = 0; q < t; ++q) {
        outer[off + q] = k;
        for (int p = q; p < t; ++p)
          inner[k++] = off + p;
        for (const int i : below_[static_cast<std::size_t>(j)]) {
          for (int p = 0; p < tangent_[static_cast<std::size_t>(i)]; ++p)
            inner[k++] = offset_[static_cast<std::size_t>(i)] + p;
        }
      }
    }
    outer[n_] = k;
    std::fill(H_nn_.valuePtr(), H_nn_.valuePtr() + nnz, 0.0);
    H_nc_ = Eigen::MatrixXd::Zero(n_, c_);
    H_cc_ = Eigen::MatrixXd::Zero(c_, c_);
  }

  int n() const { return n_; }
  int c() const { return c_; }

  // Adds J^T J of a Jacobian (Problem::Evaluate's CRS over the columns above) whose consecutive
  // row groups of `rows_per_block` are the residual blocks.
  void Add(const ceres::CRSMatrix& J, const std::vector<int>& rows_per_block) {
    int r = 0;
    for (const int m : rows_per_block) {
      if (m > 0)
        AddBlock(J, r, m);
      r += m;
    }
  }

  SparseColMajor& H_nn() { return H_nn_; }
  Eigen::MatrixXd& H_nc() { return H_nc_; }
  const Eigen::MatrixXd& H_cc() const { return H_cc_; }

 private:
  struct Run {
    int block;  // column block
    int first;  // its first entry in the residual block's row
  };

  // Residual block of rows [r, r + m): every row holds the same columns (Ceres writes all of a
  // residual block's non-constant parameter blocks into each of its rows).
  void AddBlock(const ceres::CRSMatrix& J, int r, int m) {
    const int begin = J.rows[static_cast<std::size_t>(r)];
    const int k = J.rows[static_cast<std::size_t>(r) + 1] - begin;
    if (J.rows[static_cast<std::size_t>(r + m)] - begin != m * k)
      throw std::logic_error("covariance: a residual block's rows differ in their columns");
    if (k == 0)
      return;
    runs_.clear();
    for (int e = 0; e < k;) {
      const int col = J.cols[static_cast<std::size_t>(begin + e)];
      const int b = block_of_col_[static_cast<std::size_t>(col)];
      const int t = tangent_[static_cast<std::size_t>(b)];
      if (col != offset_[static_cast<std::size_t>(b)] || e + t > k ||
          J.cols[static_cast<std::size_t>(begin + e + t - 1)] != col + t - 1)
        throw std::logic_error("covariance: a parameter block's columns are not contiguous");
      runs_.push_back(Run{b, e});
      e += t;
    }
    const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>
        M(J.values.data() + begin, m, k);
    G_.resize(k, k);
    G_.setZero();
    G_.selfadjointView<Eigen::Lower>().rankUpdate(M.transpose());
    // Only G's lower triangle is set: G(a, b) for entry a after entry b, else G(b, a).
    const auto g = [this](int a, int b) { return a >= b ? G_(a, b) : G_(b, a); };
    double* values = H_nn_.valuePtr();
    const int* outer = H_nn_.outerIndexPtr();
    for (const Run& v : runs_) {
      const int j = v.block;
      const int tj = tangent_[static_cast<std::size_t>(j)];
      if (j >= nb_) {
        // A calibration column: its calibration rows (H_cc, full); its nuisance rows are H_nc.
        for (const Run& u : runs_) {
          if (u.block < nb_)
            continue;
          const int ti = tangent_[static_cast<std::size_t>(u.block)];
          const int ri = offset_[static_cast<std::size_t>(u.block)] - n_;
          const int cj = offset_[static_cast<std::size_t>(j)] - n_;
          for (int q = 0; q < tj; ++q) {
            for (int p = 0; p < ti; ++p)
              H_cc_(ri + p, cj + q) += g(u.first + p, v.first + q);
          }
        }
        continue;
      }
      const std::vector<int>& below = below_[static_cast<std::size_t>(j)];
      const std::vector<int>& below_start = below_start_[static_cast<std::size_t>(j)];
      for (const Run& u : runs_) {
        const int i = u.block;
        const int ti = tangent_[static_cast<std::size_t>(i)];
        const int oj = offset_[static_cast<std::size_t>(j)];
        if (i >= nb_) {
          const int ci = offset_[static_cast<std::size_t>(i)] - n_;
          for (int q = 0; q < tj; ++q) {
            for (int p = 0; p < ti; ++p)
              H_nc_(oj + q, ci + p) += g(u.first + p, v.first + q);
          }
        } else if (i == j) {
          for (int q = 0; q < tj; ++q) {
            double* col = values + outer[oj + q];
            for (int p = q; p < tj; ++p)
              col[p - q] += g(u.first + p, v.first + q);
          }
        } else if (i > j) {
          const auto it = std::lower_bound(below.begin(), below.end(), i);
          const int start = below_start[static_cast<std::size_t>(it - below.begin())];
          for (int q = 0; q < tj; ++q) {
            double* col = values + outer[oj + q] + (tj - q) + start;
            for (int p = 0; p < ti; ++p)
              col[p] += g(u.first + p, v.first + q);
          }
        }
      }
    }
  }

  std::vector<int> tangent_;
  std::vector<int> offset_;
  int nb_ = 0;
  int n_ = 0;
  int c_ = 0;
  std::vector<int> block_of_col_;
  std::vector<std::vector<int>> below_;        // per nuisance column block, sorted row blocks
  std::vector<std::vector<int>> below_start_;  // their first row's place below the diagonal block
  SparseColMajor H_nn_;                        // lower triangle
  Eigen::MatrixXd H_nc_;
  Eigen::MatrixXd H_cc_;
  std::vector<Run> runs_;
  Eigen::MatrixXd G_;
};

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
