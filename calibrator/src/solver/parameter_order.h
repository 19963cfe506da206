#pragma once

#include <ceres/problem.h>

#include <unordered_set>
#include <vector>

namespace ctcal {

// The problem's parameter blocks in the order the residual blocks first read them (residual
// blocks in insertion order), then the blocks no residual block reads (in Ceres' order: they add
// no entry to the normal equations, so their place cannot change a sum).
//
// Why not ceres::Problem::GetParameterBlocks: it lists the blocks by their memory address (Ceres
// keeps them in a map keyed by the pointer), which differs from run to run with the heap's layout.
// The columns of the normal equations follow this order, and the sparse factorisation rounds
// differently for a permuted matrix: the same recording gave results that differed in the last
// digits from run to run (issue: reproducible bit for bit for a given --threads).
inline std::vector<double*> ParameterBlocksInResidualOrder(const ceres::Problem& problem) {
  std::vector<ceres::ResidualBlockId> residuals;
  problem.GetResidualBlocks(&residuals);
  std::vector<double*> order, blocks;
  std::unordered_set<const double*> seen;
  for (const ceres::ResidualBlockId id : residuals) {
    problem.GetParameterBlocksForResidualBlock(id, &blocks);
    for (double* b : blocks) {
      if (seen.insert(b).second)
        order.push_back(b);
    }
  }
  problem.GetParameterBlocks(&blocks);
  for (double* b : blocks) {
    if (seen.insert(b).second)
      order.push_back(b);
  }
  return order;
}

}  // namespace ctcal
