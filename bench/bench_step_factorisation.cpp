// The own Levenberg-Marquardt step's factorisation and Schur solves of H_nn (lm_solver.cpp
// SolveStep) on normal equations shaped like the calibrations' (ShapedNormalEquations: a band of
// trajectory knots and the bias splines' knots, each coupled to the knots of its interval); then
// A^-1 applied to 9 columns (8 border columns and the gradient) as the step does.
//   Eigen:          Eigen::CholmodSupernodalLLT on a damped copy of EuRoC's H_nn (the step
//                   before session 13): CHOLMOD's own ordering, its factorize transposing the
//                   lower triangle twice per call.
//   SparseCholesky: calibrator/src/solver/sparse_cholesky.h: the permuted pattern built once,
//                   H_nn + D scattered into it, factored in place, by CHOLMOD's simplicial or
//                   supernodal factorisation (its switch, or forced: where each pays); with
//                   2 threads on the EuRoC-shaped band, split in two halves factored at once
//                   (SplitFactor, sparse_cholesky_impl.h).
// Results: docs/performance.md ("Issue 23", sessions 13-15 and 22).
#include <benchmark/benchmark.h>

#include <Eigen/CholmodSupport>
#include <random>
#include <vector>

#include "../calibrator/src/solver/normal_equations.h"
#include "../calibrator/src/solver/sparse_cholesky.h"

namespace {

using SparseColMajor = ctcal::SparseCholesky::SparseColMajor;

// A 6x6-block band of `knots` trajectory knots (order 4: each row couples 4 consecutive knots)
// and bias knots of `bias_columns` columns every `knots_per_bias` knots, each coupled to the
// trajectory knots of its interval and to the next bias knot (the bias splines are linear).
SparseColMajor ShapedNormalEquations(int knots, int knots_per_bias, int bias_columns) {
  const int biases = knots / knots_per_bias + 2;
  const int n = 6 * knots + bias_columns * biases;
  std::mt19937 rng(1);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<Eigen::Triplet<double>> triplets;
  for (int k = 0; k + 4 <= knots; ++k) {
    std::vector<int> cols;
    for (int c = 6 * k; c < 6 * (k + 4); ++c)
      cols.push_back(c);
    const int bias = 6 * knots + bias_columns * (k / knots_per_bias);
    for (int c = bias; c < bias + 2 * bias_columns; ++c)
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

// EuRoC's 36 s: 5115 knots at 7 ms, one IMU's gyro and accelerometer bias knot (6 columns) a
// second. The demo rig: 2062 knots at 29 ms, two IMUs' and a gyroscope's bias knots (15
// columns) a second.
SparseColMajor EurocShapedNormalEquations(int knots) {
  return ShapedNormalEquations(knots, 143, 6);
}
SparseColMajor DemoShapedNormalEquations(int knots) {
  return ShapedNormalEquations(knots, 34, 15);
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

// range(0): knots; range(1): 0 EuRoC-shaped, 1 demo-shaped, 2 and 3 denser bias blocks (80 and
// 135 flops per entry of L: where the supernodal factorisation starts to pay); range(2):
// SparseCholesky::Kind (0 auto, 1 simplicial, 2 supernodal); range(3): its threads (2: the split
// factor where it pays).
void BM_SparseCholesky(benchmark::State& state) {
  const int knots = static_cast<int>(state.range(0));
  const SparseColMajor H = state.range(1) == 0   ? EurocShapedNormalEquations(knots)
                           : state.range(1) == 1 ? DemoShapedNormalEquations(knots)
                           : state.range(1) == 2 ? ShapedNormalEquations(knots, 17, 30)
                                                 : ShapedNormalEquations(knots, 8, 60);
  const Eigen::MatrixXd B = RightHandSides(H.rows());
  const Eigen::VectorXd d = Eigen::VectorXd::Constant(H.rows(), 1e-8);
  ctcal::SparseCholesky chol(static_cast<ctcal::SparseCholesky::Kind>(state.range(2)));
  chol.SetThreads(static_cast<int>(state.range(3)));
  Eigen::MatrixXd X;
  for (auto _ : state) {
    chol.Factorize(H, d, true);  // the pattern of the last call, as a solve's steps
    chol.Solve(B, &X);
    chol.ReleaseSolveWorkspace();
    benchmark::DoNotOptimize(X.data());
  }
  state.counters["supernodal"] = chol.Supernodal() ? 1.0 : 0.0;
  state.counters["split"] = chol.Split() ? 1.0 : 0.0;
  state.counters["nnz_L"] = chol.FactorNonZeros();
  state.counters["flops_per_entry"] = chol.FactorFlops() / chol.FactorNonZeros();
}

// A calibration's first step: the ordering and symbolic analysis of H_nn's pattern, then the
// factorisation, twice (range(1) as above; range(2): threads, 2 splits the EuRoC-shaped band).
void BM_AnalyseAndFactorize(benchmark::State& state) {
  const int knots = static_cast<int>(state.range(0));
  const SparseColMajor H =
      state.range(1) == 0 ? EurocShapedNormalEquations(knots) : DemoShapedNormalEquations(knots);
  const Eigen::VectorXd d = Eigen::VectorXd::Constant(H.rows(), 1e-8);
  for (auto _ : state) {
    ctcal::SparseCholesky chol;
    chol.SetThreads(static_cast<int>(state.range(2)));
    benchmark::DoNotOptimize(chol.Factorize(H, d));
    // The second factorisation of the pattern: the first after an analysis allocates its buffers
    // (one half after the other when split), the later ones run as the steps do.
    benchmark::DoNotOptimize(chol.Factorize(H, d, true));
  }
}

// The step's Schur complement on the border (SubtractBorderSchur) after one factorisation:
// range(0) knots, range(1) 0 EuRoC-shaped / 1 demo-shaped, range(2) border columns, range(3)
// 0 half solves / 1 chunks of full solves, on 2 threads; range(4) the factorisation's threads (2:
// the split factor's solves, on the EuRoC-shaped band).
void BM_BorderSchur(benchmark::State& state) {
  const int knots = static_cast<int>(state.range(0));
  const SparseColMajor H =
      state.range(1) == 0 ? EurocShapedNormalEquations(knots) : DemoShapedNormalEquations(knots);
  const int c = static_cast<int>(state.range(2));
  const auto solves = state.range(3) == 0 ? ctcal::SchurSolves::kHalf : ctcal::SchurSolves::kChunks;
  std::mt19937 rng(3);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd H_nc(H.rows(), c);
  for (Eigen::Index i = 0; i < H_nc.size(); ++i)
    H_nc.data()[i] = normal(rng);
  const Eigen::VectorXd g = Eigen::VectorXd::Ones(H.rows());
  const Eigen::MatrixXd H_cc = Eigen::MatrixXd::Identity(c, c) * 1e6;
  ctcal::SparseCholesky chol;
  chol.SetThreads(static_cast<int>(state.range(4)));
  chol.Factorize(H, Eigen::VectorXd::Constant(H.rows(), 1e-8));
  state.counters["split"] = chol.Split() ? 1.0 : 0.0;
  Eigen::VectorXd h;
  for (auto _ : state) {
    Eigen::MatrixXd S = H_cc;
    benchmark::DoNotOptimize(
        ctcal::SubtractBorderSchur(&chol, H_nc, 2, ctcal::kSchurColumns, solves, &g, &S, &h));
    chol.ReleaseSolveWorkspace();
  }
}

BENCHMARK(BM_BorderSchur)
    ->Args({5115, 0, 33, 0, 1})
    ->Args({5115, 0, 33, 0, 2})
    ->Args({5115, 0, 33, 1, 1})
    ->Args({2062, 1, 97, 0, 1})
    ->Args({2062, 1, 97, 1, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_Eigen)->Arg(5115)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_AnalyseAndFactorize)
    ->Args({5115, 0, 1})
    ->Args({5115, 0, 2})
    ->Args({2062, 1, 1})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SparseCholesky)
    ->ArgsProduct({{5115}, {0}, {0, 1, 2}, {1}})
    ->ArgsProduct({{5115}, {0}, {0}, {2}})
    ->ArgsProduct({{2062}, {1, 2, 3}, {0, 1, 2}, {1}})
    ->ArgsProduct({{2062}, {1, 2}, {0}, {2}})
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
