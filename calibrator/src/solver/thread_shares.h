// The threads' shares of the assembly of H = J^T J (LevenbergMarquardt's Evaluate). Every thread
// adds into the one H (a copy of H per thread was the solver's largest memory, ~20 MB per thread on
// EuRoC's 36 s), so no two threads may write the same nuisance block's column of H_nn or row of
// H_nc at once: the nuisance blocks are cut into `threads` ranges, a residual block whose nuisance
// blocks all lie in one range is that thread's, and one that straddles a cut is assembled after
// the threads, in its order.
#pragma once

#include <cstddef>
#include <vector>

namespace ctcal {

struct ThreadShares {
  std::vector<std::vector<std::size_t>> own;  // per thread: its residual blocks, in order
  std::vector<std::size_t> shared;            // the straddling ones, after the threads
  // The nuisance blocks' band order (BandOrder), kept for tests and diagnostics.
  std::vector<int> rank;
};

// A band order of the nuisance blocks 0..nuisance_blocks-1, as rank[block]: breadth-first over
// the graph of blocks read by a common residual block, from a pseudo-peripheral block (the last
// one reached from block 0), readers taken in their order. On a trajectory's knots this is their
// order in time whatever order the problem happened to list them in (a camera's frames read the
// knots they see first, the inertial samples those of the gaps between the frames later).
// Blocks that no residual reads come last, in their order.
std::vector<int> BandOrder(const std::vector<std::vector<int>>& nuisance_of, int nuisance_blocks);

// `nuisance_of[i]`: the nuisance blocks (< nuisance_blocks) residual block i reads; `work[i]` its
// assembly cost. A residual block's key is its nuisance block of the smallest rank, a nuisance
// block's position the smallest key of the residual blocks reading it (a bias knot: its first
// sample's), and the cuts put equal work below each key. Blocks reading no nuisance block
// (only H_cc and g_c) go round-robin. The result depends on the structure and the thread count
// only, not on a schedule.
ThreadShares ShareBlocks(const std::vector<std::vector<int>>& nuisance_of,
                         const std::vector<double>& work, int nuisance_blocks, int threads);

}  // namespace ctcal
