// SparseCholesky's insides (sparse_cholesky.h), shared by its two factorisations: one CHOLMOD
// factor of the whole matrix (SingleFactor, sparse_cholesky.cpp) and the split one, two such
// factors of the halves a separator leaves and a dense factor of the separator
// (SplitFactor, sparse_cholesky_split.cpp).
#pragma once

#include <cholmod.h>

#include <algorithm>
#include <memory>
#include <tuple>
#include <utility>
#include <vector>

#include "sparse_cholesky.h"

namespace ctcal {

// A cholmod_sparse header over compressed columns held elsewhere (nothing is copied): one
// triangle of a symmetric matrix, the lower (upper = false) or the upper.
inline cholmod_sparse View(int n, const int* col_start, const int* row_index, const double* values,
                           bool sorted, bool upper = false) {
  cholmod_sparse s{};
  s.nrow = s.ncol = static_cast<std::size_t>(n);
  s.nzmax = static_cast<std::size_t>(col_start[n]);
  s.p = const_cast<int*>(col_start);
  s.i = const_cast<int*>(row_index);
  s.x = const_cast<double*>(values);
  s.stype = upper ? 1 : -1;
  s.itype = CHOLMOD_INT;
  s.xtype = values != nullptr ? CHOLMOD_REAL : CHOLMOD_PATTERN;  // no values: an ordering's input
  s.dtype = CHOLMOD_DOUBLE;
  s.sorted = sorted ? 1 : 0;
  s.packed = 1;
  return s;
}

// A cholmod_dense header over n x k column-major doubles held elsewhere.
inline cholmod_dense DenseView(double* x, std::size_t n, std::size_t k) {
  cholmod_dense b{};
  b.nrow = n;
  b.ncol = k;
  b.nzmax = n * k;
  b.d = n;
  b.x = x;
  b.xtype = CHOLMOD_REAL;
  b.dtype = CHOLMOD_DOUBLE;
  return b;
}

struct SparseCholesky::Workspace::Impl {
  Impl() {
    cholmod_start(&common);
    common.print = 0;
  }
  ~Impl() {
    Release();
    cholmod_finish(&common);
  }
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;
  void Release() {
    cholmod_free_dense(&x, &common);
    cholmod_free_dense(&y, &common);
    cholmod_free_dense(&e, &common);
    std::vector<double>().swap(rhs);
    if (second != nullptr)
      second->Release();
  }
  // The split factor's second half solves in its own (each half keeps its sizes).
  Impl* Second() {
    if (second == nullptr)
      second = std::make_unique<Impl>();
    return second.get();
  }

  // Its own: cholmod_solve2 allocates through it and counts into it.
  cholmod_common common;
  cholmod_dense* x = nullptr;  // cholmod_solve2's result and workspaces, kept between solves
  cholmod_dense* y = nullptr;
  cholmod_dense* e = nullptr;
  std::vector<double> rhs;  // B in the new order, column-major
  std::unique_ptr<Impl> second;
};

// What SparseCholesky asks of its factor once it is factored: the solves (sparse_cholesky.h says
// what each computes), and freeing the values until the next factorisation.
class Factor {
 public:
  using WorkspaceImpl = SparseCholesky::Workspace::Impl;
  virtual ~Factor() = default;
  virtual void ReleaseNumeric() = 0;
  virtual bool Solve(const Eigen::MatrixXd& B, Eigen::MatrixXd* X, WorkspaceImpl* w) const = 0;
  virtual bool HalfSolve(const Eigen::Ref<const Eigen::MatrixXd>& B, const Eigen::VectorXd* last,
                         Eigen::Ref<Eigen::MatrixXd> X, WorkspaceImpl* w) const = 0;
  virtual bool HalfSolveBack(const Eigen::Ref<const Eigen::MatrixXd>& X, Eigen::MatrixXd* Y,
                             WorkspaceImpl* w) const = 0;
  virtual double NonZeros() const = 0;
  virtual double Flops() const = 0;
  // Solve(B, X)'s own workspace.
  SparseCholesky::Workspace solve_;
};

// One CHOLMOD factor of a symmetric positive definite matrix given by its lower triangle.
struct SingleFactor final : Factor {
  using SparseColMajor = SparseCholesky::SparseColMajor;
  using Kind = SparseCholesky::Kind;

  explicit SingleFactor(Kind kind) : kind_(kind) {
    cholmod_start(&common_);
    common_.print = 0;  // a failure is an invalid step, handled by the caller
  }
  ~SingleFactor() override {
    cholmod_free_factor(&factor_, &common_);
    cholmod_finish(&common_);
  }
  SingleFactor(const SingleFactor&) = delete;
  SingleFactor& operator=(const SingleFactor&) = delete;

  // `last_set`: columns the order must put after all others (CAMD's constraint), or empty.
  void Analyze(const SparseColMajor& lower, const std::vector<int>& last_set = {});
  // The same from the pattern alone (compressed columns of the lower triangle).
  void Analyze(int n, const int* p, const int* rows, const std::vector<int>& last_set);
  void StoreUpper();
  bool SameAsAnalysed(const SparseColMajor& lower) const;
  // Factors A + diag(d), analysing `lower`'s pattern first when there is no factor (the caller
  // checks that a kept analysis is of this pattern: SameAsAnalysed).
  bool Factorize(const SparseColMajor& lower, const Eigen::VectorXd& d);
  // Factorize's second half: values_ filled by the caller (through target_).
  bool FactorizeValues();
  // A simplicial factor's numeric part and the permuted copy of A allocated now, on the calling
  // thread (Factorize would allocate them on the thread that factors).
  void AllocateNumeric();
  // The matrix's index -> its position in the factor's order.
  std::vector<int> Positions() const;
  // Whether slot `at` of the permuted copy holds the entry of permuted row and column a and b (in
  // either order), as SameAsAnalysed checks each entry.
  bool Holds(int at, int a, int b) const {
    const int row = upper_ ? std::min(a, b) : std::max(a, b);
    const int col = upper_ ? std::max(a, b) : std::min(a, b);
    return row_index_[static_cast<std::size_t>(at)] == row &&
           at >= col_start_[static_cast<std::size_t>(col)] &&
           at < col_start_[static_cast<std::size_t>(col) + 1];
  }
  void ReleaseNumeric() override;
  bool Solve(const Eigen::MatrixXd& B, Eigen::MatrixXd* X, WorkspaceImpl* w) const override;
  bool HalfSolve(const Eigen::Ref<const Eigen::MatrixXd>& B, const Eigen::VectorXd* last,
                 Eigen::Ref<Eigen::MatrixXd> X, WorkspaceImpl* w) const override;
  bool HalfSolveBack(const Eigen::Ref<const Eigen::MatrixXd>& X, Eigen::MatrixXd* Y,
                     WorkspaceImpl* w) const override;
  double NonZeros() const override { return factor_ == nullptr ? 0.0 : common_.lnz; }
  double Flops() const override { return factor_ == nullptr ? 0.0 : common_.fl; }
  // CHOLMOD's result in w.x (the factor's order, `cols` columns) back in A's order, in *X; false
  // when it is not finite.
  bool Unpermuted(const WorkspaceImpl& w, Eigen::Index cols, Eigen::MatrixXd* X) const;
  // B's columns (then `last`'s) permuted into w->rhs and handed to CHOLMOD as `b`.
  cholmod_dense PermutedRhs(const Eigen::Ref<const Eigen::MatrixXd>& B, const Eigen::VectorXd* last,
                            WorkspaceImpl* w) const;

  Kind kind_;
  bool split_half_ = false;  // a half of SplitFactor's
  cholmod_common common_;
  cholmod_factor* factor_ = nullptr;
  std::vector<int> perm_;  // new index -> the matrix's index (CHOLMOD's ordering)
  // tril(P A P^T) in compressed columns, or triu(P A P^T) (upper_: a simplicial factor's, see
  // StoreUpper); entry k of the matrix's lower triangle lands at target_[k].
  std::vector<int> col_start_, row_index_, target_;
  bool upper_ = false;
  std::vector<double> values_;
  // D^-1/2 of a simplicial LDL^T factor, in the factor's order (HalfSolve); empty for LL^T.
  std::vector<double> half_scale_;
  // A half of SplitFactor's: per factor position, the row of the whole matrix it is (perm_
  // composed with the half's columns): its solves read B's and write Y's rows of the whole
  // matrix, without a copy of the half's rows (Unpermuted then leaves Y's size to the caller).
  std::vector<int> gather_;
};

// A = [A_0 0 C_0; 0 A_1 C_1; C_0^T C_1^T A_s] (rows and columns grouped by a vertex separator s of
// A's graph, METIS' through cholmod_bisect) is R^T R with R = [R_0 0 W_0; 0 R_1 W_1; 0 0 R_s]:
// R_k^T R_k = A_k (a CHOLMOD factor each, factored on two threads), W_k = R_k^-T C_k, and
// R_s^T R_s = A_s - W_0^T W_0 - W_1^T W_1 (dense). The rows of A_k coupled to the separator are
// ordered last (CAMD), so W_k is zero above the position of the first of them: only its tail is
// held and solved. The trajectory's band splits in two at a few knots and the bias knots spanning
// them (EuRoC's 36 s: 30690 columns, a separator of ~30).
struct SplitFactor final : Factor {
  using SparseColMajor = SparseCholesky::SparseColMajor;
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  // The split of `lower`'s pattern, or null where it does not pay: a small matrix, a separator
  // larger than kMaxSeparator or a half with less than a quarter of the columns, or halves whose
  // factors CHOLMOD's switch would make supernodal (the single factor's choice then).
  static std::unique_ptr<SplitFactor> Analyze(const SparseColMajor& lower);
  // Measured with the whole command (A/B pairs, docs/performance.md, issue 23 session 22): EuRoC's
  // 36 s (30912 columns) 0.94 with the split; the demo rig (13302 columns, its step dominated by
  // its 97 border columns' solves) 1.00, with ~2 MB more peak: not split.
  static constexpr int kMinColumns = 20000;
  static constexpr int kMaxSeparator = 256;

  bool SameAsAnalysed(const SparseColMajor& lower) const;
  bool Factorize(const SparseColMajor& lower, const Eigen::VectorXd& d);
  void ReleaseNumeric() override;
  bool Solve(const Eigen::MatrixXd& B, Eigen::MatrixXd* X, WorkspaceImpl* w) const override;
  bool HalfSolve(const Eigen::Ref<const Eigen::MatrixXd>& B, const Eigen::VectorXd* last,
                 Eigen::Ref<Eigen::MatrixXd> X, WorkspaceImpl* w) const override;
  bool HalfSolveBack(const Eigen::Ref<const Eigen::MatrixXd>& X, Eigen::MatrixXd* Y,
                     WorkspaceImpl* w) const override;
  double NonZeros() const override;
  double Flops() const override;

  struct Coupling {
    int entry;   // in the matrix's lower triangle
    int row;     // the half's factor position minus its tail
    int column;  // separator index
  };
  struct Half {
    Half() : factor(SparseCholesky::Kind::kSimplicial) { factor.split_half_ = true; }
    std::vector<int> global;  // local index -> the matrix's
    // A_k's entries are the matrix's entries within the half, in the matrix's order: its n-th
    // lands at factor.target_[n] (no copy of A_k is kept).
    std::vector<Coupling> coupling;
    SingleFactor factor;
    int tail = 0;          // the first factor position W_k can be non-zero at
    RowMajor W;            // W_k's rows tail.., s columns
    Eigen::MatrixXd gram;  // W_k^T W_k
  };
  Half half[2];
  std::vector<char> part;      // per column of the matrix: 0, 1 (its half) or 2 (the separator)
  std::vector<int> local;      // per column of the matrix: its index in its half or separator
  std::vector<int> separator;  // separator index -> the matrix's
  std::vector<std::tuple<int, int, int>> separator_entries;  // (entry, i, j), i >= j
  Eigen::MatrixXd L_s;                                       // R_s^T (lower)
  std::vector<int> outer;                                    // the analysed pattern's column starts
  bool first_done = false;  // a factorisation of this analysis has allocated its buffers
};

struct SparseCholesky::Impl {
  explicit Impl(Kind kind);
  ~Impl();
  Kind kind;
  int threads = 1;
  SingleFactor single;
  std::unique_ptr<SplitFactor> split;  // when the analysis split the matrix
  Factor& factor() { return split != nullptr ? static_cast<Factor&>(*split) : single; }
  const Factor& factor() const {
    return split != nullptr ? static_cast<const Factor&>(*split) : single;
  }
};

}  // namespace ctcal
