// BaseImuResidual: zero at a noise-free truth (trajectory, gravity, bias splines, intrinsics) for
// every IMU model x g_sensitivity, orders 4-6, split and joint, bias orders 2-4; analytic residual
// and Jacobians equal to the Jet autodiff ones and to central differences on every block's
// manifold (gravity on the sphere, the IMU rotation on So3LeftManifold); whitening by the
// per-sample sigmas.
#include "ctcal/calibrator/residuals/base_imu_residual.h"

#include <gtest/gtest.h>

#include <memory>
#include <random>

#include "residual_test_utils.h"

namespace ctcal {
namespace {

constexpr std::int64_t kDtNs = 50'000'000;       // trajectory knots every 50 ms
constexpr std::int64_t kBiasDtNs = 400'000'000;  // bias knots every 0.4 s
constexpr int kNumKnots = 16;

InertialNoise Noise() {
  InertialNoise n;
  n.gyroscope_noise_density = 1.7e-4;
  n.gyroscope_random_walk = 2e-5;
  n.accelerometer_noise_density = 2e-3;
  n.accelerometer_random_walk = 3e-3;
  n.update_rate = 200.0;
  return n;
}

template <typename C>
class BaseImuResidualTest : public ::testing::Test {
 protected:
  static constexpr int N = C::N;
  static constexpr Se3Representation Rep = C::Rep;
  static constexpr int Nb = C::Nb;
  using Residual = BaseImuResidual<N, Rep, Nb>;

  BaseImuResidualTest()
      : spline_(testing::MakeTrajectory<N, Rep>(kNumKnots, kDtNs, 3)),
        bg_(testing::MakeBias<Nb>(6, kBiasDtNs, 0.01, 4)),
        ba_(testing::MakeBias<Nb>(6, kBiasDtNs, 0.1, 5)),
        g_W_(Eigen::Vector3d(0.3, -0.2, -9.7).normalized() * 9.81) {}

  // The setup of a sample at stamp_ns with the noise-free raw reading of `intrinsics`, and the
  // segments (trajectory, bias) it belongs to.
  ImuSampleSetup Truth(const ImuIntrinsics& intrinsics, std::int64_t stamp_ns, int* first,
                       int* bias_first) const {
    Se3Kinematics<double> k;
    spline_.Evaluate(stamp_ns, 0.0, 2, &g_W_, &k, nullptr, first);
    const Eigen::Vector3d b_g = bg_.Evaluate(stamp_ns, 0, 0.0, bias_first);
    const Eigen::Vector3d b_a = ba_.Evaluate(stamp_ns);
    ImuSampleSetup s;
    s.layout = intrinsics.layout();
    intrinsics.RawFromTrue(k.w_B, k.SpecificForce(g_W_), b_g, b_a, &s.z.w_m, &s.z.a_m);
    s.W = ImuWhitening::Of(Noise());
    s.clock = SegmentClock::At(stamp_ns, spline_.timing(), *first);
    s.bias_clock = SegmentClock::At(stamp_ns, bg_.timing(), *bias_first);
    return s;
  }

  std::vector<double*> Blocks(int first, int bias_first, ImuIntrinsics* intrinsics) {
    typename Residual::Parameters p;
    p.traj = testing::SegmentBlocks(&spline_, first);
    p.g_W = g_W_.data();
    p.bg = testing::BiasBlocks(&bg_, bias_first);
    p.ba = testing::BiasBlocks(&ba_, bias_first);
    p.intrinsics = intrinsics;
    return Residual::Blocks(p);
  }

  std::vector<const ceres::Manifold*> Manifolds(const ImuModelLayout& L) const {
    auto m = testing::TrajectoryManifolds<N, Rep>();
    m.push_back(testing::GravityManifold());
    m.insert(m.end(), 2 * Nb, nullptr);
    testing::AppendImuIntrinsicManifolds(L, &m);
    return m;
  }

  Se3Spline<N, Rep> spline_;
  RdSpline<3, Nb> bg_;
  RdSpline<3, Nb> ba_;
  Eigen::Vector3d g_W_;
};

TYPED_TEST_SUITE(BaseImuResidualTest, testing::InertialConfigs);

TYPED_TEST(BaseImuResidualTest, ZeroAtNoiseFreeTruthForEveryModel) {
  constexpr int N = TestFixture::N;
  constexpr Se3Representation Rep = TestFixture::Rep;
  constexpr int Nb = TestFixture::Nb;
  const std::int64_t stamp_ns = testing::kT0Ns + 5 * kDtNs + 12'345'679;
  for (const ImuModel model : testing::kAllImuModels) {
    for (const GSensitivity gs : testing::kAllGSensitivities) {
      SCOPED_TRACE(ToString(model) + " g_sensitivity " + ToString(gs));
      ImuIntrinsics intrinsics = testing::RandomImuIntrinsics(model, gs, 9);
      int first = 0, bias_first = 0;
      const ImuSampleSetup setup = this->Truth(intrinsics, stamp_ns, &first, &bias_first);
      for (const bool analytic : {true, false}) {
        std::unique_ptr<ceres::CostFunction> cost(MakeBaseImuResidual<N, Rep, Nb>(analytic, setup));
        const testing::Evaluation e =
            testing::EvaluateCost(*cost, this->Blocks(first, bias_first, &intrinsics), false);
        ASSERT_TRUE(e.ok);
        EXPECT_LT(e.r.norm(), 1e-7) << (analytic ? "analytic " : "autodiff ") << e.r.transpose();
      }
    }
  }
}

TYPED_TEST(BaseImuResidualTest, AnalyticMatchesAutoDiffAndCentralDifferences) {
  using Residual = typename TestFixture::Residual;
  const std::int64_t stamp_ns = testing::kT0Ns + 7 * kDtNs + 31'000'003;
  for (const ImuModel model : testing::kAllImuModels) {
    for (const GSensitivity gs : testing::kAllGSensitivities) {
      const std::string name = ToString(model) + " g_sensitivity " + ToString(gs);
      ImuIntrinsics intrinsics = testing::RandomImuIntrinsics(model, gs, 10);
      int first = 0, bias_first = 0;
      ImuSampleSetup setup = this->Truth(intrinsics, stamp_ns, &first, &bias_first);
      setup.z.w_m += Eigen::Vector3d(0.01, -0.02, 0.005);  // away from the truth
      setup.z.a_m += Eigen::Vector3d(-0.1, 0.05, 0.2);
      const typename Residual::Analytic analytic(setup);
      std::unique_ptr<ceres::CostFunction> autodiff(Residual::MakeAutoDiff(setup));
      testing::ExpectAnalyticMatchesAutoDiffAndNumeric(analytic, *autodiff,
                                                       this->Blocks(first, bias_first, &intrinsics),
                                                       this->Manifolds(setup.layout), name);
    }
  }
}

// r = W (z - z_pred): an error of one sample sigma on one axis is a residual of exactly 1 there.
TYPED_TEST(BaseImuResidualTest, WhitenedBySampleSigmas) {
  constexpr int N = TestFixture::N;
  constexpr Se3Representation Rep = TestFixture::Rep;
  constexpr int Nb = TestFixture::Nb;
  const std::int64_t stamp_ns = testing::kT0Ns + 6 * kDtNs;
  ImuIntrinsics intrinsics = testing::RandomImuIntrinsics(ImuModel::kImu2, GSensitivity::kNone, 2);
  int first = 0, bias_first = 0;
  ImuSampleSetup setup = this->Truth(intrinsics, stamp_ns, &first, &bias_first);
  setup.z.w_m.y() += Noise().GyroSampleSigma();
  setup.z.a_m.z() -= 2.0 * Noise().AccelSampleSigma();
  std::unique_ptr<ceres::CostFunction> cost(MakeBaseImuResidual<N, Rep, Nb>(true, setup));
  const testing::Evaluation e =
      testing::EvaluateCost(*cost, this->Blocks(first, bias_first, &intrinsics), false);
  Eigen::Matrix<double, 6, 1> expected;
  expected << 0, 1, 0, 0, 0, -2;
  EXPECT_LT((e.r - expected).norm(), 1e-6) << e.r.transpose();
}

}  // namespace
}  // namespace ctcal
