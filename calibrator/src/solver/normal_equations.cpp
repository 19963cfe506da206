#include "normal_equations.h"

#include "ctcal/sensors/parallel_for.h"
#include "sparse_cholesky.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

namespace ctcal {

NormalEquations::NormalEquations(std::vector<int> tangent, int nuisance_blocks,
                                 const std::vector<std::vector<int>>& blocks_of, bool allocate)
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
    throw std::runtime_error("normal equations: the nuisance information has too many entries");
  nnz_ = nnz;
  if (allocate)
    Allocate();
}

void NormalEquations::Allocate() {
  if (allocated_)
    return;
  allocated_ = true;
  const std::int64_t nnz = nnz_;
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
  H_nc_.resize(n_, c_);
  H_cc_.resize(c_, c_);
  SetZero();
}

void NormalEquations::SetZero() {
  std::fill(H_nn_.valuePtr(), H_nn_.valuePtr() + H_nn_.nonZeros(), 0.0);
  H_nc_.setZero();
  H_cc_.setZero();
}

void NormalEquations::Release() {
  H_nn_ = SparseColMajor();
  H_nc_ = Eigen::MatrixXd();
  H_cc_ = Eigen::MatrixXd();
  below_ = {};
  below_start_ = {};
  block_of_col_ = {};
  G_ = Eigen::MatrixXd();
}

Eigen::VectorXd NormalEquations::Diagonal() const {
  Eigen::VectorXd d(n_ + c_);
  for (int i = 0; i < n_; ++i)
    d(i) = H_nn_.valuePtr()[H_nn_.outerIndexPtr()[i]];  // the diagonal leads its column
  d.tail(c_) = H_cc_.diagonal();
  return d;
}

Eigen::VectorXd NormalEquations::Multiply(const Eigen::VectorXd& x) const {
  Eigen::VectorXd y(n_ + c_);
  const auto x_n = x.head(n_);
  const auto x_c = x.tail(c_);
  y.head(n_) = H_nn_.selfadjointView<Eigen::Lower>() * x_n;
  y.head(n_) += H_nc_ * x_c;
  y.tail(c_) = H_nc_.transpose() * x_n;
  y.tail(c_) += H_cc_ * x_c;
  return y;
}

void NormalEquations::Add(const ceres::CRSMatrix& J, const std::vector<int>& rows_per_block) {
  int r = 0;
  for (const int m : rows_per_block) {
    if (m > 0) {
      // Every row of a residual block holds the same columns (Ceres writes all of a residual
      // block's non-constant parameter blocks into each of its rows), in increasing order.
      const int begin = J.rows[static_cast<std::size_t>(r)];
      const int k = J.rows[static_cast<std::size_t>(r) + 1] - begin;
      if (J.rows[static_cast<std::size_t>(r + m)] - begin != m * k)
        throw std::logic_error("normal equations: a residual block's rows differ in their columns");
      runs_.clear();
      for (int e = 0; e < k;) {
        const int col = J.cols[static_cast<std::size_t>(begin + e)];
        const int b = block_of_col_[static_cast<std::size_t>(col)];
        const int t = tangent_[static_cast<std::size_t>(b)];
        if (col != offset_[static_cast<std::size_t>(b)] || e + t > k ||
            J.cols[static_cast<std::size_t>(begin + e + t - 1)] != col + t - 1)
          throw std::logic_error(
              "normal equations: a parameter block's columns are not contiguous");
        runs_.push_back(Run{b, e});
        e += t;
      }
      AddBlock(J.values.data() + begin, m, k, runs_);
    }
    r += m;
  }
}

void NormalEquations::AddBlock(const double* J, int m, int k, const std::vector<Run>& runs,
                               Eigen::MatrixXd* G, Eigen::MatrixXd* H_cc) {
  if (k == 0 || m == 0)
    return;
  const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> M(
      J, m, k);
  G->resize(k, k);
  G->setZero();
  G->selfadjointView<Eigen::Lower>().rankUpdate(M.transpose());
  // Only G's lower triangle is set: G(a, b) for entry a after entry b, else G(b, a).
  const Eigen::MatrixXd& Gr = *G;
  const auto g = [&Gr](int a, int b) { return a >= b ? Gr(a, b) : Gr(b, a); };
  double* values = H_nn_.valuePtr();
  const int* outer = H_nn_.outerIndexPtr();
  for (const Run& v : runs) {
    const int j = v.block;
    const int tj = tangent_[static_cast<std::size_t>(j)];
    if (j >= nb_) {
      // A border column: its border rows (H_cc, full); its nuisance rows are H_nc.
      for (const Run& u : runs) {
        if (u.block < nb_)
          continue;
        const int ti = tangent_[static_cast<std::size_t>(u.block)];
        const int ri = offset_[static_cast<std::size_t>(u.block)] - n_;
        const int cj = offset_[static_cast<std::size_t>(j)] - n_;
        for (int q = 0; q < tj; ++q) {
          for (int p = 0; p < ti; ++p)
            (*H_cc)(ri + p, cj + q) += g(u.first + p, v.first + q);
        }
      }
      continue;
    }
    const std::vector<int>& below = below_[static_cast<std::size_t>(j)];
    const std::vector<int>& below_start = below_start_[static_cast<std::size_t>(j)];
    for (const Run& u : runs) {
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

int SchurThreads(int threads, int c) {
  return std::max(1, std::min(threads, (c + 1) / 2));
}

int SchurColumnsPerSolve(int threads, int c, int columns_in_flight) {
  return std::max(2, columns_in_flight / SchurThreads(threads, c));
}

bool HalfSolveBorder(SparseCholesky* llt, const Eigen::MatrixXd& H_nc, int threads,
                     int columns_in_flight, const Eigen::VectorXd* g_n, Eigen::MatrixXd* W) {
  const auto n = static_cast<int>(H_nc.rows()), c = static_cast<int>(H_nc.cols());
  const int T = SchurThreads(threads, c);
  const int columns = SchurColumnsPerSolve(threads, c, columns_in_flight);
  // With g_n: one chunk at least, for g_n alone when there is no border column.
  const int chunks = std::max(g_n != nullptr ? 1 : 0, (c + columns - 1) / columns);
  W->resize(n, c + (g_n != nullptr ? 1 : 0));
  std::vector<SparseCholesky::Workspace> workspaces(static_cast<std::size_t>(T));
  std::vector<char> solved(static_cast<std::size_t>(T), 1);
  ParallelFor(T, static_cast<std::size_t>(T), [&](std::size_t t) {
    for (int chunk = static_cast<int>(t); chunk < chunks; chunk += T) {
      const int j = chunk * columns;
      const int w = std::min(columns, c - j);
      const Eigen::VectorXd* last = chunk == chunks - 1 ? g_n : nullptr;
      // W's columns j .. j + w, and g_n's (W's last, c) right after them in the last chunk.
      if (!llt->HalfSolve(H_nc.middleCols(j, w), last,
                          W->middleCols(j, w + (last != nullptr ? 1 : 0)), &workspaces[t])) {
        solved[t] = 0;
        return;
      }
    }
    workspaces[t].Release();
  });
  return std::find(solved.begin(), solved.end(), 0) == solved.end();
}

void SubtractGram(const Eigen::Ref<const Eigen::MatrixXd>& W, int threads, Eigen::MatrixXd* S) {
  const auto c = static_cast<int>(W.cols());
  if (c == 0)
    return;
  // Column blocks fixed by the thread count: the bits do not depend on the schedule.
  const int P = std::max(1, std::min(threads, c));
  ParallelFor(P, static_cast<std::size_t>(P), [&](std::size_t t) {
    const int j0 = static_cast<int>(t) * c / P, j1 = (static_cast<int>(t) + 1) * c / P;
    S->middleCols(j0, j1 - j0).noalias() -= W.transpose() * W.middleCols(j0, j1 - j0);
  });
}

namespace {

// kHalf: S -= W_c^T W_c and h_g = W_c^T w_g (H_cn A^-1 g_n = (R^-T H_nc)^T (R^-T g_n)).
bool SubtractBorderSchurHalf(SparseCholesky* llt, const Eigen::MatrixXd& H_nc, int threads,
                             int columns_in_flight, const Eigen::VectorXd* g_n, Eigen::MatrixXd* S,
                             Eigen::VectorXd* h_g) {
  const auto c = static_cast<int>(H_nc.cols());
  Eigen::MatrixXd W;
  if (!HalfSolveBorder(llt, H_nc, threads, columns_in_flight, g_n, &W))
    return false;
  SubtractGram(W.leftCols(c), threads, S);
  if (g_n != nullptr)
    *h_g = W.leftCols(c).transpose() * W.col(c);
  return true;
}

// kChunks: A_nn^-1 [H_nc | g_n] a chunk at a time, S -= H_nc^T (A_nn^-1 H_J) per chunk.
bool SubtractBorderSchurChunks(SparseCholesky* llt, const Eigen::MatrixXd& H_nc, int threads,
                               int columns_in_flight, const Eigen::VectorXd* g_n,
                               Eigen::MatrixXd* S, Eigen::VectorXd* h_g) {
  const auto n = static_cast<int>(H_nc.rows()), c = static_cast<int>(H_nc.cols());
  const int T = SchurThreads(threads, c);
  const int columns = SchurColumnsPerSolve(threads, c, columns_in_flight);
  // With g_n: one chunk at least, for g_n alone when there is no border column.
  const int chunks = std::max(g_n != nullptr ? 1 : 0, (c + columns - 1) / columns);
  std::vector<SparseCholesky::Workspace> workspaces(static_cast<std::size_t>(T - 1));
  std::vector<char> solved(static_cast<std::size_t>(T), 1);
  Eigen::VectorXd y_g;  // A_nn^-1 g_n
  ParallelFor(T, static_cast<std::size_t>(T), [&](std::size_t t) {
    Eigen::MatrixXd B, Y;
    for (int chunk = static_cast<int>(t); chunk < chunks; chunk += T) {
      const int j = chunk * columns;
      const int w = std::min(columns, c - j);
      const int g_col = j == 0 && g_n != nullptr ? 1 : 0;
      B.resize(n, w + g_col);
      B.leftCols(w) = H_nc.middleCols(j, w);
      if (g_col)
        B.col(w) = *g_n;
      const bool ok = t == 0 ? llt->Solve(B, &Y) : llt->Solve(B, &Y, &workspaces[t - 1]);
      if (!ok) {
        solved[t] = 0;
        return;
      }
      if (w > 0)
        S->middleCols(j, w).noalias() -= H_nc.transpose() * Y.leftCols(w);
      if (g_col)
        y_g = Y.col(w);
    }
  });
  if (std::find(solved.begin(), solved.end(), 0) != solved.end())
    return false;
  if (g_n != nullptr)
    *h_g = H_nc.transpose() * y_g;
  return true;
}

}  // namespace

bool SubtractBorderSchur(SparseCholesky* llt, const Eigen::MatrixXd& H_nc, int threads,
                         int columns_in_flight, SchurSolves solves, const Eigen::VectorXd* g_n,
                         Eigen::MatrixXd* S, Eigen::VectorXd* h_g) {
  return solves == SchurSolves::kHalf
             ? SubtractBorderSchurHalf(llt, H_nc, threads, columns_in_flight, g_n, S, h_g)
             : SubtractBorderSchurChunks(llt, H_nc, threads, columns_in_flight, g_n, S, h_g);
}

Eigen::MatrixXd MarginalizeNuisance(NormalEquations* normal, double* nuisance_damping,
                                    SparseCholesky* factorisation, int threads,
                                    SchurSolves solves) {
  using SparseColMajor = NormalEquations::SparseColMajor;
  const int n = normal->n(), c = normal->c();
  *nuisance_damping = 0.0;
  const Eigen::MatrixXd H_cc = normal->H_cc();
  if (n == 0)
    return H_cc;
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
    normal->Release();
  }
  const int m = static_cast<int>(H_nn.rows());

  // A combination of touched nuisance states the data do not determine makes H_nn singular;
  // damping it by a tiny fraction of its scale marginalises it with a flat prior instead of
  // failing, and the amount is reported. Only H_nn's lower triangle is stored (and read).
  double max_diag = 0.0;
  for (int i = 0; i < m; ++i)
    max_diag = std::max(max_diag, H_nn.valuePtr()[H_nn.outerIndexPtr()[i]]);
  SparseCholesky local;
  local.SetThreads(threads);
  SparseCholesky& llt = factorisation != nullptr ? *factorisation : local;
  // A failed attempt is handled (and reported) by the damping below.
  bool factored = llt.Factorize(H_nn, Eigen::VectorXd::Zero(m));
  for (const double relative : {1e-12, 1e-9, 1e-6}) {
    if (factored)
      break;
    factored =
        llt.Factorize(H_nn, Eigen::VectorXd::Constant(m, relative * std::max(max_diag, 1.0)));
    *nuisance_damping = relative;
  }
  if (!factored)
    throw std::runtime_error("covariance: the nuisance information cannot be factored");
  H_nn = SparseColMajor();  // the factor holds what the solve needs
  Eigen::MatrixXd information = H_cc;
  bool solved = false;
  if (solves == SchurSolves::kHalf) {
    // W = R^-T H_nc takes H_nc's place: it is freed before the product.
    Eigen::MatrixXd W;
    solved = HalfSolveBorder(&llt, H_nc, threads, kSchurColumns, nullptr, &W);
    H_nc = Eigen::MatrixXd();
    if (solved)
      SubtractGram(W, threads, &information);
  } else {
    solved = SubtractBorderSchur(&llt, H_nc, threads, kSchurColumns, solves, nullptr, &information,
                                 nullptr);
  }
  if (!solved)
    throw std::runtime_error("covariance: the nuisance information's solve is not finite");
  llt.ReleaseNumeric();  // and its solves' workspace
  return 0.5 * (information + information.transpose()).eval();
}

}  // namespace ctcal
