// Cost of one Evaluate with every Jacobian, analytic vs Jet autodiff, per residual type: the
// corner (pinhole-radtan) and the base IMU (imu2, g_sensitivity none) for orders 4-6 in both
// representations, the auxiliary IMU and gyroscope for orders 4-6 (split), bias order 4.
// Results: docs/performance.md, "Residual evaluation".
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>
#include <vector>

#include "ctcal/calibrator/residuals/residuals.h"

namespace ctcal {
namespace {

constexpr std::int64_t kT0Ns = 1'000'000'000;
constexpr std::int64_t kDtNs = 50'000'000;
constexpr std::int64_t kBiasDtNs = 500'000'000;
constexpr std::int64_t kStampNs = kT0Ns + 5 * kDtNs + 12'345'678;
constexpr int kNb = 4;

template <int N, Se3Representation Rep>
Se3Spline<N, Rep> Trajectory() {
  Se3Spline<N, Rep> spline(KnotTiming{kT0Ns, kDtNs}, 16);
  for (int k = 0; k < spline.NumKnots(); ++k) {
    const double t = 0.05 * k;
    spline.KnotRotation(k) =
        ExpSO3<double>(Eigen::Vector3d(0.6 * std::sin(1.1 * t), 0.5 * std::cos(0.7 * t), 0.4 * t));
    spline.KnotPosition(k) = Eigen::Vector3d(std::sin(0.9 * t), 0.5 * std::cos(1.3 * t), t - 1.0);
  }
  return spline;
}

RdSpline<3, kNb> Bias(double value) {
  return RdSpline<3, kNb>(KnotTiming{kT0Ns, kBiasDtNs}, 8, Eigen::Vector3d::Constant(value));
}

// Evaluate with every Jacobian block requested, as Ceres does for a variable block.
void Run(benchmark::State& state, const ceres::CostFunction& cost,
         const std::vector<double*>& blocks) {
  std::vector<double> residuals(cost.num_residuals());
  std::vector<std::vector<double>> J;
  std::vector<double*> J_ptr;
  for (const int size : cost.parameter_block_sizes())
    J.emplace_back(static_cast<std::size_t>(size * cost.num_residuals()));
  for (auto& j : J)
    J_ptr.push_back(j.data());
  for (auto _ : state) {
    const bool ok = cost.Evaluate(blocks.data(), residuals.data(), J_ptr.data());
    benchmark::DoNotOptimize(ok);
    benchmark::DoNotOptimize(residuals.data());
    benchmark::ClobberMemory();
  }
}

template <class Spline>
std::vector<double*> Segment(Spline* spline, int first) {
  const auto b = spline->SegmentBlocks(first);
  return std::vector<double*>(b.begin(), b.end());
}

std::vector<double*> BiasSegment(RdSpline<3, kNb>* bias, int first) {
  std::vector<double*> b;
  for (int i = 0; i < kNb; ++i)
    b.push_back(bias->KnotData(first + i));
  return b;
}

template <int N, Se3Representation Rep, bool kAnalytic>
void BM_Corner(benchmark::State& state) {
  using Model = PinholeRadtanModel;
  auto spline = Trajectory<N, Rep>();
  Eigen::Quaterniond q_B_C = Eigen::Quaterniond::Identity();
  Eigen::Vector3d t_B_C(0.05, 0.0, 0.0);
  double offset = 0.001, line_delay = 3e-5;
  Eigen::VectorXd params(8);
  params << 460, 455, 320, 245, -0.25, 0.08, 1e-3, -5e-4;
  Se3Kinematics<double> k;
  int first = 0;
  spline.Evaluate(kStampNs, offset, 0, nullptr, &k, nullptr, &first);
  CornerMeasurement m;
  m.p_W = k.R_W_B * (Eigen::Vector3d(0.1, -0.1, 1.0) + t_B_C) + k.p_W_B;
  m.uv = Eigen::Vector2d(330, 250);
  const SegmentClock clock = SegmentClock::At(kStampNs, spline.timing(), first);
  using R = CornerResidual<N, Rep>;
  std::unique_ptr<ceres::CostFunction> cost(
      kAnalytic
          ? static_cast<ceres::CostFunction*>(new typename R::template Analytic<Model>(m, clock))
          : R::template MakeAutoDiff<Model>(m, clock));
  typename R::Parameters p{Segment(&spline, first),
                           q_B_C.coeffs().data(),
                           t_B_C.data(),
                           &offset,
                           &line_delay,
                           params.data()};
  Run(state, *cost, R::Blocks(p));
}

ImuIntrinsics Imu2() {
  ImuIntrinsics x(ImuModel::kImu2, GSensitivity::kNone);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(0, 1) = 0.01;
  x.SetD_w(D);
  x.SetD_a(D);
  return x;
}

ImuSampleSetup ImuSetup(const KnotTiming& timing, int first, int bias_first) {
  ImuSampleSetup s;
  s.layout = ImuModelLayout::Of(ImuModel::kImu2, GSensitivity::kNone);
  s.z.w_m = Eigen::Vector3d(0.1, 0.2, 0.3);
  s.z.a_m = Eigen::Vector3d(0.1, 0.2, 9.8);
  s.W = ImuWhitening{100.0, 30.0};
  s.clock = SegmentClock::At(kStampNs, timing, first);
  s.bias_clock = SegmentClock::At(kStampNs, KnotTiming{kT0Ns, kBiasDtNs}, bias_first);
  return s;
}

template <int N, Se3Representation Rep, bool kAnalytic>
void BM_BaseImu(benchmark::State& state) {
  auto spline = Trajectory<N, Rep>();
  auto bg = Bias(0.01), ba = Bias(0.1);
  Eigen::Vector3d g_W(0, 0, -9.81);
  ImuIntrinsics imu = Imu2();
  const int first = spline.ComputeIndexOrThrow(kStampNs).first_index;
  const int bias_first = bg.ComputeIndexOrThrow(kStampNs).first_index;
  using R = BaseImuResidual<N, Rep, kNb>;
  std::unique_ptr<ceres::CostFunction> cost(
      MakeBaseImuResidual<N, Rep, kNb>(kAnalytic, ImuSetup(spline.timing(), first, bias_first)));
  typename R::Parameters p{Segment(&spline, first), g_W.data(), BiasSegment(&bg, bias_first),
                           BiasSegment(&ba, bias_first), &imu};
  Run(state, *cost, R::Blocks(p));
}

template <int N, Se3Representation Rep, bool kAnalytic>
void BM_AuxImu(benchmark::State& state) {
  auto spline = Trajectory<N, Rep>();
  auto bg = Bias(0.01), ba = Bias(0.1);
  Eigen::Vector3d g_W(0, 0, -9.81), t_B_S(0.1, 0.05, -0.02);
  Eigen::Quaterniond q_B_S = Eigen::Quaterniond::Identity();
  double offset = 0.002;
  ImuIntrinsics imu = Imu2();
  const int first = spline.ComputeIndexOrThrow(kStampNs, offset).first_index;
  const int bias_first = bg.ComputeIndexOrThrow(kStampNs).first_index;
  using R = AuxImuResidual<N, Rep, kNb>;
  std::unique_ptr<ceres::CostFunction> cost(
      MakeAuxImuResidual<N, Rep, kNb>(kAnalytic, ImuSetup(spline.timing(), first, bias_first)));
  typename R::Parameters p{Segment(&spline, first),
                           g_W.data(),
                           q_B_S.coeffs().data(),
                           t_B_S.data(),
                           &offset,
                           BiasSegment(&bg, bias_first),
                           BiasSegment(&ba, bias_first),
                           &imu};
  Run(state, *cost, R::Blocks(p));
}

template <int N, Se3Representation Rep, bool kAnalytic>
void BM_AuxGyro(benchmark::State& state) {
  auto spline = Trajectory<N, Rep>();
  auto bg = Bias(0.01);
  Eigen::Quaterniond q_B_S = Eigen::Quaterniond::Identity();
  double offset = 0.002;
  GyroIntrinsics gyro(GyroModel::kUpper);
  const int first = spline.ComputeIndexOrThrow(kStampNs, offset).first_index;
  const int bias_first = bg.ComputeIndexOrThrow(kStampNs).first_index;
  GyroSampleSetup s;
  s.model = GyroModel::kUpper;
  s.w_m = Eigen::Vector3d(0.1, 0.2, 0.3);
  s.inv_sigma = 100.0;
  s.clock = SegmentClock::At(kStampNs, spline.timing(), first);
  s.bias_clock = SegmentClock::At(kStampNs, bg.timing(), bias_first);
  using R = AuxGyroResidual<N, Rep, kNb>;
  std::unique_ptr<ceres::CostFunction> cost(MakeAuxGyroResidual<N, Rep, kNb>(kAnalytic, s));
  typename R::Parameters p{Segment(&spline, first), q_B_S.coeffs().data(), &offset,
                           BiasSegment(&bg, bias_first), &gyro};
  Run(state, *cost, R::Blocks(p));
}

constexpr Se3Representation kSplit = Se3Representation::kSplit;
constexpr Se3Representation kJoint = Se3Representation::kJoint;

#define CTCAL_BENCH_BOTH(NAME, N, REP)    \
  BENCHMARK_TEMPLATE(NAME, N, REP, true); \
  BENCHMARK_TEMPLATE(NAME, N, REP, false);

CTCAL_BENCH_BOTH(BM_Corner, 4, kSplit)
CTCAL_BENCH_BOTH(BM_Corner, 5, kSplit)
CTCAL_BENCH_BOTH(BM_Corner, 6, kSplit)
CTCAL_BENCH_BOTH(BM_Corner, 4, kJoint)
CTCAL_BENCH_BOTH(BM_Corner, 5, kJoint)
CTCAL_BENCH_BOTH(BM_Corner, 6, kJoint)
CTCAL_BENCH_BOTH(BM_BaseImu, 4, kSplit)
CTCAL_BENCH_BOTH(BM_BaseImu, 5, kSplit)
CTCAL_BENCH_BOTH(BM_BaseImu, 6, kSplit)
CTCAL_BENCH_BOTH(BM_BaseImu, 4, kJoint)
CTCAL_BENCH_BOTH(BM_BaseImu, 5, kJoint)
CTCAL_BENCH_BOTH(BM_BaseImu, 6, kJoint)
CTCAL_BENCH_BOTH(BM_AuxImu, 4, kSplit)
CTCAL_BENCH_BOTH(BM_AuxImu, 5, kSplit)
CTCAL_BENCH_BOTH(BM_AuxImu, 6, kSplit)
CTCAL_BENCH_BOTH(BM_AuxGyro, 4, kSplit)
CTCAL_BENCH_BOTH(BM_AuxGyro, 5, kSplit)
CTCAL_BENCH_BOTH(BM_AuxGyro, 6, kSplit)

}  // namespace
}  // namespace ctcal

BENCHMARK_MAIN();
