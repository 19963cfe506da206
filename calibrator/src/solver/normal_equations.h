// H = J^T J of a least-squares problem, held as [H_nn H_nc; H_cn H_cc] in a pattern fixed once
// from the residual blocks' parameter blocks, and accumulated in place residual block by residual
// block: the Levenberg-Marquardt solver's normal equations (lm_solver.cpp) and the marginal
// covariance's information (marginal_covariance.cpp). Private to the calibrator library.
#pragma once

#include <ceres/crs_matrix.h>

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <cstdint>
#include <vector>

namespace ctcal {

class SparseCholesky;

// The columns are parameter blocks (their tangent spaces): the first `nuisance_blocks` are the
// nuisance states n (a sparse, banded coupling: the trajectory and bias knots), the rest the
// border c (coupled to nearly everything: the calibration). H_nn is held as its lower triangle in a
// sparse pattern (columns, then rows, in the order of the column blocks), H_nc and H_cc densely.
// Adding a chunk's J^T J to a growing Eigen sparse matrix (`H += Jt J`) held the old sum, the new
// sum and the product at once: three copies of H_nn, the peak of a 10 min 1 kHz run
// (docs/performance.md, step 7). Here every block's J_b^T J_b (dense, rows x cols^2) is scattered
// into the one H_nn.
class NormalEquations {
 public:
  using SparseColMajor = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

  // A residual block's columns: column block `block` is J's columns [first, first + tangent).
  struct Run {
    int block;
    int first;
  };

  // tangent: tangent size of each column block in column order; the first `nuisance_blocks` are
  // the nuisance states. blocks_of: for every residual block, its column blocks (any order).
  // allocate false: only the pattern's shape (NonZeros) until Allocate(), so that a caller can
  // choose by memory before any of it is taken.
  NormalEquations(std::vector<int> tangent, int nuisance_blocks,
                  const std::vector<std::vector<int>>& blocks_of, bool allocate = true);
  // The pattern and the values (zero); nothing when they are already allocated.
  void Allocate();
  // Entries of H_nn's lower triangle (also before Allocate).
  std::int64_t NonZeros() const { return nnz_; }

  int n() const { return n_; }
  int c() const { return c_; }
  int NumBlocks() const { return static_cast<int>(tangent_.size()); }
  int Tangent(int block) const { return tangent_[static_cast<std::size_t>(block)]; }
  // The first column of a column block (nuisance and border counted together: border columns
  // start at n()).
  int Offset(int block) const { return offset_[static_cast<std::size_t>(block)]; }

  // Adds J^T J of a Jacobian (Problem::Evaluate's CRS over the columns above) whose consecutive
  // row groups of `rows_per_block` are the residual blocks.
  void Add(const ceres::CRSMatrix& J, const std::vector<int>& rows_per_block);

  // Adds J^T J of one residual block: J is m x k, row-major, its columns the runs' blocks.
  void AddBlock(const double* J, int m, int k, const std::vector<Run>& runs) {
    AddBlock(J, m, k, runs, &G_, &H_cc_);
  }
  // The same with the caller's scratch `G` and the border-border block added to `H_cc` (c x c):
  // threads may add blocks at once as long as no two of them share a nuisance block (each
  // nuisance block's column of H_nn and row of H_nc is written by one thread), each with its own
  // G and H_cc (summed afterwards).
  void AddBlock(const double* J, int m, int k, const std::vector<Run>& runs, Eigen::MatrixXd* G,
                Eigen::MatrixXd* H_cc);

  // Every value 0 (the pattern kept).
  void SetZero();

  // The diagonal of H (n + c values).
  Eigen::VectorXd Diagonal() const;
  // y = H x (H symmetric: its lower triangle and border as held).
  Eigen::VectorXd Multiply(const Eigen::VectorXd& x) const;

  SparseColMajor& H_nn() { return H_nn_; }
  const SparseColMajor& H_nn() const { return H_nn_; }
  Eigen::MatrixXd& H_nc() { return H_nc_; }
  const Eigen::MatrixXd& H_nc() const { return H_nc_; }
  Eigen::MatrixXd& H_cc() { return H_cc_; }
  const Eigen::MatrixXd& H_cc() const { return H_cc_; }
  // Frees the values and the pattern (MarginalizeNuisance, once it has taken them over).
  void Release();

 private:
  std::vector<int> tangent_;
  std::vector<int> offset_;
  int nb_ = 0;
  int n_ = 0;
  int c_ = 0;
  std::vector<int> block_of_col_;
  std::vector<std::vector<int>> below_;        // per nuisance column block, sorted row blocks
  std::vector<std::vector<int>> below_start_;  // their first row's place below the diagonal block
  std::int64_t nnz_ = 0;
  bool allocated_ = false;
  SparseColMajor H_nn_;  // lower triangle
  Eigen::MatrixXd H_nc_;
  Eigen::MatrixXd H_cc_;
  std::vector<Run> runs_;  // scratch of Add
  Eigen::MatrixXd G_;      // scratch of AddBlock
};

// How SubtractBorderSchur applies A_nn^-1 to the border columns.
//   kHalf:   W = R^-T [H_nc | g_n] by half solves (A_nn = R^T R, SparseCholesky::HalfSolve), held
//            whole, and S -= W_c^T W_c by matrix products: one triangular solve per column
//            instead of two, for W's n x (c + 1) doubles (the border's rows of the whole H's
//            Cholesky factor). The own solver's steps and covariance.
//   kChunks: A_nn^-1 [H_nc | g_n] by full solves a few columns at a time, each chunk subtracted
//            before the next: no n x c buffer. Ceres' covariance (marginal_covariance.cpp).
enum class SchurSolves { kHalf, kChunks };

// The border's information with the nuisance states marginalised, H_cc - H_cn H_nn^-1 H_nc (H_nn
// factored by CHOLMOD, SparseCholesky). A nuisance state no residual touches (zero diagonal) is
// left out exactly; a singular H_nn is damped by 1e-12, 1e-9 or 1e-6 of its largest diagonal, the
// amount returned in *nuisance_damping (0 when none was needed). Takes H's values over (H is
// released). Throws std::runtime_error when H_nn cannot be factored even damped. `factorisation`:
// the one the solve used (its analysis reused when H_nn has its pattern; its values freed
// afterwards), or null. `threads` solve its columns (SubtractBorderSchur, kSchurColumns in
// flight), by `solves`.
Eigen::MatrixXd MarginalizeNuisance(NormalEquations* normal, double* nuisance_damping,
                                    SparseCholesky* factorisation = nullptr, int threads = 1,
                                    SchurSolves solves = SchurSolves::kChunks);

// Border columns in flight in the Schur complement's solves (SubtractBorderSchur: the solver's
// step and the covariance): each solve reads the whole factor, each column costs 3 x 8 bytes per
// nuisance parameter with kHalf, 5 x 8 with kChunks (LevenbergMarquardt::NormalEquationsBytes).
constexpr int kSchurColumns = 8;

// *S -= H_nc^T A_nn^-1 H_nc with A_nn factored in `llt` (*S holds A_cc on entry: the Schur
// complement on the border), by `solves` (above). `columns_in_flight` columns are solved at once
// over all `threads` (each its own workspace), so the solves' buffers do not grow with the
// threads; the chunks and the products' column blocks are fixed by the thread count, so S depends
// on it but not on the schedule. With `g_n`, also *h_g = H_nc^T A_nn^-1 g_n (solved with the
// first chunk, or as W's last column). False when a solve is not finite.
bool SubtractBorderSchur(SparseCholesky* llt, const Eigen::MatrixXd& H_nc, int threads,
                         int columns_in_flight, SchurSolves solves, const Eigen::VectorXd* g_n,
                         Eigen::MatrixXd* S, Eigen::VectorXd* h_g);

// kHalf's two parts. *W = R^-T [H_nc | g_n] (A_nn = R^T R, SparseCholesky::HalfSolve; g_n's
// column last when given), solved as SubtractBorderSchur solves its chunks; false when a solve is
// not finite. *S -= W^T W, column blocks fixed by the thread count.
bool HalfSolveBorder(SparseCholesky* llt, const Eigen::MatrixXd& H_nc, int threads,
                     int columns_in_flight, const Eigen::VectorXd* g_n, Eigen::MatrixXd* W);
void SubtractGram(const Eigen::Ref<const Eigen::MatrixXd>& W, int threads, Eigen::MatrixXd* S);

// The threads SubtractBorderSchur uses for `c` border columns (no more than one per two columns),
// and its columns per solve (the columns in flight shared among them, two at least).
int SchurThreads(int threads, int c);
int SchurColumnsPerSolve(int threads, int c, int columns_in_flight);

}  // namespace ctcal
