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

constexpr std::int64_t kDtNs = testing::kInertialKnotDtNs;

InertialNoise Noise() {
  return EurocAdis16448Noise(200.0);
}

template <typename C>
class BaseImuResidualTest : public ::testing::Test,
                            protected testing::InertialState<C::N, C::Rep, C::Nb> {
 public:
  static constexpr int N = C::N;
  static constexpr Se3Representation Rep = C::Rep;
  static constexpr int Nb = C::Nb;
  using Residual = BaseImuResidual<N, Rep, Nb>;

  static ceres::CostFunction* MakeResidual(bool analytic, const ImuSampleSetup& setup) {
    return MakeBaseImuResidual<N, Rep, Nb>(analytic, setup);
  }

  BaseImuResidualTest() : testing::InertialState<N, Rep, Nb>(3, Eigen::Vector3d(0.3, -0.2, -9.7)) {}

  // The setup of a sample at stamp_ns with the noise-free raw reading of `intrinsics`, and the
  // segments (trajectory, bias) it belongs to.
  ImuSampleSetup Truth(const ImuIntrinsics& intrinsics, std::int64_t stamp_ns, int* first,
                       int* bias_first) const {
    Se3Kinematics<double> k;
    this->spline_.Evaluate(stamp_ns, 0.0, 2, &this->g_W_, &k, nullptr, first);
    const Eigen::Vector3d b_g = this->bg_.Evaluate(stamp_ns, 0, 0.0, bias_first);
    const Eigen::Vector3d b_a = this->ba_.Evaluate(stamp_ns);
    ImuSampleSetup s;
    s.layout = intrinsics.layout();
    intrinsics.RawFromTrue(k.w_B, k.SpecificForce(this->g_W_), b_g, b_a, &s.z.w_m, &s.z.a_m);
    s.W = ImuWhitening::Of(Noise());
    s.clock = SegmentClock::At(stamp_ns, this->spline_.timing(), *first);
    s.bias_clock = SegmentClock::At(stamp_ns, this->bg_.timing(), *bias_first);
    return s;
  }

  std::vector<double*> Blocks(int first, int bias_first, ImuIntrinsics* intrinsics) {
    typename Residual::Parameters p;
    this->SetSharedBlocks(first, bias_first, intrinsics, &p);
    return Residual::Blocks(p);
  }

  std::vector<const ceres::Manifold*> Manifolds(const ImuModelLayout& L) const {
    auto m = testing::TrajectoryManifolds<N, Rep>();
    m.push_back(testing::GravityManifold());
    m.insert(m.end(), 2 * Nb, nullptr);
    testing::AppendImuIntrinsicManifolds(L, &m);
    return m;
  }
};

TYPED_TEST_SUITE(BaseImuResidualTest, testing::InertialConfigs);

TYPED_TEST(BaseImuResidualTest, ZeroAtNoiseFreeTruthForEveryModel) {
  testing::ExpectZeroAtTruthForEveryImuModel(this, testing::kT0Ns + 5 * kDtNs + 12'345'679, 9);
}

TYPED_TEST(BaseImuResidualTest, AnalyticMatchesAutoDiffAndCentralDifferences) {
  using Residual = typename TestFixture::Residual;
  const std::int64_t stamp_ns = testing::kT0Ns + 7 * kDtNs + 31'000'003;
  testing::ForEveryImuModel(10, [&](const std::string& name, ImuIntrinsics* intrinsics) {
    int first = 0, bias_first = 0;
    ImuSampleSetup setup = this->Truth(*intrinsics, stamp_ns, &first, &bias_first);
    setup.z.w_m += Eigen::Vector3d(0.01, -0.02, 0.005);  // away from the truth
    setup.z.a_m += Eigen::Vector3d(-0.1, 0.05, 0.2);
    const typename Residual::Analytic analytic(setup);
    std::unique_ptr<ceres::CostFunction> autodiff(Residual::MakeAutoDiff(setup));
    testing::ExpectAnalyticMatchesAutoDiffAndNumeric(analytic, *autodiff,
                                                     this->Blocks(first, bias_first, intrinsics),
                                                     this->Manifolds(setup.layout), name);
  });
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
