// FrameCornersResidual (the compressed per-frame camera block) against the per-corner blocks it
// replaces: its Jacobians match central differences on every block's manifold at a noise-free
// frame; at a noisy frame (with outliers beyond the Huber threshold) its cost equals the sum of
// the per-corner costs and its gradient and Gauss-Newton Hessian equal theirs, in L2 and Huber;
// and one Levenberg-Marquardt iteration of Ceres over many frames moves every parameter to the
// same value as the per-corner problem does. The same for the split form (pose rows over every
// block, intrinsic rows over the intrinsics), also over several iterations, where the intrinsic
// rows read each candidate point from the blocks' memory. A residual-only evaluation gives the
// same cost.
#include "ctcal/calibrator/residuals/frame_corners_residual.h"

#include <gtest/gtest.h>

#include <deque>
#include <memory>
#include <random>

#include "residual_test_utils.h"

namespace ctcal {
namespace {

using testing::TrajectoryConfig;

constexpr std::int64_t kDtNs = testing::kCameraKnotDtNs;

template <typename C>
class FrameCornersTest : public ::testing::Test, protected testing::CameraState<C::N, C::Rep> {
 protected:
  static constexpr int N = C::N;
  static constexpr Se3Representation Rep = C::Rep;
  using Spline = Se3Spline<N, Rep>;
  using Frame = FrameCornersResidual<N, Rep>;
  using Corner = CornerResidual<N, Rep>;

  FrameCornersTest() : testing::CameraState<N, Rep>(0.0031, 0.0) {}

  int SegmentAt(std::int64_t stamp_ns) const {
    const double s = 1e-9 * static_cast<double>(stamp_ns - testing::kT0Ns) + this->offset_;
    return std::min(static_cast<int>(s / (1e-9 * kDtNs)), this->spline_.NumSegments() - 1);
  }

  // The corners of a board seen at stamp_ns: a 6x5 grid ~1 m in front of the camera (tilted),
  // projected at the true pose; pixel noise of sigma px and `outliers` corners moved by 15 sigma.
  std::vector<CornerMeasurement> Corners(const CameraModel& camera, std::int64_t stamp_ns,
                                         double noise_px, int outliers, unsigned seed) const {
    std::mt19937 rng(seed);
    std::normal_distribution<double> gauss(0.0, 1.0);
    Se3Kinematics<double> k;
    this->spline_.Evaluate(stamp_ns, this->offset_, 0, nullptr, &k);
    const Eigen::Matrix3d R_B_C = this->q_B_C_.toRotationMatrix();
    const Eigen::Matrix3d tilt = ExpSO3<double>(Eigen::Vector3d(0.3, -0.2, 0.1)).toRotationMatrix();
    std::vector<CornerMeasurement> out;
    for (int i = 0; i < 6; ++i) {
      for (int j = 0; j < 5; ++j) {
        const Eigen::Vector3d p_C =
            tilt * Eigen::Vector3d(0.12 * (i - 2.5), 0.12 * (j - 2.0), 0.0) +
            Eigen::Vector3d(0.0, 0.0, 1.0);
        CornerMeasurement m;
        m.p_W = k.R_W_B * (R_B_C * p_C + this->t_B_C_) + k.p_W_B;
        m.sigma_px = 0.5 + 0.1 * ((i + j) % 3);
        EXPECT_TRUE(camera.Project(p_C, &m.uv));
        m.uv += noise_px * m.sigma_px * Eigen::Vector2d(gauss(rng), gauss(rng));
        if (static_cast<int>(out.size()) < outliers)
          m.uv += 15.0 * m.sigma_px * Eigen::Vector2d(0.8, -0.6);
        out.push_back(m);
      }
    }
    return out;
  }

  // The corners as the calibrator holds them (HeldCorner, one frame): corner i is board point i.
  struct HeldFrame {
    std::vector<HeldCorner> corners;
    std::vector<Eigen::Vector3d> board_W;
  };
  static HeldFrame Held(const std::vector<CornerMeasurement>& corners) {
    HeldFrame f;
    for (const CornerMeasurement& m : corners) {
      HeldCorner c;
      c.uv = m.uv;
      c.sigma_px = m.sigma_px;
      c.corner_id = static_cast<std::int32_t>(f.board_W.size());
      f.board_W.push_back(m.p_W);
      f.corners.push_back(c);
    }
    return f;
  }

  std::vector<double*> FrameBlocks(int seg, double* params) {
    typename Frame::Parameters p;
    this->SetCameraBlocks(seg, params, &p);
    return Frame::Blocks(p);
  }

  std::vector<double*> CornerBlocks(int seg, double* params) {
    typename Corner::Parameters p;
    this->SetCameraBlocks(seg, params, &p);
    p.line_delay = &this->line_delay_;
    return Corner::Blocks(p);
  }

  std::vector<const ceres::Manifold*> FrameManifolds() const {
    std::vector<const ceres::Manifold*> m = testing::TrajectoryManifolds<N, Rep>();
    m.insert(m.end(), {testing::LeftRotationManifold(), nullptr, nullptr, nullptr});
    return m;
  }

  // Adds every parameter block of the spline and the camera to P with its manifold.
  void AddParameters(ceres::Problem* P, double* params, int num_params) {
    for (int k = 0; k < this->spline_.NumKnots(); ++k) {
      double* d = this->spline_.KnotData(k);
      if constexpr (Rep == Se3Representation::kJoint) {
        P->AddParameterBlock(d, 7, &se3_);
      } else {
        P->AddParameterBlock(d, 4, &so3_);
        P->AddParameterBlock(d + 4, 3);
      }
    }
    P->AddParameterBlock(this->q_B_C_.coeffs().data(), 4, &left_);
    P->AddParameterBlock(this->t_B_C_.data(), 3);
    P->AddParameterBlock(&this->offset_, 1);
    P->AddParameterBlock(&this->line_delay_, 1);
    P->SetParameterBlockConstant(&this->line_delay_);
    P->AddParameterBlock(params, num_params);
  }

  // How a frame enters a problem.
  enum Mode { kPerCorner = 0, kCompressed = 1, kSplit = 2 };

  // A problem whose evaluation points are written into the blocks' memory (the split form needs
  // that, as in the calibrator).
  ceres::Problem::Options ProblemOptions() {
    ceres::Problem::Options po;
    po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    po.evaluation_callback = &point_in_memory_;
    return po;
  }

  // The frame block (whole or split), or the per-corner blocks of the same corners, added to P;
  // the split blocks read the corners held by the fixture (held_), which outlives P.
  void AddFrame(ceres::Problem* P, int mode, CameraModelType type,
                const std::vector<CornerMeasurement>& corners, std::int64_t stamp, double huber,
                double* params) {
    const int seg = SegmentAt(stamp);
    const SegmentClock clock = SegmentClock::At(stamp, this->spline_.timing(), seg);
    if (mode == kCompressed) {
      P->AddResidualBlock(MakeFrameCornersResidual<N, Rep>(type, corners, clock, huber), nullptr,
                          FrameBlocks(seg, params));
      return;
    }
    if (mode == kSplit) {
      const std::vector<double*> blocks = FrameBlocks(seg, params);
      const HeldFrame& f = held_.emplace_back(Held(corners));
      const int count = static_cast<int>(f.corners.size());
      P->AddResidualBlock(
          MakeFrameCornersResidual<N, Rep>(type, f.corners.data(), count, f.board_W.data(), clock,
                                           huber, FrameRows::kPose),
          nullptr, blocks);
      P->AddResidualBlock(
          MakeFrameCornersResidual<N, Rep>(type, f.corners.data(), count, f.board_W.data(), clock,
                                           huber, FrameRows::kIntrinsics, blocks),
          nullptr, params);
      return;
    }
    for (const CornerMeasurement& m : corners) {
      P->AddResidualBlock(MakeCornerResidual<N, Rep>(true, type, m, clock),
                          huber > 0.0 ? new ceres::HuberLoss(huber) : nullptr,
                          CornerBlocks(seg, params));
    }
  }

  struct PointInMemory : ceres::EvaluationCallback {
    void PrepareForEvaluation(bool, bool) override {}
  } point_in_memory_;
  std::deque<HeldFrame> held_;  // the split blocks' corners (a deque: stable addresses)
  So3RightManifold so3_;
  Se3RightManifold se3_;
  So3LeftManifold left_;
};

using Configs = ::testing::Types<TrajectoryConfig<4, Se3Representation::kSplit>,
                                 TrajectoryConfig<5, Se3Representation::kJoint>>;
TYPED_TEST_SUITE(FrameCornersTest, Configs);

constexpr CameraModelType kModels[] = {CameraModelType::kPinholeRadtan,
                                       CameraModelType::kPinholeEquidistant,
                                       CameraModelType::kDoubleSphere};

// The block with its Jacobians always asked for: a residual-only evaluation returns the cost alone
// (r = [sqrt(sum rho); 0], frame_corners_residual.h), so central differences of the factor's rows
// need the evaluation that factors.
class WithJacobians : public ceres::CostFunction {
 public:
  explicit WithJacobians(const ceres::CostFunction& inner) : inner_(inner) {
    set_num_residuals(inner.num_residuals());
    *mutable_parameter_block_sizes() = inner.parameter_block_sizes();
  }
  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    if (jacobians != nullptr)
      return inner_.Evaluate(p, residuals, jacobians);
    std::vector<std::vector<double>> storage;
    for (const int size : parameter_block_sizes())
      storage.emplace_back(static_cast<std::size_t>(num_residuals() * size));
    std::vector<double*> J;
    for (std::vector<double>& block : storage)
      J.push_back(block.data());
    return inner_.Evaluate(p, residuals, J.data());
  }

 private:
  const ceres::CostFunction& inner_;
};

// Noise-free frame (e = 0, where the Gauss-Newton Jacobian [R; 0] is the exact derivative): the
// analytic Jacobian of every block equals central differences on its manifold.
TYPED_TEST(FrameCornersTest, JacobiansMatchCentralDifferences) {
  for (const CameraModelType type : kModels) {
    Eigen::VectorXd params = testing::CameraParams(type);
    const CameraModel camera(type, params, Eigen::Vector2i(640, 480));
    const std::int64_t stamp = testing::kT0Ns + 437'000'000;
    const auto corners = this->Corners(camera, stamp, 0.0, 0, 1);
    const int seg = this->SegmentAt(stamp);
    const std::unique_ptr<ceres::CostFunction> cost(
        MakeFrameCornersResidual<TestFixture::N, TestFixture::Rep>(
            type, corners, SegmentClock::At(stamp, this->spline_.timing(), seg), 0.0));
    std::vector<double*> blocks = this->FrameBlocks(seg, params.data());
    const auto manifolds = this->FrameManifolds();
    const testing::Evaluation e = testing::EvaluateCost(*cost, blocks);
    ASSERT_TRUE(e.ok);
    EXPECT_LT(e.r.norm(), 1e-9);
    for (std::size_t b = 0; b < blocks.size(); ++b) {
      const Eigen::MatrixXd J = testing::TangentJacobian(e.J[b], manifolds[b], blocks[b]);
      const Eigen::MatrixXd Jn =
          testing::NumericTangentJacobian(WithJacobians(*cost), blocks, static_cast<int>(b),
                                          manifolds[b], b + 1 == blocks.size() ? 1e-5 : 1e-6);
      const double scale = std::max(1.0, testing::MaxAbs(J));
      EXPECT_LT(testing::MaxAbs(J - Jn) / scale, 1e-6)
          << CameraModelName(type) << " block " << b << "\nanalytic\n"
          << J << "\nnumeric\n"
          << Jn;
      EXPECT_LT(testing::MaxAbs(J.bottomRows(1)), 1e-300);  // the remainder row
    }
  }
}

// A block reading corners held by the caller (the calibrator's one compact copy: pixels, board
// ids into a table of board points) is the block that owns full copies of them: the same
// residuals and Jacobians to the last bit, in L2 and with Huber.
TYPED_TEST(FrameCornersTest, HeldCornersGiveTheSameBlockAsOwnedOnes) {
  for (const CameraModelType type : kModels) {
    Eigen::VectorXd params = testing::CameraParams(type);
    const CameraModel camera(type, params, Eigen::Vector2i(640, 480));
    const std::int64_t stamp = testing::kT0Ns + 437'000'000;
    const auto corners = this->Corners(camera, stamp, 1.0, 3, 5);
    const int seg = this->SegmentAt(stamp);
    const SegmentClock clock = SegmentClock::At(stamp, this->spline_.timing(), seg);
    for (const double huber : {0.0, 3.0}) {
      const std::unique_ptr<ceres::CostFunction> owned(
          MakeFrameCornersResidual<TestFixture::N, TestFixture::Rep>(type, corners, clock, huber));
      const auto f = TestFixture::Held(corners);
      const std::unique_ptr<ceres::CostFunction> held(
          MakeFrameCornersResidual<TestFixture::N, TestFixture::Rep>(
              type, f.corners.data(), static_cast<int>(f.corners.size()), f.board_W.data(), clock,
              huber));
      const std::vector<double*> blocks = this->FrameBlocks(seg, params.data());
      const testing::Evaluation a = testing::EvaluateCost(*owned, blocks);
      const testing::Evaluation b = testing::EvaluateCost(*held, blocks);
      ASSERT_TRUE(a.ok && b.ok);
      EXPECT_GT(a.r.norm(), 0.0);
      EXPECT_EQ(a.r, b.r) << CameraModelName(type) << " huber " << huber;
      for (std::size_t k = 0; k < blocks.size(); ++k)
        EXPECT_EQ(a.J[k], b.J[k]) << CameraModelName(type) << " block " << k;
    }
  }
}

// Cost, gradient and Gauss-Newton Hessian (tangent space, as Ceres sees them) of one noisy frame
// with three outliers: compressed == per corner, in L2 and with Huber (threshold 3).
TYPED_TEST(FrameCornersTest, CostGradientAndHessianEqualPerCorner) {
  for (const CameraModelType type : kModels) {
    for (const double huber : {0.0, 3.0}) {
      Eigen::VectorXd params = testing::CameraParams(type);
      const CameraModel camera(type, params, Eigen::Vector2i(640, 480));
      const std::int64_t stamp = testing::kT0Ns + 512'000'000;
      const auto corners = this->Corners(camera, stamp, 1.0, 3, 2);
      struct Eval {
        double cost = 0.0;
        std::vector<double> gradient;
        Eigen::MatrixXd H;
      } ev[3];
      for (int compressed = 0; compressed < 3; ++compressed) {
        ceres::Problem P(this->ProblemOptions());
        this->AddParameters(&P, params.data(), static_cast<int>(params.size()));
        this->AddFrame(&P, compressed, type, corners, stamp, huber, params.data());
        ceres::CRSMatrix crs;
        ASSERT_TRUE(P.Evaluate(ceres::Problem::EvaluateOptions(), &ev[compressed].cost, nullptr,
                               &ev[compressed].gradient, &crs));
        Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
        for (int r = 0; r < crs.num_rows; ++r) {
          for (int i = crs.rows[r]; i < crs.rows[r + 1]; ++i)
            J(r, crs.cols[i]) = crs.values[i];
        }
        ev[compressed].H = J.transpose() * J;
        // A residual-only evaluation (a candidate step's): the same cost, the compressed blocks'
        // summed over the corners without the factorisation.
        double cost_only = 0.0;
        ASSERT_TRUE(
            P.Evaluate(ceres::Problem::EvaluateOptions(), &cost_only, nullptr, nullptr, nullptr));
        EXPECT_NEAR(cost_only, ev[compressed].cost, 1e-12 * ev[compressed].cost)
            << CameraModelName(type) << " " << huber << " mode " << compressed;
      }
      EXPECT_GT(ev[0].cost, 30.0);  // noise and outliers: far from zero
      const Eigen::Map<const Eigen::VectorXd> g0(ev[0].gradient.data(), ev[0].gradient.size());
      for (int m = 1; m < 3; ++m) {
        EXPECT_NEAR(ev[m].cost, ev[0].cost, 1e-12 * ev[0].cost)
            << CameraModelName(type) << " " << huber << " mode " << m;
        const Eigen::Map<const Eigen::VectorXd> g(ev[m].gradient.data(), ev[m].gradient.size());
        ASSERT_EQ(g0.size(), g.size());
        EXPECT_LT((g - g0).cwiseAbs().maxCoeff(), 1e-9 * g0.cwiseAbs().maxCoeff())
            << CameraModelName(type) << " " << huber << " mode " << m;
        EXPECT_LT(testing::MaxAbs(ev[m].H - ev[0].H), 1e-9 * testing::MaxAbs(ev[0].H))
            << CameraModelName(type) << " " << huber << " mode " << m;
      }
      // The split halves hold the whole block's rows: the same normal equations to rounding.
      EXPECT_LT(testing::MaxAbs(ev[2].H - ev[1].H), 1e-13 * testing::MaxAbs(ev[1].H));
    }
  }
}

// One Levenberg-Marquardt iteration of Ceres over 40 noisy frames (spline knots and intrinsics
// free, extrinsics and time offset held): the same step with compressed (whole and split) and
// per-corner blocks; and four iterations (candidate points evaluated, some maybe rejected) the
// same with split and whole blocks.
TYPED_TEST(FrameCornersTest, OneSolverStepEqualsPerCorner) {
  const CameraModelType type = CameraModelType::kPinholeRadtan;
  const Eigen::VectorXd truth = testing::CameraParams(type);
  const CameraModel camera(type, truth, Eigen::Vector2i(640, 480));
  std::vector<std::pair<std::int64_t, std::vector<CornerMeasurement>>> frames;
  const std::int64_t span = (this->spline_.NumKnots() - TestFixture::N) * kDtNs - 20'000'000;
  for (int f = 0; f < 40; ++f) {
    const std::int64_t stamp = testing::kT0Ns + 5'000'000 + f * (span / 40);
    frames.emplace_back(stamp, this->Corners(camera, stamp, 1.0, f % 7 == 0 ? 1 : 0, 100 + f));
  }
  double* knots = this->spline_.KnotData(0);
  const Eigen::Index num_knot_values = 7 * this->spline_.NumKnots();
  const Eigen::VectorXd knots0 = Eigen::Map<const Eigen::VectorXd>(knots, num_knot_values);
  for (const double huber : {0.0, 3.0}) {
    Eigen::VectorXd result[3];
    Eigen::VectorXd four[3];
    for (int run = 0; run < 5; ++run) {
      const int compressed = run < 3 ? run : run - 2;  // runs 3, 4: 4 iterations, whole / split
      const int iterations = run < 3 ? 1 : 4;
      Eigen::Map<Eigen::VectorXd>(knots, num_knot_values) = knots0;
      // Start away from the truth: intrinsics off by a few px / percent.
      Eigen::VectorXd params = truth;
      params.head<4>() += Eigen::Vector4d(3.0, -2.0, 1.5, -1.0);
      params(4) += 0.01;
      ceres::Problem P(this->ProblemOptions());
      this->AddParameters(&P, params.data(), static_cast<int>(params.size()));
      for (const auto& [stamp, corners] : frames)
        this->AddFrame(&P, compressed, type, corners, stamp, huber, params.data());
      P.SetParameterBlockConstant(this->q_B_C_.coeffs().data());
      P.SetParameterBlockConstant(this->t_B_C_.data());
      P.SetParameterBlockConstant(&this->offset_);
      ceres::Solver::Options so;
      so.linear_solver_type = ceres::DENSE_QR;
      so.max_num_iterations = iterations;
      so.logging_type = ceres::SILENT;
      ceres::Solver::Summary summary;
      ceres::Solve(so, &P, &summary);
      if (iterations == 1) {
        ASSERT_EQ(summary.iterations.size(), 2u);
        EXPECT_TRUE(summary.iterations.back().step_is_successful);
      }
      Eigen::VectorXd& out = iterations == 1 ? result[compressed] : four[compressed];
      out.resize(params.size() + num_knot_values);
      out << params, Eigen::Map<const Eigen::VectorXd>(knots, num_knot_values);
      // A real step: the cost fell by far more than the agreement tolerance.
      EXPECT_LT(summary.final_cost, 0.9 * summary.initial_cost);
    }
    // All moved (the intrinsics by ~px) and agree to 1e-9 of the largest value (the focal).
    for (int m = 1; m < 3; ++m) {
      EXPECT_LT((result[m] - result[0]).cwiseAbs().maxCoeff(), 1e-9 * truth.cwiseAbs().maxCoeff())
          << "huber " << huber << " mode " << m;
    }
    EXPECT_GT((four[1] - result[1]).cwiseAbs().maxCoeff(), 1e-6);  // the later iterations moved
    EXPECT_LT((four[2] - four[1]).cwiseAbs().maxCoeff(), 1e-9 * truth.cwiseAbs().maxCoeff())
        << "huber " << huber;
  }
}

}  // namespace
}  // namespace ctcal
