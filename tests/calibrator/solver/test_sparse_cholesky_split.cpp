// The split factorisation of SparseCholesky (calibrator/src/solver/sparse_cholesky_impl.h
// SplitFactor): on two threads a band of trajectory knots with bias knots is factored as two halves
// and a separator, and every solve agrees with the single factor's of the same matrix (Eigen's
// sparse LDL^T as the reference); the half solves give the inverse as a product; a pattern with
// the same column counts but other rows is analysed anew; a matrix that is not positive definite
// is refused; small matrices and one thread keep the single factor.
#include <gtest/gtest.h>

#include <Eigen/SparseCholesky>
#include <random>
#include <vector>

#include "../../../calibrator/src/solver/sparse_cholesky.h"
#include "solves_on_threads.h"

namespace ctcal {
namespace {

using SparseColMajor = SparseCholesky::SparseColMajor;

// J^T J's lower triangle for random rows, each touching 4 consecutive knot blocks of 6 and the two
// bias blocks of 6 its time lies between (a linear bias spline, one knot per `per_bias` knots),
// built sparsely: large enough to be split (SplitFactor::kMinColumns).
SparseColMajor KnotsWithBiases(int knots, int per_bias, std::mt19937* rng) {
  const int biases = knots / per_bias + 2, n = 6 * (knots + biases);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<Eigen::Triplet<double>> entries;
  for (int k = 0; k + 4 <= knots; ++k) {
    std::vector<int> cols;
    for (int c = 6 * k; c < 6 * (k + 4); ++c)
      cols.push_back(c);
    const int bias = knots + k / per_bias;
    for (int c = 6 * bias; c < 6 * (bias + 2); ++c)
      cols.push_back(c);
    Eigen::MatrixXd J(12, static_cast<int>(cols.size()));
    for (int i = 0; i < J.size(); ++i)
      J.data()[i] = normal(*rng);
    const Eigen::MatrixXd JtJ = J.transpose() * J;
    for (std::size_t a = 0; a < cols.size(); ++a)
      for (std::size_t b = 0; b < cols.size(); ++b)
        if (cols[a] >= cols[b])
          entries.emplace_back(cols[a], cols[b], JtJ(static_cast<int>(a), static_cast<int>(b)));
  }
  for (int i = 0; i < n; ++i)
    entries.emplace_back(i, i, 1.0);
  SparseColMajor A(n, n);
  A.setFromTriplets(entries.begin(), entries.end());
  A.makeCompressed();
  return A;
}

Eigen::MatrixXd Random(Eigen::Index rows, Eigen::Index cols, std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd B(rows, cols);
  for (Eigen::Index i = 0; i < B.size(); ++i)
    B.data()[i] = normal(*rng);
  return B;
}

// A^-1 B for A + diag(d) given by its lower triangle, by Eigen's own sparse LDL^T.
Eigen::MatrixXd Reference(const SparseColMajor& lower, const Eigen::VectorXd& d,
                          const Eigen::MatrixXd& B) {
  SparseColMajor A = lower;
  for (int j = 0; j < A.outerSize(); ++j)
    A.coeffRef(j, j) += d(j);
  Eigen::SimplicialLDLT<SparseColMajor, Eigen::Lower> ldlt(A);
  EXPECT_EQ(ldlt.info(), Eigen::Success);
  return ldlt.solve(B);
}

TEST(SparseCholeskySplit, SplitsOnTwoThreadsAndSolvesAsTheReference) {
  std::mt19937 rng(3);
  const SparseColMajor A = KnotsWithBiases(3500, 143, &rng);
  const auto n = A.rows();
  const Eigen::VectorXd d = Eigen::VectorXd::Constant(n, 1e-3);
  SparseCholesky split, single;
  split.SetThreads(2);
  ASSERT_TRUE(split.Factorize(A, d));
  ASSERT_TRUE(single.Factorize(A, d));
  EXPECT_TRUE(split.Split());
  EXPECT_FALSE(single.Split());
  // The halves fill about as little as the whole (their bias knots are ordered with them).
  EXPECT_LE(split.FactorNonZeros(), 1.1 * single.FactorNonZeros());
  const Eigen::MatrixXd B = Random(n, 6, &rng);
  const Eigen::MatrixXd expected = Reference(A, d, B);
  Eigen::MatrixXd X;
  ASSERT_TRUE(split.Solve(B, &X));
  EXPECT_LE((X - expected).norm(), 1e-9 * expected.norm());

  // Half solves: B^T A^-1 C = (R^-T B)^T (R^-T C), with a last column appended and with B
  // without columns; and R^-1 (R^-T g) = A^-1 g.
  const Eigen::MatrixXd C = Random(n, 3, &rng);
  const Eigen::VectorXd g = C.col(2);
  SparseCholesky::Workspace first, second;
  Eigen::MatrixXd HB(n, 6), HC(n, 3), Hg(n, 1);
  ASSERT_TRUE(split.HalfSolve(B, nullptr, HB, &first));
  ASSERT_TRUE(split.HalfSolve(C.leftCols(2), &g, HC, &second));
  ASSERT_TRUE(split.HalfSolve(C.leftCols(0), &g, Hg, &first));
  const Eigen::MatrixXd BtAC = B.transpose() * Reference(A, d, C);
  EXPECT_LE((HB.transpose() * HC - BtAC).norm(), 1e-9 * BtAC.norm());
  EXPECT_EQ(Hg.col(0), HC.col(2));
  Eigen::MatrixXd back;
  ASSERT_TRUE(split.HalfSolveBack(Hg, &back, &second));
  const Eigen::MatrixXd Ag = Reference(A, d, g);
  EXPECT_LE((back - Ag).norm(), 1e-9 * Ag.norm());

  // Refactorised with other values of the pattern, after its numeric part was freed.
  split.ReleaseNumeric();
  const Eigen::VectorXd d2 = Eigen::VectorXd::Constant(n, 0.5);
  ASSERT_TRUE(split.Factorize(A, d2));
  EXPECT_TRUE(split.Split());
  ASSERT_TRUE(split.Solve(B, &X));
  const Eigen::MatrixXd expected2 = Reference(A, d2, B);
  EXPECT_LE((X - expected2).norm(), 1e-9 * expected2.norm());
}

// The step's border columns are solved on several threads, each with its own workspace: the bits
// of the one-workspace Solve.
TEST(SparseCholeskySplit, SolvesOnSeveralThreadsWithTheSameBits) {
  std::mt19937 rng(5);
  const SparseColMajor A = KnotsWithBiases(3400, 100, &rng);
  SparseCholesky chol;
  chol.SetThreads(2);
  ASSERT_TRUE(chol.Factorize(A, Eigen::VectorXd::Constant(A.rows(), 1e-3)));
  ASSERT_TRUE(chol.Split());
  test::ExpectTheSameBitsOnThreads(chol, A.rows(), 3, 6, &rng);
}

// A pattern with the same count of entries in every column but one entry on another row: not the
// analysed one (its check reads every entry, not the column counts), so it is analysed anew and
// solved right.
TEST(SparseCholeskySplit, ReanalysesAPatternWithTheSameColumnCounts) {
  std::mt19937 rng(7);
  const SparseColMajor A = KnotsWithBiases(3500, 143, &rng);
  const auto n = static_cast<int>(A.rows());
  // Column 0's last entry moved to a row it did not have (the damping d keeps both positive
  // definite).
  std::vector<Eigen::Triplet<double>> entries;
  int moved_from = -1;
  for (int j = 0; j < n; ++j) {
    for (SparseColMajor::InnerIterator it(A, j); it; ++it)
      entries.emplace_back(static_cast<int>(it.row()), j, it.value());
  }
  // The last entry of column 0 (the highest row it has) becomes row n - 1.
  for (auto& e : entries) {
    if (e.col() == 0 && e.row() == A.innerIndexPtr()[A.outerIndexPtr()[1] - 1]) {
      moved_from = e.row();
      e = Eigen::Triplet<double>(n - 1, 0, e.value());
    }
  }
  ASSERT_GT(moved_from, 0);
  SparseColMajor M(n, n);
  M.setFromTriplets(entries.begin(), entries.end());
  M.makeCompressed();
  ASSERT_TRUE(std::equal(A.outerIndexPtr(), A.outerIndexPtr() + n + 1, M.outerIndexPtr()));
  const Eigen::VectorXd d = Eigen::VectorXd::Constant(n, 200.0);
  SparseCholesky chol;
  chol.SetThreads(2);
  const Eigen::MatrixXd B = Random(n, 2, &rng);
  Eigen::MatrixXd X;
  const SparseColMajor& M_ = M;
  for (const SparseColMajor* P : {&A, &M_, &A}) {
    ASSERT_TRUE(chol.Factorize(*P, d));
    ASSERT_TRUE(chol.Solve(B, &X));
    const Eigen::MatrixXd expected = Reference(*P, d, B);
    EXPECT_LE((X - expected).norm(), 1e-9 * expected.norm());
  }
}

TEST(SparseCholeskySplit, RefusesAMatrixThatIsNotPositiveDefinite) {
  std::mt19937 rng(9);
  const SparseColMajor A = KnotsWithBiases(3500, 143, &rng);
  const auto n = A.rows();
  SparseCholesky chol;
  chol.SetThreads(2);
  const Eigen::VectorXd small = Eigen::VectorXd::Constant(n, 1e-6);
  ASSERT_TRUE(chol.Factorize(A, small));
  ASSERT_TRUE(chol.Split());
  // A negative damping on one column (a half's or the separator's alike: every column in turn
  // would be tested by a dense check; here the first, the middle and the last) leaves A indefinite.
  for (const Eigen::Index j : {Eigen::Index{0}, n / 2, n - 1}) {
    Eigen::VectorXd d = small;
    d(j) = -1e6;
    EXPECT_FALSE(chol.Factorize(A, d)) << "column " << j;
  }
  EXPECT_TRUE(chol.Factorize(A, small));
}

TEST(SparseCholeskySplit, KeepsTheSingleFactorForSmallMatricesAndOneThread) {
  std::mt19937 rng(11);
  const SparseColMajor small = KnotsWithBiases(2000, 143, &rng);
  const SparseColMajor large = KnotsWithBiases(3500, 143, &rng);
  SparseCholesky two;
  two.SetThreads(2);
  ASSERT_TRUE(two.Factorize(small, Eigen::VectorXd::Constant(small.rows(), 1e-3)));
  EXPECT_FALSE(two.Split());
  SparseCholesky one;
  one.SetThreads(1);
  ASSERT_TRUE(one.Factorize(large, Eigen::VectorXd::Constant(large.rows(), 1e-3)));
  EXPECT_FALSE(one.Split());
  SparseCholesky forced(SparseCholesky::Kind::kSimplicial);
  forced.SetThreads(2);
  ASSERT_TRUE(forced.Factorize(large, Eigen::VectorXd::Constant(large.rows(), 1e-3)));
  EXPECT_FALSE(forced.Split());
}

}  // namespace
}  // namespace ctcal
