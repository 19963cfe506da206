#include "ctcal/calibrator/lm_solver.h"

#include <ceres/cost_function.h>
#include <ceres/evaluation_callback.h>
#include <ceres/loss_function.h>
#include <ceres/manifold.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "ctcal/sensors/parallel_for.h"
#include "normal_equations.h"
#include "parameter_order.h"
#include "sparse_cholesky.h"
#include "thread_shares.h"

namespace ctcal {
namespace {

using Clock = std::chrono::steady_clock;
using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

// StopOnBorderDecrease judges only steps whose damping D = diag(H) / radius is negligible: a
// damped step understates the distance to the optimum (the step starts at radius 1e8 and grows
// on success; a rejected step halves it and more).
constexpr double kBorderStopRadius = 1e6;

// A free parameter block: one column block of the normal equations.
struct Column {
  double* values = nullptr;
  const ceres::Manifold* manifold = nullptr;
  int ambient = 0;
  int tangent = 0;
  std::vector<double> lower, upper;  // empty when the block has no bound
  RowMatrix plus_jacobian;           // ambient x tangent at the current point (manifolds only)
};

struct Block {
  const ceres::CostFunction* cost = nullptr;
  const ceres::LossFunction* loss = nullptr;
  std::vector<double*> params;             // every parameter block (the values' memory)
  std::vector<int> column;                 // its column block, -1 for a constant block
  std::vector<NormalEquations::Run> runs;  // the free blocks' columns in the block's Jacobian
  int rows = 0;
  int cols = 0;  // tangent columns of the free blocks
};

// One thread's evaluation buffers, Eigen's (aligned): Eigen's vectorised sums peel their first
// elements by the address' alignment, so malloc's 16-byte alignment would make the last bits
// depend on where the heap put a buffer, and two runs differ.
struct Scratch {
  Eigen::VectorXd r;
  std::vector<Eigen::VectorXd> ambient;  // per parameter block, rows x ambient
  std::vector<double*> jacobians;
  RowMatrix J;        // rows x cols, tangent
  Eigen::MatrixXd G;  // J^T J of the block (NormalEquations::AddBlock)
};

// out(r, t) = sum_k a(r, k) p(k, t) for the rows of a row-major `a` (rows x ambient) and
// `p` (ambient x tangent), into the rows of a row-major matrix with `stride` columns; the sizes
// fixed at compile time where A and T are not Eigen::Dynamic.
template <int A, int T>
void LiftRows(const double* a, int rows, const double* p, double* out, int stride, int ambient = A,
              int tangent = T) {
  if constexpr (A != Eigen::Dynamic) {
    ambient = A;
    tangent = T;
  }
  for (int row = 0; row < rows; ++row, a += ambient, out += stride) {
    for (int t = 0; t < tangent; ++t) {
      double v = 0.0;
      for (int k = 0; k < ambient; ++k)
        v += a[k] * p[k * tangent + t];
      out[t] = v;
    }
  }
}

// Ceres' robust loss applied to a block's residuals and Jacobian (Triggs et al., "Bundle
// Adjustment - A Modern Synthesis", as ceres::internal::Corrector): with s = |r|^2 and rho(s), the
// cost is rho(s) / 2 and the block is replaced by r' = sqrt(rho') / (1 - a) r, J' = sqrt(rho')
// (I - a r r^T / s) J, a = 1 - sqrt(1 + 2 s rho'' / rho') (where rho'' > 0, else a = 0), whose
// Gauss-Newton normal equations are the second-order model of rho around r.
void ApplyLoss(const ceres::LossFunction& loss, int rows, double* r, RowMatrix* J, double* cost) {
  Eigen::Map<Eigen::VectorXd> res(r, rows);
  const double s = res.squaredNorm();
  double rho[3];
  loss.Evaluate(s, rho);
  *cost = 0.5 * rho[0];
  const double sqrt_rho1 = std::sqrt(rho[1]);
  // Ceres corrects the curvature only where rho'' > 0 (a <= 0): in a loss' outlier region
  // (rho'' < 0) it only scales, which it found to converge faster.
  double scaling = sqrt_rho1, alpha_over_s = 0.0;
  if (s > 0.0 && rho[2] > 0.0) {
    const double alpha = 1.0 - std::sqrt(1.0 + 2.0 * s * rho[2] / rho[1]);
    scaling = sqrt_rho1 / (1.0 - alpha);
    alpha_over_s = alpha / s;
  }
  if (J != nullptr) {
    if (alpha_over_s == 0.0) {
      *J *= sqrt_rho1;
    } else {
      const Eigen::RowVectorXd rtJ = res.transpose() * *J;
      *J = sqrt_rho1 * (*J - alpha_over_s * res * rtJ);
    }
  }
  res *= scaling;
}

}  // namespace

class NuisanceFactorisation {
 public:
  SparseCholesky chol;            // its analysis of the last solve's pattern
  std::vector<double*> nuisance;  // the last solve's nuisance blocks, in column order
};

class LevenbergMarquardt::Impl {
 public:
  Impl(const ceres::Solver::Options& options, const std::vector<double*>& border,
       ceres::Problem* problem, ceres::EvaluationCallback* point_callback,
       std::shared_ptr<NuisanceFactorisation> shared)
      : o_(options),
        problem_(*problem),
        point_callback_(point_callback),
        shared_(std::move(shared)) {
    if (o_.minimizer_type != ceres::TRUST_REGION ||
        o_.trust_region_strategy_type != ceres::LEVENBERG_MARQUARDT)
      throw std::invalid_argument(
          "SolveLevenbergMarquardt: only TRUST_REGION with "
          "LEVENBERG_MARQUARDT");
    if (o_.jacobi_scaling || o_.use_nonmonotonic_steps || o_.use_inner_iterations)
      throw std::invalid_argument(
          "SolveLevenbergMarquardt: no Jacobi scaling, non-monotonic "
          "steps or inner iterations");
    threads_ = std::max(1, o_.num_threads);
    Setup(border);
  }

  void Solve(ceres::Solver::Summary* summary);
  const std::vector<double*>& Border() const { return border_; }
  void StopOnBorderDecrease(double cost_change) { border_stop_ = std::max(0.0, cost_change); }
  MarginalInformation MarginalizeToBorder();
  std::size_t NormalEquationsBytes() const {
    const std::size_t n = static_cast<std::size_t>(H_->n()), c = static_cast<std::size_t>(H_->c());
    const std::size_t h = static_cast<std::size_t>(H_->NonZeros()) * 12 + (n * c + c * c) * 8;
    // H once (the threads share it, PartitionBlocks), the threads' H_cc, the step's damped copy
    // of H_nn in the factorisation's order with its map (SparseCholesky), and each thread's
    // right-hand sides and solutions (SolveStep: kSchurColumns at a time; SparseCholesky's
    // permuted B, CHOLMOD's result and workspace). Not W = R^-T H_nc of the half solves
    // (SchurSolves::kHalf): it is the border's rows of the Cholesky factor of the whole H, which
    // Ceres' factorisation holds as well (AMD orders the dense border last), the part
    // CeresBytes() leaves out as common to both.
    return h + static_cast<std::size_t>(threads_ - 1) * c * c * 8 +
           static_cast<std::size_t>(H_->NonZeros()) * 16 +
           static_cast<std::size_t>(SolvingThreads()) * 3 * n *
               static_cast<std::size_t>(ColumnsPerSolve() + 1) * 8;
  }
  // SolveStep's threads and border columns per solve: kSchurColumns in flight over the threads,
  // so the step's memory does not grow with them (the own solver's choice against Ceres is by
  // memory).
  int SolvingThreads() const { return SchurThreads(threads_, H_->c()); }
  int ColumnsPerSolve() const { return SchurColumnsPerSolve(threads_, H_->c(), kSchurColumns); }
  std::size_t JacobianBytes() const { return jacobian_values_ * 8; }
  std::size_t CeresBytes() const {
    const std::size_t n = static_cast<std::size_t>(H_->n()), c = static_cast<std::size_t>(H_->c());
    // CRS: a value and its column index per entry; J^T J as its upper triangle.
    return jacobian_values_ * 12 +
           (static_cast<std::size_t>(H_->NonZeros()) + n * c + c * (c + 1) / 2) * 12;
  }

 private:
  void Setup(const std::vector<double*>& border);
  bool EvaluateBlock(const Block& b, bool jacobian, Scratch* s, double* cost) const;
  bool Evaluate(bool jacobian, double* cost);
  void Store(const Eigen::VectorXd& x);
  bool Plus(const Eigen::VectorXd& x, const Eigen::VectorXd& delta, Eigen::VectorXd* out) const;
  bool UpdatePlusJacobians();
  void GradientNorms(ceres::IterationSummary* it);
  bool SolveStep(double radius, Eigen::VectorXd* step);
  void PartitionBlocks(int nuisance_blocks);

  const ceres::Solver::Options o_;  // a copy: the solver outlives the caller's options
  ceres::Problem& problem_;
  ceres::EvaluationCallback* const point_callback_;
  int threads_ = 1;
  std::vector<Column> columns_;
  std::vector<int> offset_;  // ambient offset of each column block in x
  std::vector<Block> blocks_;
  std::unique_ptr<NormalEquations> H_;
  // Which residual blocks each thread assembles into the one H_ (Evaluate; PartitionBlocks), and
  // those that straddle two threads' nuisance blocks, assembled after them.
  std::vector<std::vector<std::size_t>> thread_blocks_;
  std::vector<std::size_t> shared_blocks_;
  std::vector<Eigen::MatrixXd> partial_cc_;  // threads 1..: their H_cc (thread 0 adds into H_'s)
  std::vector<Scratch> scratch_;
  Eigen::VectorXd g_;  // J^T r at the current point
  double fixed_cost_ = 0.0;
  int num_residuals_ = 0;
  std::size_t jacobian_values_ = 0;      // rows x tangent columns over the residual blocks
  std::shared_ptr<SparseCholesky> llt_;  // of the damped H_nn, kept for the solve's steps
  bool pattern_analysed_ = false;        // llt_ has H_nn's pattern (after a step's Factorize)
  const std::shared_ptr<NuisanceFactorisation> shared_;  // the caller's, or null
  std::vector<double*> border_;
  bool final_point_ = false;  // H_ holds the normal equations at the solve's final point
  double border_stop_ = 0.0;  // StopOnBorderDecrease's cost change (0: off)
  double border_decrease_ = std::numeric_limits<double>::infinity();  // of the last step
};

void LevenbergMarquardt::Impl::Setup(const std::vector<double*>& border) {
  std::vector<ceres::ResidualBlockId> ids;
  problem_.GetResidualBlocks(&ids);
  std::unordered_map<const double*, int> column_of;
  const std::vector<double*> order = ParameterBlocksInResidualOrder(problem_);
  // Free blocks that some residual block reads (Ceres' preprocessor drops the others): the
  // nuisance blocks in the problem's order, then the border in the caller's.
  std::unordered_map<const double*, bool> used;
  std::vector<double*> params;
  for (const ceres::ResidualBlockId id : ids) {
    problem_.GetParameterBlocksForResidualBlock(id, &params);
    for (double* p : params) {
      if (!problem_.IsParameterBlockConstant(p))
        used[p] = true;
    }
  }
  std::unordered_map<const double*, bool> is_border;
  for (double* p : border) {
    if (used.count(p))
      is_border[p] = true;
  }
  const auto add_column = [&](double* p) {
    Column c;
    c.values = p;
    c.manifold = problem_.GetManifold(p);
    c.ambient = problem_.ParameterBlockSize(p);
    c.tangent = problem_.ParameterBlockTangentSize(p);
    bool bounded = false;
    std::vector<double> lo(static_cast<std::size_t>(c.ambient)),
        hi(static_cast<std::size_t>(c.ambient));
    for (int i = 0; i < c.ambient; ++i) {
      lo[static_cast<std::size_t>(i)] = problem_.GetParameterLowerBound(p, i);
      hi[static_cast<std::size_t>(i)] = problem_.GetParameterUpperBound(p, i);
      bounded = bounded || lo[static_cast<std::size_t>(i)] > -std::numeric_limits<double>::max() ||
                hi[static_cast<std::size_t>(i)] < std::numeric_limits<double>::max();
    }
    if (bounded) {
      c.lower = std::move(lo);
      c.upper = std::move(hi);
    }
    column_of.emplace(p, static_cast<int>(columns_.size()));
    columns_.push_back(std::move(c));
  };
  std::vector<double*> nuisance_blocks;
  for (double* p : order) {
    if (used.count(p) && !is_border.count(p))
      nuisance_blocks.push_back(p);
  }
  if (shared_ != nullptr) {
    // The last solve's order where the blocks are the same: a deterministic order kept.
    const std::unordered_set<const double*> now(nuisance_blocks.begin(), nuisance_blocks.end());
    const std::vector<double*>& last = shared_->nuisance;
    if (last.size() == now.size() &&
        std::all_of(last.begin(), last.end(), [&](const double* p) { return now.count(p) > 0; }))
      nuisance_blocks = last;
    shared_->nuisance = nuisance_blocks;
  }
  for (double* p : nuisance_blocks)
    add_column(p);
  const int nuisance = static_cast<int>(columns_.size());
  for (double* p : border) {
    if (is_border.count(p) && !column_of.count(p)) {
      add_column(p);
      border_.push_back(p);
    }
  }
  offset_.assign(columns_.size() + 1, 0);
  std::vector<int> tangent;
  for (std::size_t k = 0; k < columns_.size(); ++k) {
    offset_[k + 1] = offset_[k] + columns_[k].ambient;
    tangent.push_back(columns_[k].tangent);
  }

  // The residual blocks with a free parameter block; the others are Ceres' fixed cost.
  std::vector<std::vector<int>> blocks_of;
  Scratch fixed;
  for (const ceres::ResidualBlockId id : ids) {
    Block b;
    b.cost = problem_.GetCostFunctionForResidualBlock(id);
    b.loss = problem_.GetLossFunctionForResidualBlock(id);
    problem_.GetParameterBlocksForResidualBlock(id, &b.params);
    b.rows = b.cost->num_residuals();
    std::vector<int> cols;
    for (double* p : b.params) {
      const auto it = column_of.find(p);
      const int k = it == column_of.end() ? -1 : it->second;
      b.column.push_back(k);
      if (k >= 0) {
        b.runs.push_back(NormalEquations::Run{k, b.cols});
        b.cols += columns_[static_cast<std::size_t>(k)].tangent;
        cols.push_back(k);
      }
    }
    if (cols.empty()) {
      double cost = 0.0;
      if (point_callback_ != nullptr)
        point_callback_->PrepareForEvaluation(false, true);
      if (!EvaluateBlock(b, false, &fixed, &cost))
        throw std::runtime_error(
            "SolveLevenbergMarquardt: a constant residual block cannot be "
            "evaluated at the initial point");
      fixed_cost_ += cost;
      continue;
    }
    num_residuals_ += b.rows;
    jacobian_values_ += static_cast<std::size_t>(b.rows) * static_cast<std::size_t>(b.cols);
    blocks_of.push_back(std::move(cols));
    blocks_.push_back(std::move(b));
  }
  // The pattern's shape only: the caller may hand the problem to Ceres by NormalEquationsBytes()
  // before any of it is allocated (Solve allocates).
  H_ = std::make_unique<NormalEquations>(std::move(tangent), nuisance, blocks_of, false);
  threads_ = static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(threads_),
                                                    std::max<std::size_t>(blocks_.size(), 1)));
  PartitionBlocks(nuisance);
  partial_cc_.assign(static_cast<std::size_t>(threads_ - 1), Eigen::MatrixXd());
  scratch_.resize(static_cast<std::size_t>(threads_));
  g_.resize(H_->n() + H_->c());
}

bool LevenbergMarquardt::Impl::EvaluateBlock(const Block& b, bool jacobian, Scratch* s,
                                             double* cost) const {
  s->r.resize(b.rows);
  const std::size_t np = b.params.size();
  if (jacobian) {
    s->ambient.resize(std::max(s->ambient.size(), np));
    s->jacobians.assign(np, nullptr);
    for (std::size_t i = 0; i < np; ++i) {
      if (b.column[i] < 0)
        continue;
      const Column& c = columns_[static_cast<std::size_t>(b.column[i])];
      s->ambient[i].resize(b.rows * c.ambient);
      s->jacobians[i] = s->ambient[i].data();
    }
  }
  if (!b.cost->Evaluate(b.params.data(), s->r.data(), jacobian ? s->jacobians.data() : nullptr))
    return false;
  const Eigen::Map<const Eigen::VectorXd> r(s->r.data(), b.rows);
  if (!r.allFinite())
    return false;
  if (jacobian) {
    // The ambient Jacobians lifted to the tangent spaces: J_b = dr/dx dPlus(x, d)/dd at d = 0.
    s->J.resize(b.rows, b.cols);
    int first = 0;
    for (std::size_t i = 0; i < np; ++i) {
      if (b.column[i] < 0)
        continue;
      const Column& c = columns_[static_cast<std::size_t>(b.column[i])];
      const Eigen::Map<const RowMatrix> Ja(s->ambient[i].data(), b.rows, c.ambient);
      if (!Ja.allFinite())
        return false;
      if (c.manifold != nullptr) {
        // A few ambient coordinates (a quaternion's 4) per row: plain loops, which Eigen's
        // general product kernel (its packing and blocking set up per block) cost more
        // instructions for. Each entry summed from zero in the ambient order, as that kernel did.
        if (c.ambient == 4 && c.tangent == 3)
          LiftRows<4, 3>(Ja.data(), b.rows, c.plus_jacobian.data(), &s->J(0, first), b.cols);
        else
          LiftRows<Eigen::Dynamic, Eigen::Dynamic>(Ja.data(), b.rows, c.plus_jacobian.data(),
                                                   &s->J(0, first), b.cols, c.ambient, c.tangent);
      } else
        s->J.middleCols(first, c.tangent) = Ja;
      first += c.tangent;
    }
  }
  if (b.loss != nullptr)
    ApplyLoss(*b.loss, b.rows, s->r.data(), jacobian ? &s->J : nullptr, cost);
  else
    *cost = 0.5 * r.squaredNorm();
  return true;
}

// The threads' shares of the assembly of H = J^T J (thread_shares.h), the work of a block taken as
// rows x columns^2 (its J_b^T J_b). The result depends only on the thread count.
void LevenbergMarquardt::Impl::PartitionBlocks(int nuisance_blocks) {
  std::vector<std::vector<int>> nuisance_of(blocks_.size());
  std::vector<double> work(blocks_.size());
  for (std::size_t i = 0; i < blocks_.size(); ++i) {
    for (const NormalEquations::Run& run : blocks_[i].runs) {
      if (run.block < nuisance_blocks)
        nuisance_of[i].push_back(run.block);
    }
    work[i] = static_cast<double>(blocks_[i].rows) * blocks_[i].cols * blocks_[i].cols;
  }
  ThreadShares shares = ShareBlocks(nuisance_of, work, nuisance_blocks, threads_);
  thread_blocks_ = std::move(shares.own);
  shared_blocks_ = std::move(shares.shared);
}

// The cost at the values in the parameter blocks' memory (without the fixed cost) and, with
// `jacobian`, H = J^T J and g = J^T r there. Thread t takes its share of PartitionBlocks, then
// thread 0 the blocks that straddle two shares; the partial sums are added in thread order: the
// same sums for the same thread count whatever the schedule, and the same cost with or without
// `jacobian` (the step's acceptance compares the two).
bool LevenbergMarquardt::Impl::Evaluate(bool jacobian, double* cost) {
  const std::size_t T = static_cast<std::size_t>(threads_);
  std::vector<double> costs(T, 0.0);
  std::vector<char> ok(T, 1);
  std::vector<Eigen::VectorXd> g(T);
  // Every pass is announced as a new point: the solver moves x between passes without telling
  // which point it returns to, and a callback's cache keyed by its calls stays correct that way.
  if (point_callback_ != nullptr)
    point_callback_->PrepareForEvaluation(jacobian, true);
  // One residual block into the sums of thread t (false: not finite or not evaluable).
  const auto add = [&](std::size_t t, std::size_t i, Eigen::MatrixXd* H_cc) {
    const Block& b = blocks_[i];
    Scratch& s = scratch_[t];
    double c = 0.0;
    if (!EvaluateBlock(b, jacobian, &s, &c))
      return false;
    costs[t] += c;
    if (!jacobian)
      return true;
    H_->AddBlock(s.J.data(), b.rows, b.cols, b.runs, &s.G, H_cc);
    const Eigen::Map<const Eigen::VectorXd> r(s.r.data(), b.rows);
    for (const NormalEquations::Run& run : b.runs) {
      const int t_b = H_->Tangent(run.block);
      g[t].segment(H_->Offset(run.block), t_b).noalias() +=
          s.J.middleCols(run.first, t_b).transpose() * r;
    }
    return true;
  };
  if (jacobian)
    H_->SetZero();
  ParallelFor(threads_, T, [&](std::size_t t) {
    Eigen::MatrixXd* H_cc = nullptr;
    if (jacobian) {
      H_cc = t == 0 ? &H_->H_cc() : &partial_cc_[t - 1];
      if (t > 0)
        H_cc->setZero(H_->c(), H_->c());
      g[t].setZero(g_.size());
    }
    for (const std::size_t i : thread_blocks_[t]) {
      if (!add(t, i, H_cc)) {
        ok[t] = 0;
        return;
      }
    }
  });
  if (ok[0]) {
    for (const std::size_t i : shared_blocks_) {
      if (!add(0, i, jacobian ? &H_->H_cc() : nullptr)) {
        ok[0] = 0;
        break;
      }
    }
  }
  *cost = 0.0;
  for (std::size_t t = 0; t < T; ++t) {
    if (!ok[t])
      return false;
    *cost += costs[t];
  }
  if (!std::isfinite(*cost))
    return false;
  if (jacobian) {
    g_ = g[0];
    for (std::size_t t = 1; t < T; ++t) {
      H_->H_cc() += partial_cc_[t - 1];
      g_ += g[t];
    }
  }
  return true;
}

void LevenbergMarquardt::Impl::Store(const Eigen::VectorXd& x) {
  for (std::size_t k = 0; k < columns_.size(); ++k)
    std::copy(x.data() + offset_[k], x.data() + offset_[k + 1], columns_[k].values);
}

// x [+] delta block by block, projected on the bounds (Ceres' ParameterBlock::Plus).
bool LevenbergMarquardt::Impl::Plus(const Eigen::VectorXd& x, const Eigen::VectorXd& delta,
                                    Eigen::VectorXd* out) const {
  out->resize(x.size());
  for (std::size_t k = 0; k < columns_.size(); ++k) {
    const Column& c = columns_[k];
    const double* xk = x.data() + offset_[k];
    const double* dk = delta.data() + H_->Offset(static_cast<int>(k));
    double* yk = out->data() + offset_[k];
    if (c.manifold != nullptr) {
      if (!c.manifold->Plus(xk, dk, yk))
        return false;
    } else {
      for (int i = 0; i < c.ambient; ++i)
        yk[i] = xk[i] + dk[i];
    }
    for (std::size_t i = 0; i < c.lower.size(); ++i)
      yk[i] = std::min(std::max(yk[i], c.lower[i]), c.upper[i]);
  }
  return true;
}

bool LevenbergMarquardt::Impl::UpdatePlusJacobians() {
  for (Column& c : columns_) {
    if (c.manifold == nullptr)
      continue;
    c.plus_jacobian.resize(c.ambient, c.tangent);
    if (!c.manifold->PlusJacobian(c.values, c.plus_jacobian.data()))
      return false;
  }
  return true;
}

// Ceres' gradient norms: of x - Plus(x, -g) (the projected gradient), at the current point.
void LevenbergMarquardt::Impl::GradientNorms(ceres::IterationSummary* it) {
  Eigen::VectorXd x(offset_.back()), y;
  for (std::size_t k = 0; k < columns_.size(); ++k)
    std::copy(columns_[k].values, columns_[k].values + columns_[k].ambient, x.data() + offset_[k]);
  if (!Plus(x, -g_, &y)) {
    it->gradient_max_norm = it->gradient_norm = std::numeric_limits<double>::infinity();
    return;
  }
  it->gradient_max_norm = (x - y).lpNorm<Eigen::Infinity>();
  it->gradient_norm = (x - y).norm();
}

// The damped step (the header's Schur complement). False when a factorisation fails.
bool LevenbergMarquardt::Impl::SolveStep(double radius, Eigen::VectorXd* step) {
  const int n = H_->n(), c = H_->c();
  Eigen::VectorXd D = H_->Diagonal().cwiseMax(o_.min_lm_diagonal).cwiseMin(o_.max_lm_diagonal);
  D /= radius;
  step->resize(n + c);
  // A_nn = R^T R. W = R^-T [H_nc | g_n] (half solves): S = A_cc - H_cn A_nn^-1 H_nc = A_cc -
  // W_c^T W_c, H_cn A_nn^-1 g_n = W_c^T w_g, and d_n = -A_nn^-1 (g_n + H_nc d_c) = -R^-1 (w_g +
  // W_c d_c): one triangular solve per border column instead of two (on one thread the demo
  // rig's 97 border columns were ~3/4 of its step; EuRoC's 36 s: the border ~33 -> ~16 ms a step
  // on two threads), and one more for d_n instead of a full solve.
  Eigen::MatrixXd W;
  Eigen::MatrixXd S;  // the Schur complement on the border
  if (n > 0) {
    if (llt_ == nullptr)
      llt_ = shared_ != nullptr ? std::shared_ptr<SparseCholesky>(shared_, &shared_->chol)
                                : std::make_shared<SparseCholesky>();
    llt_->SetThreads(threads_);
    // A_nn = H_nn + D's first n; H_nn's pattern is fixed from the solve's first factorisation on.
    const bool factored = llt_->Factorize(H_->H_nn(), D, pattern_analysed_);
    pattern_analysed_ = true;
    if (!factored)
      return false;
    const Eigen::VectorXd g_n = g_.head(n);
    if (!HalfSolveBorder(llt_.get(), H_->H_nc(), threads_, kSchurColumns, &g_n, &W))
      return false;
  }
  if (c > 0) {
    S = H_->H_cc();
    Eigen::VectorXd rhs = -g_.tail(c);
    if (n > 0) {
      SubtractGram(W.leftCols(c), threads_, &S);
      rhs.noalias() += W.leftCols(c).transpose() * W.col(c);
    }
    S.diagonal() += D.tail(c);
    const Eigen::LLT<Eigen::MatrixXd, Eigen::Lower> llt(S);
    if (llt.info() != Eigen::Success)
      return false;
    step->tail(c) = llt.solve(rhs);
    // The border's share of the model decrease, 1/2 d_c^T S d_c, with S undamped.
    const Eigen::VectorXd d_c = step->tail(c);
    border_decrease_ = 0.5 * (d_c.dot(S * d_c) - d_c.dot(D.tail(c).cwiseProduct(d_c)));
  } else {
    // No border, no calibration to have converged: the rule does not apply (a zero would end
    // the solve before its first step).
    border_decrease_ = std::numeric_limits<double>::infinity();
  }
  if (n > 0) {
    Eigen::VectorXd z = W.col(c);
    if (c > 0)
      z.noalias() += W.leftCols(c) * step->tail(c);
    W = Eigen::MatrixXd();
    SparseCholesky::Workspace workspace;
    Eigen::MatrixXd d_n;
    if (!llt_->HalfSolveBack(z, &d_n, &workspace))
      return false;
    step->head(n) = -d_n;
  }
  if (llt_ != nullptr)
    llt_->ReleaseSolveWorkspace();
  return step->allFinite();
}

void LevenbergMarquardt::Impl::Solve(ceres::Solver::Summary* summary) {
  const auto t_start = Clock::now();
  H_->Allocate();
  ceres::Solver::Summary& S = *summary;
  S = ceres::Solver::Summary();
  S.minimizer_type = ceres::TRUST_REGION;
  S.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  S.linear_solver_type_given = o_.linear_solver_type;
  S.linear_solver_type_used = o_.linear_solver_type;
  S.num_threads_given = o_.num_threads;
  S.num_threads_used = threads_;
  S.fixed_cost = fixed_cost_;
  // Summary's counts and times start at -1 (not computed).
  S.num_linear_solves = S.num_residual_evaluations = S.num_jacobian_evaluations = 0;
  S.num_successful_steps = S.num_unsuccessful_steps = 0;
  S.residual_evaluation_time_in_seconds = S.jacobian_evaluation_time_in_seconds = 0.0;
  S.linear_solver_time_in_seconds = 0.0;
  S.preprocessor_time_in_seconds = S.postprocessor_time_in_seconds = 0.0;
  S.num_residual_blocks = static_cast<int>(blocks_.size());
  S.num_residual_blocks_reduced = S.num_residual_blocks;
  S.num_residuals = num_residuals_;
  S.num_residuals_reduced = num_residuals_;
  S.num_parameter_blocks = static_cast<int>(columns_.size());
  S.num_parameter_blocks_reduced = S.num_parameter_blocks;
  S.num_parameters = S.num_parameters_reduced = offset_.back();
  S.num_effective_parameters = S.num_effective_parameters_reduced = H_->n() + H_->c();
  // Whether H_ and g_ are at x: after an accepted step they are evaluated lazily, at the start of
  // the next iteration, so that a solve a callback or the iteration limit ends right after the
  // step does not assemble them for nothing (the robust solve's RobustStageStop: one J^T J less).
  bool jacobian_at_x = true;
  const auto finish = [&](ceres::TerminationType type, const std::string& message, double x_cost) {
    // Only the normal equations at the final point outlive the solve (MarginalizeToBorder).
    final_point_ = type != ceres::FAILURE && jacobian_at_x;
    partial_cc_.clear();
    scratch_.clear();
    // A caller's factorisation keeps its numeric factor for the next solve or the covariance of
    // the same pattern (the final solve, MarginalizeNuisance, which frees it): factoring into a
    // released one allocates and fills L's columns anew (EuRoC's 36 s: 112 instead of 27 ms, each
    // time). The peak, in a Jacobian pass beside H and the factor, stays (measured).
    if (llt_ != nullptr)
      llt_->ReleaseSolveWorkspace();
    llt_.reset();
    pattern_analysed_ = false;
    S.termination_type = type;
    S.message = message;
    S.final_cost = x_cost + fixed_cost_;
    S.total_time_in_seconds = Seconds(t_start);
    S.minimizer_time_in_seconds = S.total_time_in_seconds;
  };

  Eigen::VectorXd x(offset_.back()), candidate, step;
  for (std::size_t k = 0; k < columns_.size(); ++k)
    std::copy(columns_[k].values, columns_[k].values + columns_[k].ambient, x.data() + offset_[k]);
  double x_cost = 0.0;
  const auto evaluate_jacobian = [&]() {
    const auto t = Clock::now();
    const bool ok = UpdatePlusJacobians() && Evaluate(true, &x_cost);
    S.jacobian_evaluation_time_in_seconds += Seconds(t);
    ++S.num_jacobian_evaluations;
    return ok;
  };

  // Iteration 0.
  ceres::IterationSummary it;
  it.iteration = 0;
  if (!evaluate_jacobian()) {
    finish(ceres::FAILURE, "Initial residual and Jacobian evaluation failed.", x_cost);
    S.initial_cost = S.final_cost;
    return;
  }
  S.initial_cost = x_cost + fixed_cost_;
  it.cost = S.initial_cost;
  it.step_is_valid = it.step_is_successful = true;
  GradientNorms(&it);

  double radius = o_.initial_trust_region_radius;
  double decrease_factor = 2.0;
  int invalid_steps = 0;
  const auto run_callbacks = [&]() -> bool {
    it.trust_region_radius = radius;
    it.cumulative_time_in_seconds = Seconds(t_start);
    // Ceres counts iteration 0 as a successful step.
    ++(it.step_is_successful ? S.num_successful_steps : S.num_unsuccessful_steps);
    S.iterations.push_back(it);
    for (ceres::IterationCallback* callback : o_.callbacks) {
      switch ((*callback)(it)) {
        case ceres::SOLVER_CONTINUE:
          break;
        case ceres::SOLVER_ABORT:
          finish(ceres::USER_FAILURE, "User callback returned SOLVER_ABORT.", x_cost);
          return false;
        case ceres::SOLVER_TERMINATE_SUCCESSFULLY:
          finish(ceres::USER_SUCCESS, "User callback returned SOLVER_TERMINATE_SUCCESSFULLY.",
                 x_cost);
          return false;
      }
    }
    if (it.iteration >= o_.max_num_iterations) {
      finish(ceres::NO_CONVERGENCE, "Maximum number of iterations reached.", x_cost);
      return false;
    }
    if (jacobian_at_x && it.step_is_successful && it.gradient_max_norm <= o_.gradient_tolerance) {
      finish(ceres::CONVERGENCE, "Gradient tolerance reached.", x_cost);
      return false;
    }
    if (radius <= o_.min_trust_region_radius) {
      finish(ceres::CONVERGENCE, "Minimum trust region radius reached.", x_cost);
      return false;
    }
    return true;
  };
  const auto rejected = [&]() {
    radius /= decrease_factor;
    decrease_factor *= 2.0;
  };

  while (run_callbacks()) {
    const auto t_iteration = Clock::now();
    const ceres::IterationSummary previous = it;
    it = ceres::IterationSummary();
    it.iteration = previous.iteration + 1;
    it.gradient_max_norm = previous.gradient_max_norm;
    it.gradient_norm = previous.gradient_norm;
    if (!jacobian_at_x) {
      if (!evaluate_jacobian()) {
        finish(ceres::FAILURE, "Residual and Jacobian evaluation failed.", x_cost);
        return;
      }
      jacobian_at_x = true;
      GradientNorms(&it);
      if (it.gradient_max_norm <= o_.gradient_tolerance) {
        finish(ceres::CONVERGENCE, "Gradient tolerance reached.", x_cost);
        return;
      }
    }
    const auto t_linear = Clock::now();
    bool valid = SolveStep(radius, &step);
    ++S.num_linear_solves;
    it.linear_solver_iterations = 1;
    double model_cost_change = 0.0;
    if (valid) {
      // The Gauss-Newton model's decrease, without the damping: -(d^T g + d^T H d / 2).
      model_cost_change = -(step.dot(g_) + 0.5 * step.dot(H_->Multiply(step)));
      valid = model_cost_change > 0.0;
    }
    it.step_solver_time_in_seconds = Seconds(t_linear);
    S.linear_solver_time_in_seconds += it.step_solver_time_in_seconds;
    if (!valid) {
      if (++invalid_steps >= o_.max_num_consecutive_invalid_steps) {
        finish(ceres::FAILURE,
               "Number of consecutive invalid steps more than "
               "Solver::Options::max_num_consecutive_invalid_steps: " +
                   std::to_string(o_.max_num_consecutive_invalid_steps),
               x_cost);
        return;
      }
      rejected();
      it.step_is_valid = it.step_is_successful = false;
      it.cost = x_cost + fixed_cost_;
      it.iteration_time_in_seconds = Seconds(t_iteration);
      continue;
    }
    invalid_steps = 0;
    it.step_is_valid = true;
    // The border converged (StopOnBorderDecrease): the point stays, with its normal equations.
    if (border_stop_ > 0.0 && radius >= kBorderStopRadius && border_decrease_ < border_stop_) {
      finish(ceres::CONVERGENCE, "Border's predicted decrease below its tolerance.", x_cost);
      return;
    }

    // The candidate, evaluated in the parameter blocks' memory.
    double candidate_cost = std::numeric_limits<double>::max();
    if (Plus(x, step, &candidate)) {
      Store(candidate);
      const auto t = Clock::now();
      double c = 0.0;
      if (Evaluate(false, &c))
        candidate_cost = c;
      S.residual_evaluation_time_in_seconds += Seconds(t);
      ++S.num_residual_evaluations;
    } else {
      candidate = x;
    }
    it.step_norm = (x - candidate).norm();
    if (it.step_norm <= (x.norm() + o_.parameter_tolerance) * o_.parameter_tolerance) {
      Store(x);
      finish(ceres::CONVERGENCE, "Parameter tolerance reached.", x_cost);
      return;
    }
    it.cost_change = x_cost - candidate_cost;
    if (std::abs(it.cost_change) <= o_.function_tolerance * x_cost) {
      Store(x);
      finish(ceres::CONVERGENCE, "Function tolerance reached.", x_cost);
      return;
    }
    it.relative_decrease = it.cost_change / model_cost_change;
    if (it.relative_decrease > o_.min_relative_decrease) {
      // The callbacks see the gradient norms of the point before the step (lazy H, above).
      x.swap(candidate);
      x_cost = candidate_cost;
      jacobian_at_x = false;
      it.step_is_successful = true;
      radius = std::min(
          o_.max_trust_region_radius,
          radius / std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * it.relative_decrease - 1.0, 3)));
      decrease_factor = 2.0;
    } else {
      Store(x);
      rejected();
      it.step_is_successful = false;
    }
    it.cost = x_cost + fixed_cost_;
    it.iteration_time_in_seconds = Seconds(t_iteration);
  }
}

MarginalInformation LevenbergMarquardt::Impl::MarginalizeToBorder() {
  if (!final_point_ || H_ == nullptr)
    throw std::logic_error("MarginalizeToBorder: no normal equations at a solve's final point");
  MarginalInformation out;
  out.nuisance_dimension = H_->n();
  out.information = MarginalizeNuisance(H_.get(), &out.nuisance_damping,
                                        shared_ != nullptr ? &shared_->chol : nullptr, threads_,
                                        SchurSolves::kHalf);
  H_.reset();
  return out;
}

LevenbergMarquardt::LevenbergMarquardt(const ceres::Solver::Options& options,
                                       const std::vector<double*>& border, ceres::Problem* problem,
                                       ceres::EvaluationCallback* point_callback,
                                       std::shared_ptr<NuisanceFactorisation> shared)
    : impl_(std::make_unique<Impl>(options, border, problem, point_callback, std::move(shared))) {}
LevenbergMarquardt::~LevenbergMarquardt() = default;
void LevenbergMarquardt::Solve(ceres::Solver::Summary* summary) {
  impl_->Solve(summary);
}
void LevenbergMarquardt::StopOnBorderDecrease(double cost_change) {
  impl_->StopOnBorderDecrease(cost_change);
}
const std::vector<double*>& LevenbergMarquardt::Border() const {
  return impl_->Border();
}
std::size_t LevenbergMarquardt::NormalEquationsBytes() const {
  return impl_->NormalEquationsBytes();
}
std::size_t LevenbergMarquardt::JacobianBytes() const {
  return impl_->JacobianBytes();
}
std::size_t LevenbergMarquardt::CeresBytes() const {
  return impl_->CeresBytes();
}
MarginalInformation LevenbergMarquardt::MarginalizeToBorder() {
  return impl_->MarginalizeToBorder();
}

std::shared_ptr<NuisanceFactorisation> MakeNuisanceFactorisation() {
  return std::make_shared<NuisanceFactorisation>();
}

void SolveLevenbergMarquardt(const ceres::Solver::Options& options,
                             const std::vector<double*>& border, ceres::Problem* problem,
                             ceres::Solver::Summary* summary,
                             ceres::EvaluationCallback* point_callback) {
  LevenbergMarquardt(options, border, problem, point_callback).Solve(summary);
}

}  // namespace ctcal
