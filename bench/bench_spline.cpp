// Cost of one trajectory evaluation as an IMU residual needs it: pose, body angular velocity and
// specific force, with their Jacobians with respect to every control point of the local support.
//   Analytic: Se3Spline::EvaluateSegment<double> with J_R, J_p, J_w, J_f (tangent Jacobians).
//   Jet:      the identical EvaluateSegment on ceres::Jet<double, 7N>, one derivative per ambient
//             parameter of the segment (what ceres::AutoDiffCostFunction would compute).
// Results: docs/performance.md ("Spline evaluation").
#include <benchmark/benchmark.h>
#include <ceres/jet.h>

#include <random>
#include <vector>

#include "ctcal/spline/se3_spline.h"

namespace {

using ctcal::Se3Kinematics;
using ctcal::Se3Representation;
using ctcal::Se3Spline;

template <int N, Se3Representation Rep>
Se3Spline<N, Rep> RandomSegment() {
  Se3Spline<N, Rep> s(ctcal::KnotTiming{0, 50'000'000}, N);
  std::mt19937 rng(1);
  std::normal_distribution<double> gauss(0.0, 0.3);
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (int k = 0; k < N; ++k) {
    q = (q * ctcal::ExpSO3<double>(Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng))))
            .normalized();
    p += Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng));
    s.KnotRotation(k) = q;
    s.KnotPosition(k) = p;
  }
  return s;
}

template <int N, Se3Representation Rep>
void BM_Analytic(benchmark::State& state) {
  using Spline = Se3Spline<N, Rep>;
  auto spline = RandomSegment<N, Rep>();
  const auto mutable_blocks = spline.SegmentBlocks(0);
  std::array<const double*, Spline::kNumBlocks> blocks;
  for (int b = 0; b < Spline::kNumBlocks; ++b)
    blocks[b] = mutable_blocks[b];
  const Eigen::Vector3d g_W(0.0, 0.0, -9.81);
  typename ctcal::Se3Jacobians<double, N>::Block J_R, J_p, J_w, J_f;
  ctcal::Se3Jacobians<double, N> J;
  J.J_R_knots = &J_R;
  J.J_p_knots = &J_p;
  J.J_w_knots = &J_w;
  J.J_f_knots = &J_f;
  double u = 0.0;
  for (auto _ : state) {
    u = u > 0.99 ? 0.0 : u + 0.0137;
    Se3Kinematics<double> kin;
    Spline::EvaluateSegment(blocks.data(), u, 20.0, 2, &g_W, &kin, &J);
    const Eigen::Vector3d f = kin.SpecificForce(g_W);
    benchmark::DoNotOptimize(f);
    benchmark::DoNotOptimize(kin);
    benchmark::DoNotOptimize(J_R.data());
    benchmark::DoNotOptimize(J_p.data());
    benchmark::DoNotOptimize(J_w.data());
    benchmark::DoNotOptimize(J_f.data());
    benchmark::ClobberMemory();
  }
}

template <int N, Se3Representation Rep>
void BM_Jet(benchmark::State& state) {
  using Spline = Se3Spline<N, Rep>;
  constexpr int kAmbient = 7 * N;
  using Jet = ceres::Jet<double, kAmbient>;
  auto spline = RandomSegment<N, Rep>();
  const auto mutable_blocks = spline.SegmentBlocks(0);
  // One derivative per ambient parameter, in block order (as AutoDiffCostFunction seeds them).
  std::vector<Jet> storage(kAmbient);
  std::array<const Jet*, Spline::kNumBlocks> blocks;
  int offset = 0;
  for (int b = 0; b < Spline::kNumBlocks; ++b) {
    for (int i = 0; i < Spline::AmbientSize(b); ++i) {
      storage[offset + i] = Jet(mutable_blocks[b][i], offset + i);
    }
    blocks[b] = storage.data() + offset;
    offset += Spline::AmbientSize(b);
  }
  const ctcal::Vec3T<Jet> g_W(Jet(0.0), Jet(0.0), Jet(-9.81));
  double u = 0.0;
  for (auto _ : state) {
    u = u > 0.99 ? 0.0 : u + 0.0137;
    Se3Kinematics<Jet> kin;
    Spline::EvaluateSegment(blocks.data(), Jet(u), Jet(20.0), 2, &g_W, &kin);
    const ctcal::Vec3T<Jet> f = kin.SpecificForce(g_W);
    benchmark::DoNotOptimize(f);
    benchmark::DoNotOptimize(kin);
    benchmark::ClobberMemory();
  }
}

constexpr auto kSplit = Se3Representation::kSplit;
constexpr auto kJoint = Se3Representation::kJoint;

BENCHMARK_TEMPLATE(BM_Analytic, 4, kSplit);
BENCHMARK_TEMPLATE(BM_Jet, 4, kSplit);
BENCHMARK_TEMPLATE(BM_Analytic, 5, kSplit);
BENCHMARK_TEMPLATE(BM_Jet, 5, kSplit);
BENCHMARK_TEMPLATE(BM_Analytic, 6, kSplit);
BENCHMARK_TEMPLATE(BM_Jet, 6, kSplit);
BENCHMARK_TEMPLATE(BM_Analytic, 4, kJoint);
BENCHMARK_TEMPLATE(BM_Jet, 4, kJoint);
BENCHMARK_TEMPLATE(BM_Analytic, 5, kJoint);
BENCHMARK_TEMPLATE(BM_Jet, 5, kJoint);
BENCHMARK_TEMPLATE(BM_Analytic, 6, kJoint);
BENCHMARK_TEMPLATE(BM_Jet, 6, kJoint);

}  // namespace

BENCHMARK_MAIN();
