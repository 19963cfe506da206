// Shared by the sparse Cholesky's tests: the step solves its border columns on several threads,
// each with its own workspace, and every thread's solve must give the bits the one-workspace
// Solve gives, the factor shared.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <random>
#include <thread>
#include <vector>

#include "../../../calibrator/src/solver/sparse_cholesky.h"

namespace ctcal::test {

// `threads` threads solve right-hand sides of 4 + t columns `rounds` times each (their workspaces
// released every 5th round) against the factored `chol`.
inline void ExpectTheSameBitsOnThreads(SparseCholesky& chol, Eigen::Index n, int threads,
                                       int rounds, std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<Eigen::MatrixXd> B(static_cast<std::size_t>(threads));
  std::vector<Eigen::MatrixXd> expected(B.size());
  for (std::size_t t = 0; t < B.size(); ++t) {
    B[t].resize(n, 4 + static_cast<Eigen::Index>(t));
    for (Eigen::Index i = 0; i < B[t].size(); ++i)
      B[t].data()[i] = normal(*rng);
    ASSERT_TRUE(chol.Solve(B[t], &expected[t]));
  }
  std::vector<int> same(B.size(), 0);
  std::vector<std::thread> pool;
  for (std::size_t t = 0; t < B.size(); ++t) {
    pool.emplace_back([&, t] {
      SparseCholesky::Workspace workspace;
      Eigen::MatrixXd X;
      for (int round = 0; round < rounds; ++round) {
        if (chol.Solve(B[t], &X, &workspace) && X == expected[t])
          ++same[t];
        if (round % 5 == 4)
          workspace.Release();
      }
    });
  }
  for (std::thread& th : pool)
    th.join();
  for (std::size_t t = 0; t < B.size(); ++t)
    EXPECT_EQ(same[t], rounds) << "thread " << t;
}

}  // namespace ctcal::test
