// The Schur complement on the border (calibrator/src/solver/normal_equations.h,
// SubtractBorderSchur), which the solver's step and the covariance's marginalisation both use:
// against the dense H_cc - H_nc^T A_nn^-1 H_nc and A_nn^-1 g_n on 1-3 threads and any number of
// border columns, and the same bits from one run to the next on a thread count (the chunks are
// handed out statically, each solved with its thread's own workspace).
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <random>
#include <vector>

#include "../../../calibrator/src/solver/normal_equations.h"
#include "../../../calibrator/src/solver/sparse_cholesky.h"

namespace ctcal {
namespace {

using SparseColMajor = SparseCholesky::SparseColMajor;

// A banded SPD lower triangle (bandwidth 12) of size n.
SparseColMajor Band(int n, std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<Eigen::Triplet<double>> entries;
  for (int j = 0; j < n; ++j) {
    entries.emplace_back(j, j, 30.0 + std::abs(normal(*rng)));
    for (int i = j + 1; i < std::min(n, j + 12); ++i)
      entries.emplace_back(i, j, normal(*rng));
  }
  SparseColMajor A(n, n);
  A.setFromTriplets(entries.begin(), entries.end());
  A.makeCompressed();
  return A;
}

TEST(BorderSchur, MatchesTheDenseComplementOnAnyThreadCount) {
  std::mt19937 rng(4);
  std::normal_distribution<double> normal(0.0, 1.0);
  const int n = 400;
  const SparseColMajor A = Band(n, &rng);
  SparseCholesky llt;
  ASSERT_TRUE(llt.Factorize(A, Eigen::VectorXd::Zero(n)));
  const Eigen::MatrixXd L = Eigen::MatrixXd(A);
  Eigen::MatrixXd dense = L + L.transpose();
  dense.diagonal() = L.diagonal();
  const Eigen::LLT<Eigen::MatrixXd> reference(dense);
  for (const int c : {0, 1, 3, 8, 21}) {
    Eigen::MatrixXd H_nc(n, c), H_cc = Eigen::MatrixXd::Identity(c, c) * 50.0;
    for (int i = 0; i < H_nc.size(); ++i)
      H_nc.data()[i] = normal(rng);
    Eigen::VectorXd g_n(n);
    for (int i = 0; i < n; ++i)
      g_n(i) = normal(rng);
    const Eigen::MatrixXd expected = H_cc - H_nc.transpose() * reference.solve(H_nc);
    const Eigen::VectorXd expected_h = H_nc.transpose() * reference.solve(g_n);
    for (const int threads : {1, 2, 3}) {
      SCOPED_TRACE(testing::Message() << c << " border columns, " << threads << " threads");
      for (const SchurSolves solves : {SchurSolves::kHalf, SchurSolves::kChunks}) {
        SCOPED_TRACE(solves == SchurSolves::kHalf ? "half solves" : "chunks");
        Eigen::MatrixXd S = H_cc, again = H_cc;
        Eigen::VectorXd h, h_again;
        ASSERT_TRUE(SubtractBorderSchur(&llt, H_nc, threads, 8, solves, &g_n, &S, &h));
        ASSERT_TRUE(SubtractBorderSchur(&llt, H_nc, threads, 8, solves, &g_n, &again, &h_again));
        EXPECT_LE((S - expected).norm(), 1e-10 * (1.0 + expected.norm()));
        ASSERT_EQ(h.size(), c);
        EXPECT_LE((h - expected_h).norm(), 1e-10 * (1.0 + expected_h.norm()));
        EXPECT_TRUE(S == again && h == h_again);  // the same bits, run to run
        Eigen::MatrixXd without_g = H_cc;
        ASSERT_TRUE(
            SubtractBorderSchur(&llt, H_nc, threads, 8, solves, nullptr, &without_g, nullptr));
        EXPECT_LE((without_g - expected).norm(), 1e-10 * (1.0 + expected.norm()));
      }
    }
  }
}

}  // namespace
}  // namespace ctcal
