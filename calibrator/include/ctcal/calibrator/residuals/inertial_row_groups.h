// A compressed inertial block (inertial_block_residual.h) handed to Ceres as several residual
// blocks, one per group of its factor's rows, each over only the parameter blocks those rows can
// touch (docs/performance.md step 7g).
//
// Why. The compressed block returns r = [z; last] with the Jacobian [R; 0], R upper triangular
// over the block's tangent columns in the block order (trajectory knots, then the sensor's common
// blocks). The rows of block u (tangent rows tan_col[u] ..) are therefore zero in every column of
// the blocks before u, but Ceres stores a residual block's Jacobian densely over all of its
// parameter blocks: 111 rows x 110 columns for a 1 kHz IMU run of K = 9 segments, ~225 MB for
// 10 min. Cut the rows at block boundaries into groups g = [b_g, b_g+1) (the trajectory blocks in
// kTrajectoryGroups parts, then the common blocks with the remainder row) and give group g the
// parameter blocks b_g .. end only: 7458 instead of 12210 values for that run (-39 %).
//
// Exactness. The groups hold disjoint rows of the same r and [R; 0], so the cost ||r||^2, the
// gradient [R; 0]^T r and the Gauss-Newton Hessian R^T R are the whole block's (as for the frames'
// split rows, frame_corners_residual.h). A group's values depend on every block of the run,
// including the knots before b_g that are not its parameters: it reads those from the blocks'
// own memory, which is the evaluation point when the problem has an EvaluationCallback (Ceres
// writes each point there before evaluating; the calibrator installs one and counts its calls).
//
// One factorisation per run and evaluation point. The groups share the run (SharedInertialRun):
// the first group evaluated at a new point evaluates the whole block (samples, QR: the expensive
// part) into the run's cache, every group copies its rows from there, and the last reader frees
// the cache. A point is identified by the callback's call counter (`generation`), which Ceres
// bumps before every evaluation pass; Ceres evaluates the groups of one pass on several threads in
// any order, hence a mutex per run. Ceres evaluates residual blocks in chunks of consecutive
// blocks, so a run's groups are read close together and only a few caches are alive at a time.
// The whole block is evaluated with the Jacobians of every knot (the calibrator never holds a knot
// constant) and of the common blocks Ceres asks this group for (every group has all of them).
//
// Residual-only evaluations (Ceres' candidate steps): the whole block returns r = [0; sqrt(c)]
// there (no factorisation), so the group holding the remainder row evaluates the cost and the
// others return zeros without any work.
#pragma once

#include <ceres/ceres.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <utility>
#include <vector>

#include "ctcal/calibrator/residuals/inertial_block_residual.h"

namespace ctcal {

// The whole block of one run, its parameter blocks, and the cache of its outputs at one point.
class SharedInertialRun {
 public:
  // whole: the run's compressed block (not stacked); blocks: its parameter blocks in its order;
  // generation: the problem's evaluation-point counter (file comment), which must outlive the run.
  SharedInertialRun(std::unique_ptr<ceres::CostFunction> whole, std::vector<double*> blocks,
                    const std::atomic<std::uint64_t>* generation)
      : whole_(std::move(whole)), blocks_(std::move(blocks)), generation_(generation) {
    if (whole_ == nullptr || generation_ == nullptr ||
        blocks_.size() != whole_->parameter_block_sizes().size())
      throw std::invalid_argument("SharedInertialRun: inconsistent block");
  }

  const ceres::CostFunction& whole() const { return *whole_; }
  const std::vector<double*>& blocks() const { return blocks_; }

  // The whole block's residual-only evaluation at the point in the blocks' memory.
  bool EvaluateResidualsOnly(double* residuals) const {
    return whole_->Evaluate(blocks_.data(), residuals, nullptr);
  }

  // Copies rows [row0, row0 + rows) of the whole block's residuals and of its Jacobians of blocks
  // first .. end (jacobians[u - first], nullptr: not wanted) at the current point; the whole
  // block is evaluated once per point for all `readers` groups (file comment).
  bool ReadRows(int first, int row0, int rows, int readers, double* residuals, double** jacobians) {
    const std::uint64_t point = generation_->load(std::memory_order_acquire);
    const std::size_t num_blocks = blocks_.size();
    const std::vector<std::int32_t>& sizes = whole_->parameter_block_sizes();
    const int num_rows = whole_->num_residuals();
    std::lock_guard<std::mutex> lock(mutex_);
    if (point_ != point || pending_ <= 0) {
      // The common blocks' Jacobians as this group wants them; every knot's (file comment).
      wanted_.assign(num_blocks, true);
      for (std::size_t u = static_cast<std::size_t>(first); u < num_blocks; ++u)
        wanted_[u] = jacobians[u - static_cast<std::size_t>(first)] != nullptr;
      std::size_t total = static_cast<std::size_t>(num_rows);
      for (std::size_t u = 0; u < num_blocks; ++u)
        total += static_cast<std::size_t>(num_rows) * static_cast<std::size_t>(sizes[u]);
      cache_.assign(total, 0.0);
      std::vector<double*> J(num_blocks, nullptr);
      std::size_t offset = static_cast<std::size_t>(num_rows);
      for (std::size_t u = 0; u < num_blocks; ++u) {
        if (wanted_[u])
          J[u] = cache_.data() + offset;
        offset += static_cast<std::size_t>(num_rows) * static_cast<std::size_t>(sizes[u]);
      }
      ok_ = whole_->Evaluate(blocks_.data(), cache_.data(), J.data());
      point_ = point;
      pending_ = readers;
    }
    --pending_;
    bool ok = ok_;
    if (ok) {
      std::copy_n(cache_.data() + row0, rows, residuals);
      std::size_t offset = static_cast<std::size_t>(num_rows);
      for (std::size_t u = 0; u < num_blocks; ++u) {
        const std::size_t size = static_cast<std::size_t>(sizes[u]);
        if (u >= static_cast<std::size_t>(first)) {
          double* out = jacobians[u - static_cast<std::size_t>(first)];
          if (out != nullptr && !wanted_[u]) {
            ok = false;  // another group wanted other common blocks at this point: cannot happen
          } else if (out != nullptr) {
            std::copy_n(cache_.data() + offset + static_cast<std::size_t>(row0) * size,
                        static_cast<std::size_t>(rows) * size, out);
          }
        }
        offset += static_cast<std::size_t>(num_rows) * size;
      }
    }
    if (pending_ == 0)
      std::vector<double>().swap(cache_);  // every group has its rows: free the cache
    return ok;
  }

 private:
  std::unique_ptr<ceres::CostFunction> whole_;
  std::vector<double*> blocks_;
  const std::atomic<std::uint64_t>* generation_;
  std::mutex mutex_;
  std::uint64_t point_ = ~std::uint64_t{0};
  int pending_ = 0;
  bool ok_ = false;
  std::vector<bool> wanted_;
  std::vector<double> cache_;  // residuals, then each block's row-major Jacobian
};

// One group of rows of a shared run: its rows [row0, row0 + rows) over blocks first .. end of the
// whole block (the last group also holds the remainder row).
class InertialRowGroup final : public ceres::CostFunction {
 public:
  InertialRowGroup(std::shared_ptr<SharedInertialRun> run, int first, int row0, int rows,
                   int readers)
      : run_(std::move(run)), first_(first), row0_(row0), rows_(rows), readers_(readers) {
    const std::vector<std::int32_t>& sizes = run_->whole().parameter_block_sizes();
    if (first < 0 || first >= static_cast<int>(sizes.size()) || row0 < 0 || rows < 1 ||
        row0 + rows > run_->whole().num_residuals() || readers < 1)
      throw std::invalid_argument("InertialRowGroup: rows or blocks out of range");
    set_num_residuals(rows);
    mutable_parameter_block_sizes()->assign(sizes.begin() + first, sizes.end());
  }

  // Whether this group holds the whole block's last row (the remainder, and the cost of a
  // residual-only evaluation).
  bool HoldsLastRow() const { return row0_ + rows_ == run_->whole().num_residuals(); }

  bool Evaluate(double const* const* /*p: the blocks' memory, which the run reads*/,
                double* residuals, double** jacobians) const override {
    if (jacobians == nullptr) {
      std::fill_n(residuals, rows_, 0.0);
      if (!HoldsLastRow())
        return true;
      std::vector<double> whole(static_cast<std::size_t>(run_->whole().num_residuals()));
      if (!run_->EvaluateResidualsOnly(whole.data()))
        return false;
      std::copy_n(whole.data() + row0_, rows_, residuals);
      return true;
    }
    return run_->ReadRows(first_, row0_, rows_, readers_, residuals, jacobians);
  }

 private:
  std::shared_ptr<SharedInertialRun> run_;
  int first_;
  int row0_;
  int rows_;
  int readers_;
};

// The number of parts the trajectory blocks' rows are cut into (file comment: 4 parts and the
// common rows keep 61 % of a 1 kHz run's values; more parts gain little, 12: 58 %).
inline constexpr int kTrajectoryGroups = 4;

// The row groups of a run: for each, its first block and its rows. tan_col: the tangent column
// where each block starts (the factor's row of that block), num_traj_blocks: the trajectory's
// blocks (first), num_rows: the whole block's rows (tangent columns + the remainder row).
struct InertialRowGroupLayout {
  int first_block = 0;
  int row0 = 0;
  int rows = 0;
};
inline std::vector<InertialRowGroupLayout> InertialRowGroups(const std::vector<int>& tan_col,
                                                             int num_traj_blocks, int num_rows) {
  std::vector<int> starts;
  for (int g = 0; g < kTrajectoryGroups; ++g) {
    const int b = g * num_traj_blocks / kTrajectoryGroups;
    if (starts.empty() || b > starts.back())
      starts.push_back(b);
  }
  if (num_traj_blocks < static_cast<int>(tan_col.size()))
    starts.push_back(num_traj_blocks);
  std::vector<InertialRowGroupLayout> groups;
  for (std::size_t g = 0; g < starts.size(); ++g) {
    InertialRowGroupLayout l;
    l.first_block = starts[g];
    l.row0 = tan_col[static_cast<std::size_t>(starts[g])];
    const int end =
        g + 1 < starts.size() ? tan_col[static_cast<std::size_t>(starts[g + 1])] : num_rows;
    l.rows = end - l.row0;
    if (l.rows > 0)
      groups.push_back(l);
  }
  return groups;
}

}  // namespace ctcal
