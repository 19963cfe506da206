// The Levenberg-Marquardt step's factorisation of the nuisance block A = H_nn + D (lm_solver.cpp):
// CHOLMOD's LL^T (supernodal or simplicial, by CHOLMOD's own switch), with the matrix handed over
// already in its fill-reducing order.
//
// Why not Eigen's CholmodSupernodalLLT: given a lower triangle and its own ordering, CHOLMOD's
// factorize transposes the matrix twice per call to reach tril(P A P^T) (cholmod_factorize.c), and
// the caller first copied H_nn to add the damping: three fresh copies of H_nn per step, and their
// pages faulted in anew every time (EuRoC's 36 s: a quarter of the run's page faults, and ~5 % of
// its CPU in the transposes). Here the order is computed once (CHOLMOD's AMD with its
// postordering), the permuted lower pattern is built once with a map from H_nn's entries to its
// own, and each step scatters H_nn + D into it; CHOLMOD, told the order is natural, factors it in
// place. The solves reuse their workspace (cholmod_solve2), one per thread.
//
// On a long recording with 2 threads or more (SetThreads), the matrix is split at a small vertex
// separator into two halves that CHOLMOD factors at once, one per thread, and a dense factor of
// the separator (SplitFactor, sparse_cholesky_impl.h): the simplicial factorisation was the step's
// one single-threaded part (EuRoC's 36 s: 23 -> 13.5 ms a step).
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>

namespace ctcal {

class Factor;
struct SingleFactor;
struct SplitFactor;

class SparseCholesky {
 public:
  using SparseColMajor = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

  // kAuto: CHOLMOD's supernodal factorisation where its flops per entry of L reach
  // kSupernodalSwitch, else the simplicial one; the others force one (benchmarks, tests).
  enum class Kind { kAuto, kSimplicial, kSupernodal };
  static constexpr double kSupernodalSwitch = 80.0;  // sparse_cholesky.cpp Analyze: measured

  explicit SparseCholesky(Kind kind = Kind::kAuto);
  ~SparseCholesky();
  SparseCholesky(const SparseCholesky&) = delete;
  SparseCholesky& operator=(const SparseCholesky&) = delete;

  // Factors A + diag(d.head(n)) from A's lower triangle (n x n, every column's diagonal entry
  // present; d may be longer). The ordering and symbolic analysis of the last pattern are reused
  // when A has the same one (checked entry by entry), another pattern is analysed anew. False
  // when the matrix is not positive definite (or CHOLMOD fails). `same_pattern`: the caller
  // vouches that `lower` has the pattern of the last call (the steps of one solve, whose H_nn's
  // pattern is fixed), and the check is skipped (0.7 % of EuRoC's CPU, on the step's one thread).
  bool Factorize(const SparseColMajor& lower, const Eigen::VectorXd& d, bool same_pattern = false);

  // With 2 threads or more and kAuto, a new pattern is split where that pays: its two halves
  // around a small separator factored at once on two threads (SplitFactor,
  // sparse_cholesky_impl.h). The result differs from the single factor's in its rounding only,
  // and depends on the threads only through this choice. From the next new pattern on.
  void SetThreads(int threads);
  // Whether the last analysis split the matrix.
  bool Split() const;

  // Frees the factor's values (and Solve(B, X)'s workspace, as ReleaseSolveWorkspace) and keeps
  // its analysis for the next Factorize of the same pattern: the spline calibration's robust and
  // final solves and their covariance share one (the analysis was a third of each solve's first
  // step on the demo rig), whose factor is freed once the covariance is done with it.
  void ReleaseNumeric();

  // The factor's entries (its analysis'; 0 before the first Factorize): how much it filled, and
  // whether CHOLMOD chose its supernodal factorisation (else the simplicial one).
  double FactorNonZeros() const;
  // The factorisation's flop count (its analysis'): per entry of L, what kAuto's switch compares.
  double FactorFlops() const;
  bool Supernodal() const;

  // The buffers of one solve at a time (B and X in the factor's order, CHOLMOD's workspace and
  // its own cholmod_common): one per thread that solves.
  class Workspace {
   public:
    Workspace();
    ~Workspace();
    Workspace(const Workspace&) = delete;
    Workspace& operator=(const Workspace&) = delete;
    void Release();  // frees the buffers until the next solve

   private:
    friend class SparseCholesky;
    friend class Factor;
    friend struct SingleFactor;
    friend struct SplitFactor;
    struct Impl;
    std::unique_ptr<Impl> impl_;
  };

  // X = (A + diag(d))^-1 B with the last factorisation. False when the result is not finite.
  bool Solve(const Eigen::MatrixXd& B, Eigen::MatrixXd* X);
  // The same in `workspace`: solves with distinct workspaces may run on several threads at once
  // (the factor is only read).
  bool Solve(const Eigen::MatrixXd& B, Eigen::MatrixXd* X, Workspace* workspace) const;

  // The factor's half of a solve: X = R^-T B for A + diag(d) = R^T R (in CHOLMOD's terms
  // R = D^1/2 L^T P, D the identity for an LL^T factor), so that B^T (A + diag(d))^-1 C = X^T Y
  // with Y the half solve of C. One triangular solve instead of Solve's two: the Schur complement
  // on the border needs only these products (SubtractBorderSchur). X's rows are in the factor's
  // order (meaningful only in such products). With `last`, B's columns are followed by it (B may
  // have none), and X has one column more than B. False when X is not finite. Like Solve with a
  // workspace, several threads may half-solve at once.
  bool HalfSolve(const Eigen::Ref<const Eigen::MatrixXd>& B, const Eigen::VectorXd* last,
                 Eigen::Ref<Eigen::MatrixXd> X, Workspace* workspace) const;

  // The other half: Y = R^-1 X (X in the factor's order, as HalfSolve's results; Y in A's), so
  // that A^-1 b = R^-1 (R^-T b). False when Y is not finite.
  bool HalfSolveBack(const Eigen::Ref<const Eigen::MatrixXd>& X, Eigen::MatrixXd* Y,
                     Workspace* workspace) const;

  // Frees the solves' workspace (n x columns, ~3 copies of B) until the next Solve: it would
  // otherwise sit beside the next Jacobian pass, the solve's memory peak.
  void ReleaseSolveWorkspace();

 private:
  struct Impl;  // CHOLMOD's state (cholmod.h stays out of this header)
  std::unique_ptr<Impl> impl_;
};

}  // namespace ctcal
