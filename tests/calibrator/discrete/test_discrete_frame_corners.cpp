// The discrete problem's compressed frame block (discrete/frame_corners.h) against the per-corner
// Jet blocks it replaces, on the same parameter blocks and manifolds: the problem's cost, gradient
// and Gauss-Newton Hessian J^T J agree to rounding, for A.1 and A.2 poses, both camera models of
// the default rig, plain L2 and the robust stage (Huber with corners beyond the threshold).
#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <memory>
#include <random>
#include <vector>

#include "ctcal/calibrator/discrete/frame_corners.h"
#include "ctcal/spline/so3_manifold.h"
#include "discrete_test_utils.h"

namespace ctcal::discrete {
namespace {

struct Evaluated {
  double cost = 0.0;
  Eigen::VectorXd gradient;
  Eigen::MatrixXd hessian;  // J^T J in the problem's tangent space
};

// Over `blocks` only (the per-corner problem also holds the constant line delay).
Evaluated Evaluate(ceres::Problem* problem, const std::vector<double*>& blocks) {
  Evaluated out;
  std::vector<double> gradient;
  ceres::CRSMatrix crs;
  ceres::Problem::EvaluateOptions options;
  options.parameter_blocks = blocks;
  problem->Evaluate(options, &out.cost, nullptr, &gradient, &crs);
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int r = 0; r < crs.num_rows; ++r) {
    for (int k = crs.rows[static_cast<std::size_t>(r)];
         k < crs.rows[static_cast<std::size_t>(r) + 1]; ++k)
      J(r, crs.cols[static_cast<std::size_t>(k)]) = crs.values[static_cast<std::size_t>(k)];
  }
  out.gradient = Eigen::Map<const Eigen::VectorXd>(gradient.data(),
                                                   static_cast<Eigen::Index>(gradient.size()));
  out.hessian = J.transpose() * J;
  return out;
}

class DiscreteFrameCornersTest : public ::testing::TestWithParam<std::tuple<bool, bool, int>> {
 protected:
  void SetUp() override {
    std::mt19937 rng(11);
    test::RandomKeyframes(&rng, 0.3, 0.05, Eigen::Vector3d(0.0, 0.0, 0.6), 0.025, &k0_, &k1_);
    test::SetBaseScaleAndRotation(&base_);
    // The camera looks down the base frame's -z (towards the board at z = 0 in W).
    const Eigen::Quaterniond q_B_C(
        ExpSO3<double>(Eigen::Vector3d(M_PI, 0.0, 0.0) + Eigen::Vector3d(0.02, -0.03, 0.01)));
    q_B_C_ = {q_B_C.x(), q_B_C.y(), q_B_C.z(), q_B_C.w()};
  }

  Keyframe k0_, k1_;
  ImuIntrinsics base_{ImuModel::kImu2, GSensitivity::kFull};
  std::array<double, 3> g_W_{0.1, -0.2, -9.8};
  std::array<double, 4> q_B_C_{};
  std::array<double, 3> t_B_C_{0.03, -0.01, 0.02};
  double time_offset_ = 0.004;
  double line_delay_ = 0.0;
};

TEST_P(DiscreteFrameCornersTest, CostGradientAndHessianMatchPerCornerBlocks) {
  const auto [kinematic, robust, model_index] = GetParam();
  const CameraModelType type =
      model_index == 0 ? CameraModelType::kPinholeRadtan : CameraModelType::kPinholeEquidistant;
  // pinhole-radtan: fu fv cu cv k1 k2 p1 p2; equidistant: fu fv cu cv k1..k4
  std::vector<double> params =
      model_index == 0 ? std::vector<double>{460.0, 458.0, 370.0, 245.0, -0.28, 0.07, 2e-4, -1e-4}
                       : std::vector<double>{380.0, 381.0, 375.0, 240.0, -0.01, 0.02, -0.01, 0.003};
  const double stamp = kinematic ? k0_.t - time_offset_ + 0.003 : k0_.t - time_offset_ + 0.011;
  const double huber = robust ? 3.0 : 0.0;

  // Corners of a board at z = 0 that project into the image, measured with noise (and, for the
  // robust stage, a few gross errors beyond the Huber threshold).
  std::mt19937 rng(5);
  std::normal_distribution<double> nd(0.0, 1.0);
  std::vector<CornerMeasurement> corners;
  {
    BlockList probe;
    const BaseSource src =
        BaseSource::Add(&probe, &k0_, kinematic ? nullptr : &k1_, &base_, g_W_.data());
    CornerIndex c;
    c.q_B_C = probe.Add(q_B_C_.data(), 4);
    c.t_B_C = probe.Add(t_B_C_.data(), 3);
    c.time_offset = probe.Add(&time_offset_, 1);
    c.line_delay = probe.Add(&line_delay_, 1);
    c.params = probe.Add(params.data(), static_cast<int>(params.size()));
    for (int iy = 0; iy < 6; ++iy) {
      for (int ix = 0; ix < 6; ++ix) {
        CornerMeasurement m;
        m.p_W = Eigen::Vector3d(-0.15 + 0.06 * ix, -0.15 + 0.06 * iy, 0.0);
        m.sigma_px = 0.5 + 0.1 * ((ix + iy) % 3);
        m.uv.setZero();
        const std::unique_ptr<ceres::CostFunction> cost(
            MakeDiscreteCorner(type, m, stamp, src, c, probe));
        Eigen::Vector2d r;
        ASSERT_TRUE(cost->Evaluate(probe.blocks().data(), r.data(), nullptr));
        const Eigen::Vector2d uv = -r * m.sigma_px;
        ASSERT_TRUE(uv.x() > 0 && uv.x() < 752 && uv.y() > 0 && uv.y() < 480) << uv.transpose();
        const double scale = robust && (ix + 2 * iy) % 7 == 0 ? 8.0 : 1.0;
        m.uv = uv + scale * m.sigma_px * Eigen::Vector2d(nd(rng), nd(rng));
        corners.push_back(m);
      }
    }
  }

  So3LeftManifold so3;
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem per_corner(po), per_frame(po);
  // The same blocks, in the same order, with the same manifolds in both problems.
  BlockList list;
  const BaseSource src =
      BaseSource::Add(&list, &k0_, kinematic ? nullptr : &k1_, &base_, g_W_.data());
  FramePoseIndex f;
  f.q_B_C = list.Add(q_B_C_.data(), 4);
  f.t_B_C = list.Add(t_B_C_.data(), 3);
  f.time_offset = list.Add(&time_offset_, 1);
  list.Add(params.data(), static_cast<int>(params.size()));
  for (ceres::Problem* p : {&per_corner, &per_frame}) {
    for (std::size_t b = 0; b < list.blocks().size(); ++b) {
      double* x = list.blocks()[b];
      const bool quat = x == k0_.q_W_B.data() || x == k1_.q_W_B.data() || x == base_.q_rotation() ||
                        x == q_B_C_.data();
      p->AddParameterBlock(x, list.sizes()[b], quat ? &so3 : nullptr);
    }
  }
  per_frame.AddResidualBlock(MakeDiscreteFrameCorners(type, corners, stamp, src, f, list, huber),
                             nullptr, list.blocks());
  // The per-corner blocks also read the (constant, global-shutter) line delay.
  per_corner.AddParameterBlock(&line_delay_, 1);
  per_corner.SetParameterBlockConstant(&line_delay_);
  for (const CornerMeasurement& m : corners) {
    BlockList corner_list;
    const BaseSource s =
        BaseSource::Add(&corner_list, &k0_, kinematic ? nullptr : &k1_, &base_, g_W_.data());
    CornerIndex c;
    c.q_B_C = corner_list.Add(q_B_C_.data(), 4);
    c.t_B_C = corner_list.Add(t_B_C_.data(), 3);
    c.time_offset = corner_list.Add(&time_offset_, 1);
    c.line_delay = corner_list.Add(&line_delay_, 1);
    c.params = corner_list.Add(params.data(), static_cast<int>(params.size()));
    per_corner.AddResidualBlock(MakeDiscreteCorner(type, m, stamp, s, c, corner_list),
                                robust ? new ceres::HuberLoss(huber) : nullptr,
                                corner_list.blocks());
  }
  const Evaluated a = Evaluate(&per_corner, list.blocks());
  const Evaluated b = Evaluate(&per_frame, list.blocks());
  ASSERT_EQ(a.gradient.size(), b.gradient.size());
  EXPECT_GT(a.cost, 10.0);  // noisy, not at a minimum: the gradient is not trivially zero
  EXPECT_NEAR(b.cost, a.cost, 1e-10 * a.cost);
  EXPECT_LT((b.gradient - a.gradient).norm(), 1e-8 * a.gradient.norm())
      << "per corner\n"
      << a.gradient.transpose() << "\nper frame\n"
      << b.gradient.transpose();
  EXPECT_LT((b.hessian - a.hessian).norm(), 1e-8 * a.hessian.norm());
}

INSTANTIATE_TEST_SUITE_P(A1A2RobustModels, DiscreteFrameCornersTest,
                         ::testing::Combine(::testing::Bool(), ::testing::Bool(),
                                            ::testing::Values(0, 1)));

}  // namespace
}  // namespace ctcal::discrete
