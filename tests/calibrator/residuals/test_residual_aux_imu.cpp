// AuxImuResidual: zero at a noise-free truth (lever arm, rotation, time offset, intrinsics, bias
// splines on the sensor's clock) for every IMU model x g_sensitivity, orders 4-6, split and joint,
// bias orders 2-4; analytic residual and Jacobians equal to the Jet autodiff ones and to central
// differences on every block's manifold, the time offset's by shifting the offset itself (also on
// a segment the shifted time has left, u < 0).
#include "ctcal/calibrator/residuals/aux_imu_residual.h"

#include <gtest/gtest.h>

#include <memory>
#include <random>

#include "residual_test_utils.h"

namespace ctcal {
namespace {

constexpr std::int64_t kDtNs = testing::kInertialKnotDtNs;

template <typename C>
class AuxImuResidualTest : public ::testing::Test,
                           protected testing::InertialState<C::N, C::Rep, C::Nb> {
 public:
  static constexpr int N = C::N;
  static constexpr Se3Representation Rep = C::Rep;
  static constexpr int Nb = C::Nb;
  using Residual = AuxImuResidual<N, Rep, Nb>;

  static ceres::CostFunction* MakeResidual(bool analytic, const ImuSampleSetup& setup) {
    return MakeAuxImuResidual<N, Rep, Nb>(analytic, setup);
  }

  AuxImuResidualTest() : testing::InertialState<N, Rep, Nb>(13, Eigen::Vector3d(-0.2, 0.1, -9.7)) {
    std::mt19937 rng(16);
    q_B_S_ = testing::RandomRotation(&rng, 2.0);
    t_B_S_ = Eigen::Vector3d(0.12, -0.07, 0.05);
  }

  ImuSampleSetup Truth(const ImuIntrinsics& intrinsics, std::int64_t stamp_ns, int* first,
                       int* bias_first) const {
    Se3Kinematics<double> k;
    this->spline_.Evaluate(stamp_ns, offset_, 2, &this->g_W_, &k, nullptr, first);
    const Eigen::Matrix3d R_S_B = q_B_S_.toRotationMatrix().transpose();
    const Eigen::Vector3d& r = t_B_S_;
    const Eigen::Vector3d w_S = R_S_B * k.w_B;
    const Eigen::Vector3d a_S =
        R_S_B * (k.SpecificForce(this->g_W_) + k.alpha_B.cross(r) + k.w_B.cross(k.w_B.cross(r)));
    ImuSampleSetup s;
    s.layout = intrinsics.layout();
    intrinsics.RawFromTrue(w_S, a_S, this->bg_.Evaluate(stamp_ns, 0, 0.0, bias_first),
                           this->ba_.Evaluate(stamp_ns), &s.z.w_m, &s.z.a_m);
    s.W = ImuWhitening::Of(EurocAdis16448Noise(400.0));
    s.clock = SegmentClock::At(stamp_ns, this->spline_.timing(), *first);
    s.bias_clock = SegmentClock::At(stamp_ns, this->bg_.timing(), *bias_first);
    return s;
  }

  std::vector<double*> Blocks(int first, int bias_first, ImuIntrinsics* intrinsics) {
    typename Residual::Parameters p;
    this->SetSharedBlocks(first, bias_first, intrinsics, &p);
    p.q_B_S = q_B_S_.coeffs().data();
    p.t_B_S = t_B_S_.data();
    p.time_offset = &offset_;
    return Residual::Blocks(p);
  }

  std::vector<const ceres::Manifold*> Manifolds(const ImuModelLayout& L) const {
    auto m = testing::TrajectoryManifolds<N, Rep>();
    m.insert(m.end(),
             {testing::GravityManifold(), testing::LeftRotationManifold(), nullptr, nullptr});
    m.insert(m.end(), 2 * Nb, nullptr);
    testing::AppendImuIntrinsicManifolds(L, &m);
    return m;
  }

  Eigen::Quaterniond q_B_S_;
  Eigen::Vector3d t_B_S_;
  double offset_ = -0.0071;
};

TYPED_TEST_SUITE(AuxImuResidualTest, testing::InertialConfigs);

TYPED_TEST(AuxImuResidualTest, ZeroAtNoiseFreeTruthForEveryModel) {
  testing::ExpectZeroAtTruthForEveryImuModel(this, testing::kT0Ns + 5 * kDtNs + 2'345'671, 19);
}

TYPED_TEST(AuxImuResidualTest, AnalyticMatchesAutoDiffAndCentralDifferences) {
  using Residual = typename TestFixture::Residual;
  const std::int64_t stamp_ns = testing::kT0Ns + 7 * kDtNs + 1'000'003;
  testing::ForEveryImuModel(20, [&](const std::string& name, ImuIntrinsics* intrinsics) {
    int first = 0, bias_first = 0;
    ImuSampleSetup setup = this->Truth(*intrinsics, stamp_ns, &first, &bias_first);
    setup.z.w_m += Eigen::Vector3d(0.01, -0.02, 0.005);
    setup.z.a_m += Eigen::Vector3d(-0.1, 0.05, 0.2);
    // The sample's own segment, and the next one, on which the shifted time has u < 0.
    for (const int segment : {first, first + 1}) {
      setup.clock = SegmentClock::At(stamp_ns, this->spline_.timing(), segment);
      if (segment != first) {
        EXPECT_LT(setup.clock.U(this->offset_), 0.0);
      }
      const typename Residual::Analytic analytic(setup);
      std::unique_ptr<ceres::CostFunction> autodiff(Residual::MakeAutoDiff(setup));
      testing::ExpectAnalyticMatchesAutoDiffAndNumeric(
          analytic, *autodiff, this->Blocks(segment, bias_first, intrinsics),
          this->Manifolds(setup.layout), name + " segment " + std::to_string(segment));
    }
  });
}

// The sign of the time offset: a sample of a sensor whose clock runs `offset` behind is explained
// by the trajectory at stamp + offset, and not at stamp - offset.
TYPED_TEST(AuxImuResidualTest, TimeOffsetShiftsTheSampleForward) {
  constexpr int N = TestFixture::N;
  constexpr Se3Representation Rep = TestFixture::Rep;
  constexpr int Nb = TestFixture::Nb;
  const std::int64_t stamp_ns = testing::kT0Ns + 6 * kDtNs;
  ImuIntrinsics intrinsics = testing::RandomImuIntrinsics(ImuModel::kImu2, GSensitivity::kNone, 3);
  int first = 0, bias_first = 0;
  const ImuSampleSetup setup = this->Truth(intrinsics, stamp_ns, &first, &bias_first);
  std::unique_ptr<ceres::CostFunction> cost(MakeAuxImuResidual<N, Rep, Nb>(true, setup));
  const std::vector<double*> blocks = this->Blocks(first, bias_first, &intrinsics);
  EXPECT_LT(testing::EvaluateCost(*cost, blocks, false).r.norm(), 1e-7);
  this->offset_ = -this->offset_;
  EXPECT_GT(testing::EvaluateCost(*cost, blocks, false).r.norm(), 1.0);
}

}  // namespace
}  // namespace ctcal
