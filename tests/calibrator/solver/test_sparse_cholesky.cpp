// The Levenberg-Marquardt step's sparse Cholesky (calibrator/src/solver/sparse_cholesky.h): on a
// matrix shaped like H_nn (a block band of trajectory knots, coupled to a few bias blocks over
// long stretches), every solve agrees with a dense LL^T of the same damped matrix, again after
// refactorising the same pattern with new values and damping, and a matrix that is not positive
// definite is refused.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <random>
#include <thread>
#include <vector>

#include "../../../calibrator/src/solver/sparse_cholesky.h"
#include "solves_on_threads.h"

namespace ctcal {
namespace {

using SparseColMajor = SparseCholesky::SparseColMajor;

// Random J (rows touching 4 consecutive knot blocks of 6 and one of 4 bias blocks of 6, by time),
// J^T J's lower triangle in compressed columns, the diagonal first in every column as H_nn holds
// it. `scale` changes the values, not the pattern.
SparseColMajor BandWithBiases(int knots, std::mt19937* rng, double scale) {
  const int biases = 4, n = 6 * (knots + biases);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n, n);
  for (int k = 0; k + 4 <= knots; ++k) {
    const int bias = knots + (k * biases) / knots;
    std::vector<int> cols;
    for (int c = 6 * k; c < 6 * (k + 4); ++c)
      cols.push_back(c);
    for (int c = 6 * bias; c < 6 * (bias + 1); ++c)
      cols.push_back(c);
    Eigen::MatrixXd J(12, static_cast<int>(cols.size()));
    for (int r = 0; r < J.rows(); ++r)
      for (int c = 0; c < J.cols(); ++c)
        J(r, c) = scale * normal(*rng);
    const Eigen::MatrixXd JtJ = J.transpose() * J;
    for (std::size_t a = 0; a < cols.size(); ++a)
      for (std::size_t b = 0; b < cols.size(); ++b)
        H(cols[a], cols[b]) += JtJ(static_cast<int>(a), static_cast<int>(b));
  }
  std::vector<Eigen::Triplet<double>> lower;
  for (int j = 0; j < n; ++j)
    for (int i = j; i < n; ++i)
      if (i == j || H(i, j) != 0.0)
        lower.emplace_back(i, j, H(i, j));
  SparseColMajor A(n, n);
  A.setFromTriplets(lower.begin(), lower.end());
  A.makeCompressed();
  return A;
}

Eigen::MatrixXd Dense(const SparseColMajor& lower, const Eigen::VectorXd& d) {
  const Eigen::MatrixXd L = Eigen::MatrixXd(lower);
  Eigen::MatrixXd A = L + L.transpose();
  A.diagonal() = L.diagonal() + d.head(lower.rows());
  return A;
}

TEST(SparseCholesky, SolvesAgreeWithDenseCholeskyAcrossRefactorisations) {
  std::mt19937 rng(5);
  std::normal_distribution<double> normal(0.0, 1.0);
  const int knots = 40;
  SparseCholesky chol;
  for (int round = 0; round < 5; ++round) {
    std::mt19937 pattern_rng(11);  // the same pattern every round, other values
    SparseColMajor A = BandWithBiases(knots, &pattern_rng, 1.0);
    for (int k = 0; k < A.nonZeros(); ++k)
      A.valuePtr()[k] *= 1.0 + 0.3 * round;
    // The damping vector is longer than A, as the solver's (the border's entries follow).
    Eigen::VectorXd d = Eigen::VectorXd::Constant(A.rows() + 5, 1e-3 * (round + 1));
    // From the third round on the caller vouches for the pattern (the solver's steps): the
    // check skipped, the values still scattered into the analysed pattern.
    ASSERT_TRUE(chol.Factorize(A, d, round >= 2)) << "round " << round;
    const Eigen::MatrixXd dense = Dense(A, d);
    Eigen::MatrixXd B(A.rows(), 3);
    for (int i = 0; i < B.size(); ++i)
      B.data()[i] = normal(rng);
    Eigen::MatrixXd X;
    ASSERT_TRUE(chol.Solve(B, &X));
    const Eigen::MatrixXd expected = dense.llt().solve(B);
    EXPECT_LE((X - expected).norm(), 1e-9 * expected.norm()) << "round " << round;
    EXPECT_LE((dense * X - B).norm(), 1e-9 * B.norm()) << "round " << round;
  }
}

// A dense lower triangle (every entry stored): CHOLMOD's switch takes the supernodal factor.
SparseColMajor DenseLower(int n, std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd J(n + 10, n);
  for (int i = 0; i < J.size(); ++i)
    J.data()[i] = normal(*rng);
  const Eigen::MatrixXd H = J.transpose() * J;
  SparseColMajor A = H.triangularView<Eigen::Lower>().toDenseMatrix().sparseView();
  A.makeCompressed();
  return A;
}

// The band fills little and gets CHOLMOD's simplicial factor (an LDL^T), a dense matrix the
// supernodal LL^T: both solve, and both refuse an indefinite matrix.
class SparseCholeskyOf : public ::testing::TestWithParam<bool> {};

// The step solves its border columns on several threads, each with its own workspace: every
// thread's solve gives the bits the one-workspace Solve gives, the factor shared.
TEST_P(SparseCholeskyOf, KindSolvesOnSeveralThreadsWithTheSameBits) {
  std::mt19937 rng(7);
  const SparseColMajor A = GetParam() ? DenseLower(200, &rng) : BandWithBiases(300, &rng, 1.0);
  SparseCholesky chol;
  ASSERT_TRUE(chol.Factorize(A, Eigen::VectorXd::Constant(A.rows(), 1e-3)));
  test::ExpectTheSameBitsOnThreads(chol, A.rows(), 4, 20, &rng);
}

// The half solve X = R^-T B (A + diag(d) = R^T R) of the Schur complement: B^T A^-1 C = X^T Y
// against the dense inverse, for the simplicial LDL^T (its D scaled in) and the supernodal LL^T
// alike, with and without a last column appended, B with no column, several workspaces; and the
// back half R^-1 that completes a solve.
TEST_P(SparseCholeskyOf, KindHalfSolvesGiveTheInverseAsAProduct) {
  std::mt19937 rng(11);
  std::normal_distribution<double> normal(0.0, 1.0);
  const SparseColMajor A = GetParam() ? DenseLower(120, &rng) : BandWithBiases(150, &rng, 1.0);
  const auto n = static_cast<int>(A.rows());
  const Eigen::VectorXd d = Eigen::VectorXd::Constant(n, 0.3);
  SparseCholesky chol;
  ASSERT_TRUE(chol.Factorize(A, d));
  ASSERT_EQ(chol.Supernodal(), GetParam());
  const Eigen::MatrixXd inverse = Dense(A, d).inverse();
  Eigen::MatrixXd B(n, 5), C(n, 3);
  for (int i = 0; i < B.size(); ++i)
    B.data()[i] = normal(rng);
  for (int i = 0; i < C.size(); ++i)
    C.data()[i] = normal(rng);
  const Eigen::VectorXd g = C.col(2);
  SparseCholesky::Workspace first, second;
  Eigen::MatrixXd X(n, 5), Y(n, 3), Z(n, 1);
  ASSERT_TRUE(chol.HalfSolve(B, nullptr, X, &first));
  // C's first two columns, then g as the appended last one: Y is C's half solve.
  ASSERT_TRUE(chol.HalfSolve(C.leftCols(2), &g, Y, &second));
  ASSERT_TRUE(chol.HalfSolve(C.leftCols(0), &g, Z, &first));
  const Eigen::MatrixXd expected = B.transpose() * inverse * C;
  EXPECT_LE((X.transpose() * Y - expected).norm(), 1e-10 * expected.norm());
  const Eigen::MatrixXd BtAB = B.transpose() * inverse * B;
  EXPECT_LE((X.transpose() * X - BtAB).norm(), 1e-10 * BtAB.norm());
  EXPECT_EQ(Z.col(0), Y.col(2));  // the same column, the same bits
  // A full solve is the half solve's product: x^T (A^-1 b) = (R^-T x)^T (R^-T b).
  Eigen::MatrixXd full;
  ASSERT_TRUE(chol.Solve(C, &full));
  EXPECT_LE((X.transpose() * Y - B.transpose() * full).norm(), 1e-10 * expected.norm());
  // And the other half: R^-1 (R^-T g) = A^-1 g, back in A's order.
  Eigen::MatrixXd back;
  ASSERT_TRUE(chol.HalfSolveBack(Z, &back, &second));
  const Eigen::VectorXd expected_back = inverse * g;
  EXPECT_LE((back.col(0) - expected_back).norm(), 1e-10 * expected_back.norm());
}

// The same band with its rows and columns symmetrically permuted at random: its natural order
// fills far more than a fill-reducing one.
SparseColMajor Scrambled(const SparseColMajor& lower, std::mt19937* rng) {
  const auto n = static_cast<int>(lower.rows());
  Eigen::VectorXi to(n);
  for (int i = 0; i < n; ++i)
    to(i) = i;
  std::shuffle(to.data(), to.data() + n, *rng);
  std::vector<Eigen::Triplet<double>> entries;
  for (int j = 0; j < n; ++j) {
    for (SparseColMajor::InnerIterator it(lower, j); it; ++it) {
      const int a = to(static_cast<int>(it.row())), b = to(j);
      entries.emplace_back(std::max(a, b), std::min(a, b), it.value());
    }
  }
  SparseColMajor out(n, n);
  out.setFromTriplets(entries.begin(), entries.end());
  out.makeCompressed();
  return out;
}

// The spline calibration keeps one factorisation for its robust and final solves and the
// covariance: the values freed between them, a matrix of another pattern analysed anew, and
// analysed as well as by a fresh one (CHOLMOD's settings of the previous analysis once left it in
// natural order).
TEST(SparseCholesky, KeepsItsAnalysisAcrossReleasesAndReanalysesANewPattern) {
  std::mt19937 rng(9);
  std::normal_distribution<double> normal(0.0, 1.0);
  const SparseColMajor first = BandWithBiases(60, &rng, 1.0);
  const SparseColMajor second = Scrambled(BandWithBiases(80, &rng, 1.0), &rng);
  SparseCholesky kept, fresh;
  ASSERT_TRUE(fresh.Factorize(second, Eigen::VectorXd::Constant(second.rows(), 1e-3)));
  for (const SparseColMajor* A : {&first, &first, &second, &second}) {
    const Eigen::VectorXd d = Eigen::VectorXd::Constant(A->rows(), 2e-3);
    ASSERT_TRUE(kept.Factorize(*A, d));
    Eigen::MatrixXd B(A->rows(), 4), X;
    for (int i = 0; i < B.size(); ++i)
      B.data()[i] = normal(rng);
    ASSERT_TRUE(kept.Solve(B, &X));
    const Eigen::MatrixXd dense = Dense(*A, d);
    EXPECT_LE((dense * X - B).norm(), 1e-9 * B.norm());
    kept.ReleaseNumeric();
  }
  EXPECT_EQ(kept.FactorNonZeros(), fresh.FactorNonZeros());
  // And the scrambled order itself would fill several times more: the check has teeth.
  SparseColMajor damped = second;
  for (int j = 0; j < damped.outerSize(); ++j)
    damped.coeffRef(j, j) += 1.0;
  Eigen::SimplicialLLT<SparseColMajor, Eigen::Lower, Eigen::NaturalOrdering<int>> natural(damped);
  ASSERT_EQ(natural.info(), Eigen::Success);
  EXPECT_GT(static_cast<double>(natural.matrixL().nestedExpression().nonZeros()),
            2.0 * fresh.FactorNonZeros());
  // While a fill-reducing order (Eigen's own AMD) fills about as little as the analysis' order.
  Eigen::SimplicialLLT<SparseColMajor, Eigen::Lower, Eigen::AMDOrdering<int>> amd(damped);
  ASSERT_EQ(amd.info(), Eigen::Success);
  EXPECT_LE(fresh.FactorNonZeros(),
            1.1 * static_cast<double>(amd.matrixL().nestedExpression().nonZeros()));
}

TEST_P(SparseCholeskyOf, KindSolvesAndRefusesAMatrixThatIsNotPositiveDefinite) {
  std::mt19937 rng(3);
  const bool dense = GetParam();
  const SparseColMajor A = dense ? DenseLower(150, &rng) : BandWithBiases(20, &rng, 1.0);
  SparseCholesky chol;
  const Eigen::VectorXd small = Eigen::VectorXd::Constant(A.rows(), 1e-6);
  ASSERT_TRUE(chol.Factorize(A, small));
  EXPECT_EQ(chol.Supernodal(), dense);
  Eigen::MatrixXd B = Eigen::MatrixXd::Ones(A.rows(), 2), X;
  ASSERT_TRUE(chol.Solve(B, &X));
  EXPECT_LE((Dense(A, small) * X - B).norm(), 1e-8 * B.norm());
  // A negative damping larger than the smallest eigenvalue leaves an indefinite matrix.
  const double lowest = Dense(A, small).selfadjointView<Eigen::Lower>().eigenvalues().minCoeff();
  EXPECT_FALSE(chol.Factorize(A, Eigen::VectorXd::Constant(A.rows(), -(lowest + 1.0))));
  // And the same pattern factors again once it is positive definite.
  EXPECT_TRUE(chol.Factorize(A, small));
}

// Both factorisations forced on one band give the same solution; kAuto takes the supernodal one
// exactly where the analysis' flops per entry of L reach the switch.
TEST(SparseCholesky, ForcedKindsAgreeAndTheSwitchFollowsTheFlopsPerEntry) {
  std::mt19937 rng(11);
  const SparseColMajor A = BandWithBiases(120, &rng, 1.0);
  const Eigen::VectorXd d = Eigen::VectorXd::Constant(A.rows(), 1e-4);
  const Eigen::MatrixXd B = Eigen::MatrixXd::Ones(A.rows(), 3);
  Eigen::MatrixXd X_simplicial, X_supernodal;
  SparseCholesky simplicial(SparseCholesky::Kind::kSimplicial);
  SparseCholesky supernodal(SparseCholesky::Kind::kSupernodal);
  ASSERT_TRUE(simplicial.Factorize(A, d));
  ASSERT_TRUE(supernodal.Factorize(A, d));
  EXPECT_FALSE(simplicial.Supernodal());
  EXPECT_TRUE(supernodal.Supernodal());
  ASSERT_TRUE(simplicial.Solve(B, &X_simplicial));
  ASSERT_TRUE(supernodal.Solve(B, &X_supernodal));
  EXPECT_LE((X_simplicial - X_supernodal).norm(), 1e-10 * X_supernodal.norm());
  for (const SparseColMajor& M : {A, DenseLower(90, &rng), DenseLower(200, &rng)}) {
    SparseCholesky chol;
    ASSERT_TRUE(chol.Factorize(M, Eigen::VectorXd::Constant(M.rows(), 1e-3)));
    EXPECT_EQ(chol.Supernodal(),
              chol.FactorFlops() / chol.FactorNonZeros() >= SparseCholesky::kSupernodalSwitch)
        << M.rows() << " columns, " << chol.FactorFlops() / chol.FactorNonZeros()
        << " flops per entry";
  }
}

INSTANTIATE_TEST_SUITE_P(, SparseCholeskyOf, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& p) {
                           return p.param ? "Supernodal" : "Simplicial";
                         });

}  // namespace
}  // namespace ctcal
