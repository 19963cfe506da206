// AuxGyroResidual: zero at a noise-free truth for every gyro model (none, upper, full), orders
// 4-6, split and joint, bias orders 2-4; analytic residual and Jacobians equal to the Jet autodiff
// ones and to central differences on every block's manifold (the time offset's by shifting it).
#include "ctcal/calibrator/residuals/aux_gyro_residual.h"

#include <gtest/gtest.h>

#include <memory>
#include <random>

#include "residual_test_utils.h"

namespace ctcal {
namespace {

constexpr std::int64_t kDtNs = 50'000'000;
constexpr std::int64_t kBiasDtNs = 400'000'000;
constexpr int kNumKnots = 16;
constexpr GyroModel kAllGyroModels[] = {GyroModel::kNone, GyroModel::kUpper, GyroModel::kFull};

GyroIntrinsics RandomGyro(GyroModel model, unsigned seed) {
  std::mt19937 rng(seed);
  GyroIntrinsics g(model);
  if (model != GyroModel::kNone)
    g.SetD_w(testing::RandomMatrix(&rng, GyroDwForm(model), Eigen::Matrix3d::Identity(), 0.02));
  return g;
}

template <typename C>
class AuxGyroResidualTest : public ::testing::Test {
 protected:
  static constexpr int N = C::N;
  static constexpr Se3Representation Rep = C::Rep;
  static constexpr int Nb = C::Nb;
  using Residual = AuxGyroResidual<N, Rep, Nb>;

  AuxGyroResidualTest()
      : spline_(testing::MakeTrajectory<N, Rep>(kNumKnots, kDtNs, 23)),
        bg_(testing::MakeBias<Nb>(6, kBiasDtNs, 0.01, 24)) {
    std::mt19937 rng(25);
    q_B_S_ = testing::RandomRotation(&rng, 2.0);
  }

  GyroSampleSetup Truth(const GyroIntrinsics& gyro, std::int64_t stamp_ns, int* first,
                        int* bias_first) const {
    Se3Kinematics<double> k;
    spline_.Evaluate(stamp_ns, offset_, 1, nullptr, &k, nullptr, first);
    GyroSampleSetup s;
    s.model = gyro.model();
    s.w_m = gyro.RawFromTrue(q_B_S_.toRotationMatrix().transpose() * k.w_B,
                             bg_.Evaluate(stamp_ns, 0, 0.0, bias_first));
    s.inv_sigma = 1.0 / 0.004;
    s.clock = SegmentClock::At(stamp_ns, spline_.timing(), *first);
    s.bias_clock = SegmentClock::At(stamp_ns, bg_.timing(), *bias_first);
    return s;
  }

  std::vector<double*> Blocks(int first, int bias_first, GyroIntrinsics* gyro) {
    typename Residual::Parameters p;
    p.traj = testing::SegmentBlocks(&spline_, first);
    p.q_B_S = q_B_S_.coeffs().data();
    p.time_offset = &offset_;
    p.bg = testing::BiasBlocks(&bg_, bias_first);
    p.intrinsics = gyro;
    return Residual::Blocks(p);
  }

  std::vector<const ceres::Manifold*> Manifolds(GyroModel model) const {
    auto m = testing::TrajectoryManifolds<N, Rep>();
    m.insert(m.end(), {testing::LeftRotationManifold(), nullptr});
    m.insert(m.end(), Nb, nullptr);
    if (model != GyroModel::kNone)
      m.push_back(nullptr);
    return m;
  }

  Se3Spline<N, Rep> spline_;
  RdSpline<3, Nb> bg_;
  Eigen::Quaterniond q_B_S_;
  double offset_ = 0.0093;
};

TYPED_TEST_SUITE(AuxGyroResidualTest, testing::InertialConfigs);

TYPED_TEST(AuxGyroResidualTest, ZeroAtNoiseFreeTruthForEveryModel) {
  constexpr int N = TestFixture::N;
  constexpr Se3Representation Rep = TestFixture::Rep;
  constexpr int Nb = TestFixture::Nb;
  const std::int64_t stamp_ns = testing::kT0Ns + 5 * kDtNs + 7'777'777;
  for (const GyroModel model : kAllGyroModels) {
    SCOPED_TRACE(ToString(model));
    GyroIntrinsics gyro = RandomGyro(model, 3);
    int first = 0, bias_first = 0;
    const GyroSampleSetup setup = this->Truth(gyro, stamp_ns, &first, &bias_first);
    testing::ExpectZeroOnBothPaths(
        [&](bool analytic) { return MakeAuxGyroResidual<N, Rep, Nb>(analytic, setup); },
        this->Blocks(first, bias_first, &gyro), 1e-8);
  }
}

TYPED_TEST(AuxGyroResidualTest, AnalyticMatchesAutoDiffAndCentralDifferences) {
  using Residual = typename TestFixture::Residual;
  const std::int64_t stamp_ns = testing::kT0Ns + 7 * kDtNs + 49'000'001;
  for (const GyroModel model : kAllGyroModels) {
    GyroIntrinsics gyro = RandomGyro(model, 4);
    int first = 0, bias_first = 0;
    GyroSampleSetup setup = this->Truth(gyro, stamp_ns, &first, &bias_first);
    setup.w_m += Eigen::Vector3d(0.02, -0.01, 0.03);
    // Own segment, and the previous one on which the shifted time has u > 1.
    for (const int segment : {first, first - 1}) {
      setup.clock = SegmentClock::At(stamp_ns, this->spline_.timing(), segment);
      const typename Residual::Analytic analytic(setup);
      std::unique_ptr<ceres::CostFunction> autodiff(Residual::MakeAutoDiff(setup));
      testing::ExpectAnalyticMatchesAutoDiffAndNumeric(
          analytic, *autodiff, this->Blocks(segment, bias_first, &gyro), this->Manifolds(model),
          ToString(model) + " segment " + std::to_string(segment));
    }
  }
}

}  // namespace
}  // namespace ctcal
