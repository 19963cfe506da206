// CornerResidual: zero at a noise-free rolling-shutter truth for every camera model, order and
// representation; analytic residual and Jacobians equal to the Jet autodiff ones and to central
// differences on every block's manifold (including time offset and line delay, and a sample whose
// offset pushed it past its segment's end); invalid projections rejected.
#include "ctcal/calibrator/residuals/corner_residual.h"

#include <gtest/gtest.h>

#include <memory>
#include <random>

#include "residual_test_utils.h"

namespace ctcal {
namespace {

constexpr std::int64_t kDtNs = testing::kCameraKnotDtNs;

template <typename C>
class CornerResidualTest : public ::testing::Test, protected testing::CameraState<C::N, C::Rep> {
 protected:
  static constexpr int N = C::N;
  static constexpr Se3Representation Rep = C::Rep;
  using Spline = Se3Spline<N, Rep>;
  using Residual = CornerResidual<N, Rep>;

  CornerResidualTest() : testing::CameraState<N, Rep>(0.0123, 3.1e-5) {}

  // A corner seen at stamp_ns: its p_W is chosen in front of the camera at the nominal read-out
  // time; then uv is iterated to the fixed point uv = project(p_C(t_S + offset + v line_delay)).
  CornerMeasurement Truth(const Eigen::VectorXd& params, CameraModelType type,
                          std::int64_t stamp_ns, const Eigen::Vector3d& p_C_nominal) const {
    const CameraModel camera(type, params, Eigen::Vector2i(640, 480));
    const auto pose_at = [&](double v) {
      Se3Kinematics<double> k;
      this->spline_.Evaluate(stamp_ns, this->offset_ + v * this->line_delay_, 0, nullptr, &k);
      return k;
    };
    const Eigen::Matrix3d R_B_C = this->q_B_C_.toRotationMatrix();
    Se3Kinematics<double> k = pose_at(240.0);
    CornerMeasurement m;
    m.p_W = k.R_W_B * (R_B_C * p_C_nominal + this->t_B_C_) + k.p_W_B;
    m.sigma_px = 0.7;
    double v = 240.0;
    for (int it = 0; it < 50; ++it) {
      k = pose_at(v);
      const Eigen::Vector3d p_C =
          R_B_C.transpose() * (k.R_W_B.transpose() * (m.p_W - k.p_W_B) - this->t_B_C_);
      EXPECT_TRUE(camera.Project(p_C, &m.uv));
      v = m.uv.y();
    }
    return m;
  }

  std::vector<double*> Blocks(int first_index, double* params) {
    typename Residual::Parameters p;
    this->SetCameraBlocks(first_index, params, &p);
    p.line_delay = &this->line_delay_;
    return Residual::Blocks(p);
  }

  // A line delay of 1e-6 s/row would shift the sample by ~0.3 ms: far outside the linear regime.
  static std::vector<double> LineDelayStep() {
    std::vector<double> steps(Residual::kNumBlocks, 0.0);
    steps[Residual::kLineDelay] = 1e-9;
    return steps;
  }

  std::vector<const ceres::Manifold*> Manifolds() const {
    auto m = testing::TrajectoryManifolds<N, Rep>();
    m.insert(m.end(), {testing::LeftRotationManifold(), nullptr, nullptr, nullptr, nullptr});
    return m;
  }

  // The segment containing t and the clock of a sample stamped stamp_ns in it.
  int SegmentOf(std::int64_t stamp_ns, double shift) const {
    return this->spline_.ComputeIndexOrThrow(stamp_ns, shift).first_index;
  }
};

TYPED_TEST_SUITE(CornerResidualTest, testing::TrajectoryConfigs);

TYPED_TEST(CornerResidualTest, ZeroAtNoiseFreeTruthForEveryCameraModel) {
  constexpr int N = TestFixture::N;
  constexpr Se3Representation Rep = TestFixture::Rep;
  const std::int64_t stamp_ns = testing::kT0Ns + 4 * kDtNs + 37'123'457;
  for (const CameraModelType type : kAllCameraModelTypes) {
    SCOPED_TRACE(CameraModelName(type) + "-" + DistortionModelName(type));
    Eigen::VectorXd params = testing::CameraParams(type);
    const CornerMeasurement m =
        this->Truth(params, type, stamp_ns, Eigen::Vector3d(0.3, -0.2, 1.5));
    // The residual is built for the segment of the shifted time, as the pipeline does.
    const int first = this->SegmentOf(stamp_ns, this->offset_ + m.uv.y() * this->line_delay_);
    const SegmentClock clock = SegmentClock::At(stamp_ns, this->spline_.timing(), first);
    for (const bool analytic : {true, false}) {
      std::unique_ptr<ceres::CostFunction> cost(
          MakeCornerResidual<N, Rep>(analytic, type, m, clock));
      const testing::Evaluation e =
          testing::EvaluateCost(*cost, this->Blocks(first, params.data()), false);
      ASSERT_TRUE(e.ok);
      EXPECT_LT(e.r.norm(), 1e-8) << (analytic ? "analytic" : "autodiff") << " " << e.r.transpose();
    }
  }
}

TYPED_TEST(CornerResidualTest, AnalyticMatchesAutoDiffAndCentralDifferences) {
  using Residual = typename TestFixture::Residual;
  const std::int64_t stamp_ns = testing::kT0Ns + 5 * kDtNs + 61'000'017;
  for (const CameraModelType type : kAllCameraModelTypes) {
    VisitCameraModel(type, [&](auto model) {
      using Model = decltype(model);
      SCOPED_TRACE(std::string(Model::kCameraModel) + "-" + Model::kDistortionModel);
      Eigen::VectorXd params = testing::CameraParams(type);
      CornerMeasurement m = this->Truth(params, type, stamp_ns, Eigen::Vector3d(-0.4, 0.25, 1.2));
      m.uv += Eigen::Vector2d(1.3, -0.8);  // away from the truth: every term of the chain counts
      // Two segments: the sample's own (u in [0, 1]) and the previous one, where the shifted time
      // lies past the end (u > 1), as after a time offset moved during a solve.
      const int own = this->SegmentOf(stamp_ns, this->offset_ + m.uv.y() * this->line_delay_);
      for (const int first : {own, own - 1}) {
        const SegmentClock clock = SegmentClock::At(stamp_ns, this->spline_.timing(), first);
        if (first != own) {
          EXPECT_GT(clock.U(this->offset_ + m.uv.y() * this->line_delay_), 1.0);
        }
        typename Residual::template Analytic<Model> analytic(m, clock);
        std::unique_ptr<ceres::CostFunction> autodiff(
            Residual::template MakeAutoDiff<Model>(m, clock));
        testing::ExpectAnalyticMatchesAutoDiffAndNumeric(
            analytic, *autodiff, this->Blocks(first, params.data()), this->Manifolds(),
            "segment " + std::to_string(first), TestFixture::LineDelayStep());
      }
    });
  }
}

TYPED_TEST(CornerResidualTest, PointBehindTheCameraIsRejected) {
  constexpr int N = TestFixture::N;
  constexpr Se3Representation Rep = TestFixture::Rep;
  const std::int64_t stamp_ns = testing::kT0Ns + 4 * kDtNs;
  Eigen::VectorXd params = testing::CameraParams(CameraModelType::kPinholeRadtan);
  CornerMeasurement m = this->Truth(params, CameraModelType::kPinholeRadtan, stamp_ns,
                                    Eigen::Vector3d(0.1, 0.1, 1.0));
  // Move the corner to the mirror point behind the camera.
  const Se3Kinematics<double> k = this->spline_.Evaluate(stamp_ns, 0);
  const Eigen::Vector3d c_W = k.R_W_B * this->t_B_C_ + k.p_W_B;
  m.p_W = c_W - (m.p_W - c_W);
  const int first = this->SegmentOf(stamp_ns, 0.0);
  const SegmentClock clock = SegmentClock::At(stamp_ns, this->spline_.timing(), first);
  for (const bool analytic : {true, false}) {
    std::unique_ptr<ceres::CostFunction> cost(
        MakeCornerResidual<N, Rep>(analytic, CameraModelType::kPinholeRadtan, m, clock));
    EXPECT_FALSE(testing::EvaluateCost(*cost, this->Blocks(first, params.data())).ok);
  }
}

}  // namespace
}  // namespace ctcal
