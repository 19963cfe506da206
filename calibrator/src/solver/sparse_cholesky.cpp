#include "sparse_cholesky.h"

#include <cholmod.h>

#include "sparse_cholesky_impl.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace ctcal {

SparseCholesky::Workspace::Workspace() : impl_(std::make_unique<Impl>()) {}
SparseCholesky::Workspace::~Workspace() = default;
void SparseCholesky::Workspace::Release() {
  impl_->Release();
}

SparseCholesky::Impl::Impl(Kind kind_in) : kind(kind_in), single(kind_in) {}
SparseCholesky::Impl::~Impl() = default;

SparseCholesky::SparseCholesky(Kind kind) : impl_(std::make_unique<Impl>(kind)) {}
SparseCholesky::~SparseCholesky() = default;

void SparseCholesky::SetThreads(int threads) {
  impl_->threads = threads;
}

bool SparseCholesky::Factorize(const SparseColMajor& lower, const Eigen::VectorXd& d,
                               bool same_pattern) {
  Impl& m = *impl_;
  // A new pattern is analysed anew: split where that pays on two threads, else one factor.
  // (No factor of either kind yet: the first pattern.)
  const bool analysed = m.split != nullptr || m.single.factor_ != nullptr;
  if (!analysed || (!same_pattern && (m.split != nullptr ? !m.split->SameAsAnalysed(lower)
                                                         : !m.single.SameAsAnalysed(lower)))) {
    m.split.reset();
    cholmod_free_factor(&m.single.factor_, &m.single.common_);
    if (m.kind == Kind::kAuto && m.threads >= 2)
      m.split = SplitFactor::Analyze(lower);
  }
  if (m.split != nullptr)
    return m.split->Factorize(lower, d);
  return m.single.Factorize(lower, d);  // analyses the pattern when it has no factor
}

void SparseCholesky::ReleaseNumeric() {
  impl_->factor().ReleaseNumeric();
}

void SingleFactor::ReleaseNumeric() {
  // A numeric factor back to its symbolic analysis, supernodal or simplicial as it is
  // (cholmod_change_factor keeps the supernodes or the column counts and frees the values); the
  // next factorize allocates them again.
  if (factor_ != nullptr && factor_->xtype != CHOLMOD_PATTERN)
    cholmod_change_factor(CHOLMOD_PATTERN, factor_->is_ll, factor_->is_super, 1, 1, factor_,
                          &common_);
  std::vector<double>().swap(values_);
  solve_.Release();
}

double SparseCholesky::FactorNonZeros() const {
  return impl_->factor().NonZeros();
}

double SparseCholesky::FactorFlops() const {
  return impl_->factor().Flops();
}

bool SparseCholesky::Supernodal() const {
  return impl_->split == nullptr && impl_->single.factor_ != nullptr &&
         impl_->single.factor_->is_super;
}

bool SparseCholesky::Split() const {
  return impl_->split != nullptr;
}

bool SparseCholesky::Solve(const Eigen::MatrixXd& B, Eigen::MatrixXd* X) {
  Factor& f = impl_->factor();
  return f.Solve(B, X, f.solve_.impl_.get());
}

bool SparseCholesky::Solve(const Eigen::MatrixXd& B, Eigen::MatrixXd* X,
                           Workspace* workspace) const {
  return impl_->factor().Solve(B, X, workspace->impl_.get());
}

bool SparseCholesky::HalfSolve(const Eigen::Ref<const Eigen::MatrixXd>& B,
                               const Eigen::VectorXd* last, Eigen::Ref<Eigen::MatrixXd> X,
                               Workspace* workspace) const {
  return impl_->factor().HalfSolve(B, last, X, workspace->impl_.get());
}

bool SparseCholesky::HalfSolveBack(const Eigen::Ref<const Eigen::MatrixXd>& X, Eigen::MatrixXd* Y,
                                   Workspace* workspace) const {
  return impl_->factor().HalfSolveBack(X, Y, workspace->impl_.get());
}

void SparseCholesky::ReleaseSolveWorkspace() {
  impl_->factor().solve_.Release();
}

void SingleFactor::Analyze(const SparseColMajor& lower, const std::vector<int>& last_set) {
  if (!lower.isCompressed())
    throw std::logic_error("SparseCholesky: the matrix must be in compressed form");
  Analyze(static_cast<int>(lower.cols()), lower.outerIndexPtr(), lower.innerIndexPtr(), last_set);
}

void SingleFactor::Analyze(int n, const int* p, const int* rows, const std::vector<int>& last_set) {
  const auto nnz = static_cast<std::size_t>(p[n]);

  // The fill-reducing order: CHOLMOD's AMD on H_nn's pattern as given, which postorders its
  // assembly tree itself. Only the permutation is wanted here: cholmod_analyze would also run a
  // symbolic factorisation of the unpermuted pattern (the same L; bench_step_factorisation's
  // EuRoC-shaped BM_AnalyseAndFactorize 75-81 -> 61-64 ms without it). Default settings first:
  // the analysis below leaves the natural order set, and a pattern analysed anew in natural order
  // filled ~15x slower.
  cholmod_defaults(&common_);
  common_.print = 0;
  {
    const cholmod_sparse a = View(n, p, rows, nullptr, false);
    perm_.resize(static_cast<std::size_t>(n));
    // With a last set (SplitFactor's rows coupled to its separator), CAMD: AMD's order within
    // each constraint set, set 0 before set 1.
    std::vector<int> member;
    if (split_half_) {
      // AMD orders columns denser than 10 sqrt(n) last, as a block; a half's bias knots (~1700
      // entries: a second of trajectory knots) crossed that with half the columns, and the half
      // then filled ~2.3x the whole: only completely dense ones so.
      common_.method[0].prune_dense = -1.0;
    }
    if (!last_set.empty()) {
      member.assign(static_cast<std::size_t>(n), 0);
      for (const int j : last_set)
        member[static_cast<std::size_t>(j)] = 1;
    }
    const bool ordered = member.empty() ? cholmod_amd(const_cast<cholmod_sparse*>(&a), nullptr, 0,
                                                      perm_.data(), &common_)
                                        : cholmod_camd(const_cast<cholmod_sparse*>(&a), nullptr, 0,
                                                       member.data(), perm_.data(), &common_);
    if (!ordered)
      throw std::runtime_error("SparseCholesky: CHOLMOD could not order the normal equations");
  }
  std::vector<int> position(static_cast<std::size_t>(n));  // H_nn's index -> new index
  for (int q = 0; q < n; ++q)
    position[static_cast<std::size_t>(perm_[static_cast<std::size_t>(q)])] = q;

  // Entry k of H_nn, (i, j) with i >= j, goes to (max, min) of (position[i], position[j]): counted
  // per new column, scattered into its column in one pass, then each column's few rows sorted
  // ascending (as CHOLMOD wants them) by insertion, target_ following its entries. One scatter
  // and one scratch array of nnz (each slot's entry): the two counting sorts before, with four,
  // were 83 ms of EuRoC's first factorisation in the calibration, bound by their cache misses and
  // page faults.
  col_start_.assign(static_cast<std::size_t>(n) + 1, 0);
  for (int j = 0; j < n; ++j) {
    const int b = position[static_cast<std::size_t>(j)];
    for (int k = p[j]; k < p[j + 1]; ++k)
      ++col_start_[static_cast<std::size_t>(
                       std::min(position[static_cast<std::size_t>(rows[k])], b)) +
                   1];
  }
  for (int j = 0; j < n; ++j)
    col_start_[static_cast<std::size_t>(j) + 1] += col_start_[static_cast<std::size_t>(j)];
  row_index_.resize(nnz);
  target_.resize(nnz);
  std::vector<int> source(nnz);  // slot -> entry of H_nn
  {
    std::vector<int> fill(col_start_.begin(), col_start_.end() - 1);
    for (int j = 0; j < n; ++j) {
      const int b = position[static_cast<std::size_t>(j)];
      for (int k = p[j]; k < p[j + 1]; ++k) {
        const int a = position[static_cast<std::size_t>(rows[k])];
        const auto at = static_cast<std::size_t>(fill[static_cast<std::size_t>(std::min(a, b))]++);
        row_index_[at] = std::max(a, b);
        source[at] = k;
      }
    }
  }
  for (int c = 0; c < n; ++c) {
    const int first = col_start_[static_cast<std::size_t>(c)];
    const int last = col_start_[static_cast<std::size_t>(c) + 1];
    for (int at = first + 1; at < last; ++at) {
      const int row = row_index_[static_cast<std::size_t>(at)];
      const int k = source[static_cast<std::size_t>(at)];
      int to = at;
      for (; to > first && row_index_[static_cast<std::size_t>(to) - 1] > row; --to) {
        row_index_[static_cast<std::size_t>(to)] = row_index_[static_cast<std::size_t>(to) - 1];
        source[static_cast<std::size_t>(to)] = source[static_cast<std::size_t>(to) - 1];
      }
      row_index_[static_cast<std::size_t>(to)] = row;
      source[static_cast<std::size_t>(to)] = k;
    }
  }
  for (std::size_t at = 0; at < nnz; ++at)
    target_[static_cast<std::size_t>(source[at])] = static_cast<int>(at);
  values_.assign(nnz, 0.0);

  // The symbolic factorisation of the permuted pattern in its given order: no permutation left
  // for factorize to apply (and none to postorder: AMD's order is postordered already).
  common_.nmethods = 1;
  common_.method[0].ordering = CHOLMOD_NATURAL;
  common_.postorder = 0;
  // Supernodal or simplicial by CHOLMOD's own switch (flops per entry of L): the trajectory's
  // band fills little, its supernodes are a few knots' columns wide, and BLAS calls on blocks
  // that small cost more than they save (EuRoC's 36 s: the step's linear solver 0.74 -> 0.46 s
  // with the simplicial factor). CHOLMOD's default switch (40) assumes a tuned BLAS; with
  // Debian's ATLAS, bench_step_factorisation puts the crossing near 80-100 (a factorisation and a
  // 9-column solve: the demo rig's band at 52 flops per entry 28 ms simplicial against 51 ms
  // supernodal, a band at 80 even, at 135 the supernodal 1.14x faster; docs/performance.md).
  common_.supernodal = kind_ == Kind::kSimplicial   ? CHOLMOD_SIMPLICIAL
                       : kind_ == Kind::kSupernodal ? CHOLMOD_SUPERNODAL
                                                    : CHOLMOD_AUTO;
  common_.supernodal_switch = SparseCholesky::kSupernodalSwitch;
  common_.final_asis = 1;
  // A simplicial factor's columns exactly as long as their counts: they never grow here (no
  // updates), and CHOLMOD's default slack (20 % and 5 entries a column) was memory for nothing.
  common_.grow0 = 1.0;
  common_.grow1 = 1.0;
  common_.grow2 = 0;
  const cholmod_sparse a = View(n, col_start_.data(), row_index_.data(), values_.data(), true);
  upper_ = false;
  factor_ = cholmod_analyze(const_cast<cholmod_sparse*>(&a), &common_);
  if (factor_ == nullptr)
    throw std::runtime_error("SparseCholesky: CHOLMOD could not analyse the normal equations");
  if (!factor_->is_super)
    StoreUpper();
}

// The permuted matrix as its upper triangle, for a simplicial factor. In the natural order CHOLMOD
// factors the triangle each kind reads in place: the supernodal factor the lower, the simplicial
// one (cholmod_rowfac) the upper; given the other, cholmod_factorize allocates and fills its
// transpose every time (cholmod_transpose_sym: 3 % of EuRoC's CPU and 16 % of its page faults).
// Once per analysis: column c's entries (r >= c) become row c of their columns r, appended in
// ascending c, so each new column's rows come out sorted.
void SingleFactor::StoreUpper() {
  const std::size_t n = col_start_.size() - 1, nnz = row_index_.size();
  std::vector<int> start(n + 1, 0);
  for (const int r : row_index_)
    ++start[static_cast<std::size_t>(r) + 1];
  for (std::size_t j = 0; j < n; ++j)
    start[j + 1] += start[j];
  std::vector<int> rows(nnz), moved(nnz);
  std::vector<int> fill(start.begin(), start.end() - 1);
  for (std::size_t c = 0; c < n; ++c) {
    for (int at = col_start_[c]; at < col_start_[c + 1]; ++at) {
      const auto r = static_cast<std::size_t>(row_index_[static_cast<std::size_t>(at)]);
      const int to = fill[r]++;
      rows[static_cast<std::size_t>(to)] = static_cast<int>(c);
      moved[static_cast<std::size_t>(at)] = to;
    }
  }
  for (int& t : target_)
    t = moved[static_cast<std::size_t>(t)];
  col_start_.swap(start);
  row_index_.swap(rows);
  upper_ = true;
}

// Whether `lower` has the analysed pattern: every entry's map target holds its permuted row and
// lies in its permuted column (the map is one to one on the analysed pattern, so an equal count
// and every entry in place is the same pattern), without a copy of the pattern kept for it.
bool SingleFactor::SameAsAnalysed(const SparseColMajor& lower) const {
  const int n = static_cast<int>(lower.cols());
  if (factor_ == nullptr || !lower.isCompressed() || perm_.size() != static_cast<std::size_t>(n) ||
      target_.size() != static_cast<std::size_t>(lower.outerIndexPtr()[n]))
    return false;
  const int* p = lower.outerIndexPtr();
  const int* rows = lower.innerIndexPtr();
  const std::vector<int> position = Positions();
  for (int j = 0; j < n; ++j) {
    const int b = position[static_cast<std::size_t>(j)];
    for (int k = p[j]; k < p[j + 1]; ++k) {
      if (!Holds(target_[static_cast<std::size_t>(k)], position[static_cast<std::size_t>(rows[k])],
                 b))
        return false;
    }
  }
  return true;
}

bool SingleFactor::Factorize(const SparseColMajor& lower, const Eigen::VectorXd& d) {
  if (factor_ == nullptr)
    Analyze(lower);
  const int n = static_cast<int>(lower.cols());
  const int* p = lower.outerIndexPtr();
  const int* rows = lower.innerIndexPtr();
  const double* v = lower.valuePtr();
  values_.resize(target_.size());
  for (int j = 0; j < n; ++j) {
    for (int k = p[j]; k < p[j + 1]; ++k)
      values_[static_cast<std::size_t>(target_[static_cast<std::size_t>(k)])] =
          v[k] + (rows[k] == j ? d(j) : 0.0);
  }
  return FactorizeValues();
}

void SingleFactor::AllocateNumeric() {
  // Unpacked: each column keeps the room its count reserves, which cholmod_rowfac fills (packed,
  // every column would be reallocated as it grows).
  if (factor_ != nullptr && factor_->xtype == CHOLMOD_PATTERN && !factor_->is_super)
    cholmod_change_factor(CHOLMOD_REAL, factor_->is_ll, 0, 0, 0, factor_, &common_);
  values_.resize(target_.size());  // freed by ReleaseNumeric
  half_scale_.reserve(perm_.size());
}

std::vector<int> SingleFactor::Positions() const {
  std::vector<int> position(perm_.size());
  for (std::size_t q = 0; q < perm_.size(); ++q)
    position[static_cast<std::size_t>(perm_[q])] = static_cast<int>(q);
  return position;
}

bool SingleFactor::FactorizeValues() {
  const int n = static_cast<int>(perm_.size());
  const cholmod_sparse a =
      View(n, col_start_.data(), row_index_.data(), values_.data(), true, upper_);
  if (!cholmod_factorize(const_cast<cholmod_sparse*>(&a), factor_, &common_))
    return false;
  // Not positive definite is a warning to CHOLMOD (status > 0, the factor stops at `minor`).
  if (common_.status != CHOLMOD_OK || factor_->minor != static_cast<std::size_t>(n))
    return false;
  // A simplicial factor is LDL^T, which CHOLMOD completes for an indefinite matrix too (only a
  // zero pivot stops it); the callers rely on the refusal (a step's invalid damping, the
  // covariance's singular H_nn). A is positive definite iff every pivot d_j > 0, the pivots LL^T
  // would take the roots of; D sits on L's unit diagonal (cholmod_core.h).
  half_scale_.clear();
  if (!factor_->is_super && !factor_->is_ll) {
    const int* Lp = static_cast<const int*>(factor_->p);
    const double* Lx = static_cast<const double*>(factor_->x);
    half_scale_.resize(static_cast<std::size_t>(n));
    for (int j = 0; j < n; ++j) {
      if (!(Lx[Lp[j]] > 0.0) || !std::isfinite(Lx[Lp[j]]))
        return false;
      half_scale_[static_cast<std::size_t>(j)] = 1.0 / std::sqrt(Lx[Lp[j]]);
    }
  }
  return true;
}

cholmod_dense SingleFactor::PermutedRhs(const Eigen::Ref<const Eigen::MatrixXd>& B,
                                        const Eigen::VectorXd* last, WorkspaceImpl* w) const {
  const std::size_t n = perm_.size();
  const auto k = static_cast<std::size_t>(B.cols()) + (last != nullptr ? 1 : 0);
  w->rhs.resize(n * k);
  for (std::size_t c = 0; c < k; ++c) {
    const double* column = c < static_cast<std::size_t>(B.cols())
                               ? B.data() + static_cast<Eigen::Index>(c) * B.outerStride()
                               : last->data();
    const std::vector<int>& from = gather_.empty() ? perm_ : gather_;
    for (std::size_t q = 0; q < n; ++q)
      w->rhs[c * n + q] = column[from[q]];
  }
  return DenseView(w->rhs.data(), n, k);
}

bool SingleFactor::Solve(const Eigen::MatrixXd& B, Eigen::MatrixXd* X, WorkspaceImpl* w) const {
  cholmod_dense b = PermutedRhs(B, nullptr, w);
  // The factor is only read (CHOLMOD_A on a supernodal LL^T): several workspaces may solve at once.
  if (!cholmod_solve2(CHOLMOD_A, factor_, &b, nullptr, &w->x, nullptr, &w->y, &w->e, &w->common))
    return false;
  return Unpermuted(*w, B.cols(), X);
}

bool SingleFactor::Unpermuted(const WorkspaceImpl& w, Eigen::Index cols, Eigen::MatrixXd* X) const {
  const double* x = static_cast<const double*>(w.x->x);
  if (gather_.empty())
    X->resize(static_cast<Eigen::Index>(perm_.size()), cols);
  const std::vector<int>& to = gather_.empty() ? perm_ : gather_;
  bool finite = true;
  for (Eigen::Index c = 0; c < cols; ++c) {
    for (std::size_t q = 0; q < to.size(); ++q) {
      const double v = x[static_cast<std::size_t>(c) * w.x->d + q];
      (*X)(to[q], c) = v;
      finite = finite && std::isfinite(v);
    }
  }
  return finite;
}

// P A P^T = L D L^T (D = I for LL^T; the order is P, CHOLMOD's own being the natural one), so
// A^-1 = (D^1/2 L^T P)^-1 (D^1/2 L^T P)^-T and R^-T B = D^-1/2 L^-1 (P B): CHOLMOD_L solves with
// L alone (its unit diagonal for LDL^T), and the rows are scaled by D^-1/2.
bool SingleFactor::HalfSolve(const Eigen::Ref<const Eigen::MatrixXd>& B,
                             const Eigen::VectorXd* last, Eigen::Ref<Eigen::MatrixXd> X,
                             WorkspaceImpl* w) const {
  cholmod_dense b = PermutedRhs(B, last, w);
  if (!cholmod_solve2(CHOLMOD_L, factor_, &b, nullptr, &w->x, nullptr, &w->y, &w->e, &w->common))
    return false;
  const double* x = static_cast<const double*>(w->x->x);
  const std::size_t n = perm_.size();
  for (Eigen::Index c = 0; c < X.cols(); ++c) {
    const double* column = x + static_cast<std::size_t>(c) * w->x->d;
    if (half_scale_.empty()) {
      for (std::size_t q = 0; q < n; ++q)
        X(static_cast<Eigen::Index>(q), c) = column[q];
    } else {
      for (std::size_t q = 0; q < n; ++q)
        X(static_cast<Eigen::Index>(q), c) = column[q] * half_scale_[q];
    }
  }
  return X.allFinite();
}

// R^-1 X = P^T L^-T D^-1/2 X: the rows scaled by D^-1/2 (LDL^T), CHOLMOD_Lt with L alone, and the
// rows back to A's order.
bool SingleFactor::HalfSolveBack(const Eigen::Ref<const Eigen::MatrixXd>& X, Eigen::MatrixXd* Y,
                                 WorkspaceImpl* w) const {
  const std::size_t n = perm_.size();
  const auto k = static_cast<std::size_t>(X.cols());
  w->rhs.resize(n * k);
  for (std::size_t c = 0; c < k; ++c) {
    const double* column = X.data() + static_cast<Eigen::Index>(c) * X.outerStride();
    for (std::size_t q = 0; q < n; ++q)
      w->rhs[c * n + q] = half_scale_.empty() ? column[q] : column[q] * half_scale_[q];
  }
  cholmod_dense b = DenseView(w->rhs.data(), n, k);
  if (!cholmod_solve2(CHOLMOD_Lt, factor_, &b, nullptr, &w->x, nullptr, &w->y, &w->e, &w->common))
    return false;
  return Unpermuted(*w, X.cols(), Y);
}

}  // namespace ctcal
