// The own Levenberg-Marquardt step's factorisation and Schur solves of H_nn (lm_solver.cpp
// SolveStep) on normal equations shaped like EuRoC's 36 s: a 6x6-block band of `knots` trajectory
// knots (order 4: each row couples 4 consecutive knots) and one 6-block bias knot per second
// (200 knots at 7 ms), each coupled to the knots of its second; then A^-1 applied to 9 columns
// (8 border columns and the gradient) as the step does.
//   Eigen:          Eigen::CholmodSupernodalLLT on a damped copy of H_nn (the step before
//                   session 13): CHOLMOD's own ordering, its factorize transposing the lower
//                   triangle twice per call.
//   SparseCholesky: calibrator/src/solver/sparse_cholesky.h: the permuted pattern built once,
//                   H_nn + D scattered into it, factored in place (since session 14 by the
//                   simplicial factorisation CHOLMOD's switch picks for this band).
// Results: docs/performance.md ("Issue 23, session 13" and "session 14").
#include <benchmark/benchmark.h>

#include <Eigen/CholmodSupport>
#include <random>
#include <vector>

#include "../calibrator/src/solver/sparse_cholesky.h"

namespace {

using SparseColMajor = ctcal::SparseCholesky::SparseColMajor;

SparseColMajor EurocShapedNormalEquations(int knots) {
  constexpr int kKnotsPerBias = 143;  // 1 s bias knots over 7 ms trajectory knots
  const int biases = knots / kKnotsPerBias + 2, n = 6 * (knots + biases);
  std::mt19937 rng(1);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<Eigen::Triplet<double>> triplets;
  for (int k = 0; k + 4 <= knots; ++k) {
    std::vector<int> cols;
    for (int c = 6 * k; c < 6 * (k + 4); ++c)
      cols.push_back(c);
    const int bias = knots + k / kKnotsPerBias;
    for (int c = 6 * bias; c < 6 * (bias + 2); ++c)
      cols.push_back(c);
    Eigen::MatrixXd J(12, static_cast<int>(cols.size()));
    for (int i = 0; i < J.size(); ++i)
      J.data()[i] = normal(rng);
    const Eigen::MatrixXd JtJ = J.transpose() * J;
    for (std::size_t a = 0; a < cols.size(); ++a)
      for (std::size_t b = 0; b < cols.size(); ++b)
        if (cols[a] >= cols[b])
          triplets.emplace_back(cols[a], cols[b], JtJ(static_cast<int>(a), static_cast<int>(b)));
  }
  for (int i = 0; i < n; ++i)
    triplets.emplace_back(i, i, 1.0);  // every diagonal present, as in H_nn
  SparseColMajor H(n, n);
  H.setFromTriplets(triplets.begin(), triplets.end());
  H.makeCompressed();
  return H;
}

Eigen::MatrixXd RightHandSides(Eigen::Index n) {
  std::mt19937 rng(2);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd B(n, 9);
  for (Eigen::Index i = 0; i < B.size(); ++i)
    B.data()[i] = normal(rng);
  return B;
}

void BM_Eigen(benchmark::State& state) {
  const SparseColMajor H = EurocShapedNormalEquations(static_cast<int>(state.range(0)));
  const Eigen::MatrixXd B = RightHandSides(H.rows());
  const Eigen::VectorXd d = Eigen::VectorXd::Constant(H.rows(), 1e-8);
  Eigen::CholmodSupernodalLLT<SparseColMajor, Eigen::Lower> llt;
  llt.cholmod().print = 0;
  llt.analyzePattern(H);
  for (auto _ : state) {
    SparseColMajor A = H;
    for (Eigen::Index i = 0; i < A.cols(); ++i)
      A.valuePtr()[A.outerIndexPtr()[i]] += d(i);
    llt.factorize(A);
    Eigen::MatrixXd X = llt.solve(B);
    benchmark::DoNotOptimize(X.data());
  }
}

void BM_SparseCholesky(benchmark::State& state) {
  const SparseColMajor H = EurocShapedNormalEquations(static_cast<int>(state.range(0)));
  const Eigen::MatrixXd B = RightHandSides(H.rows());
  const Eigen::VectorXd d = Eigen::VectorXd::Constant(H.rows(), 1e-8);
  ctcal::SparseCholesky chol;
  Eigen::MatrixXd X;
  for (auto _ : state) {
    chol.Factorize(H, d);
    chol.Solve(B, &X);
    chol.ReleaseSolveWorkspace();
    benchmark::DoNotOptimize(X.data());
  }
}

BENCHMARK(BM_Eigen)->Arg(5115)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SparseCholesky)->Arg(5115)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
