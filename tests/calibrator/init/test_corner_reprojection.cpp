// CornerReprojection, the intrinsics initialisation's residual: for every camera model at poses
// well away from the identity, the analytic residual and Jacobians equal the Jet autodiff ones of
// the same formula (ambient quaternion coefficients, and on the quaternion's tangent) and central
// differences; a corner the model cannot project is rejected.
#include "../../../calibrator/src/init/corner_reprojection.h"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <memory>
#include <random>
#include <string>
#include <vector>

#include "../residuals/residual_test_utils.h"

namespace ctcal {
namespace {

// The autodiff residual that CornerReprojection replaced, as the reference of its derivatives.
template <class Model>
struct AutoDiffCornerReprojection {
  template <typename T>
  bool operator()(const T* params, const T* q, const T* t, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q_C_W(q);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_C_W(t);
    const Eigen::Matrix<T, 3, 1> p_C = q_C_W * p_W.cast<T>() + t_C_W;
    Eigen::Matrix<T, 2, 1> uv_hat;
    if (!Model::template Project<T>(params, p_C, &uv_hat))
      return false;
    residual[0] = uv_hat[0] - T(uv[0]);
    residual[1] = uv_hat[1] - T(uv[1]);
    return true;
  }
  Eigen::Vector3d p_W;
  Eigen::Vector2d uv;
};

template <class Model>
std::unique_ptr<ceres::CostFunction> MakeAutoDiff(const Eigen::Vector3d& p_W,
                                                  const Eigen::Vector2d& uv) {
  return std::make_unique<
      ceres::AutoDiffCostFunction<AutoDiffCornerReprojection<Model>, 2, Model::kNumParams, 4, 3>>(
      new AutoDiffCornerReprojection<Model>{p_W, uv});
}

// A board pose: rotated by 20-60 deg about a random axis, the board 0.8-1.6 m in front of the
// camera.
struct Pose {
  Eigen::Quaterniond q_C_W;
  Eigen::Vector3d t_C_W;
};

std::vector<Pose> Poses() {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::vector<Pose> poses;
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d axis =
        Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng)).normalized();
    const double angle = (40.0 + 20.0 * uniform(rng)) * M_PI / 180.0;
    const Eigen::Quaterniond q(Eigen::AngleAxisd(angle, axis));
    const Eigen::Vector3d centre(0.3 * uniform(rng), 0.3 * uniform(rng), 1.2 + 0.4 * uniform(rng));
    // The board's corner region around (0.2, 0.15, 0) lands near `centre`.
    poses.push_back({q, centre - q * Eigen::Vector3d(0.2, 0.15, 0.0)});
  }
  return poses;
}

const std::vector<Eigen::Vector3d> kCorners = {
    {0.0, 0.0, 0.0}, {0.35, 0.05, 0.0}, {0.1, 0.3, 0.0}, {0.4, 0.25, 0.0}};

TEST(CornerReprojection, AnalyticMatchesAutoDiffAndCentralDifferences) {
  ceres::EigenQuaternionManifold quaternion;
  for (const CameraModelType type : kAllCameraModelTypes) {
    VisitCameraModel(type, [&](auto model) {
      using Model = decltype(model);
      SCOPED_TRACE(std::string(Model::kCameraModel) + "-" + Model::kDistortionModel);
      Eigen::VectorXd params = testing::CameraParams(type);
      for (Pose pose : Poses()) {
        for (const Eigen::Vector3d& p_W : kCorners) {
          Eigen::Vector2d uv;
          ASSERT_TRUE(Model::Project(params.data(), Eigen::Vector3d(pose.q_C_W * p_W + pose.t_C_W),
                                     &uv, nullptr, nullptr));
          uv += Eigen::Vector2d(1.3, -0.8);  // a non-zero residual
          const CornerReprojection<Model> analytic(p_W, uv);
          const std::unique_ptr<ceres::CostFunction> autodiff = MakeAutoDiff<Model>(p_W, uv);
          const std::vector<double*> blocks = {params.data(), pose.q_C_W.coeffs().data(),
                                               pose.t_C_W.data()};
          // Ambient: all 4 quaternion coefficients (the formula holds off the unit sphere too,
          // so its central differences there are the ambient derivatives as well).
          testing::ExpectAnalyticMatchesAutoDiffAndNumeric(
              analytic, *autodiff, blocks, {nullptr, nullptr, nullptr}, "ambient", {}, 1e-9, 1e-6);
          testing::ExpectAnalyticMatchesAutoDiffAndNumeric(analytic, *autodiff, blocks,
                                                           {nullptr, &quaternion, nullptr},
                                                           "tangent", {}, 1e-9, 1e-6);
        }
      }
    });
  }
}

TEST(CornerReprojection, JacobiansOfSomeBlocksOnly) {
  using Model = PinholeRadtanModel;
  Eigen::VectorXd params = testing::CameraParams(CameraModelType::kPinholeRadtan);
  Pose pose = Poses()[0];
  const CornerReprojection<Model> cost(kCorners[1], Eigen::Vector2d(300.0, 200.0));
  const std::vector<double*> blocks = {params.data(), pose.q_C_W.coeffs().data(),
                                       pose.t_C_W.data()};
  const testing::Evaluation all = testing::EvaluateCost(cost, blocks);
  ASSERT_TRUE(all.ok);
  // Ceres passes null for a constant block's Jacobian.
  Eigen::Matrix<double, 2, 4, Eigen::RowMajor> J_q;
  double* jacobians[3] = {nullptr, J_q.data(), nullptr};
  Eigen::Vector2d r;
  ASSERT_TRUE(cost.Evaluate(blocks.data(), r.data(), jacobians));
  EXPECT_EQ(r, all.r);
  EXPECT_EQ(Eigen::MatrixXd(J_q), all.J[1]);
}

TEST(CornerReprojection, CornerBehindTheCameraIsRejected) {
  for (const CameraModelType type :
       {CameraModelType::kPinholeRadtan, CameraModelType::kPinholeNone}) {
    VisitCameraModel(type, [&](auto model) {
      using Model = decltype(model);
      SCOPED_TRACE(std::string(Model::kCameraModel) + "-" + Model::kDistortionModel);
      Eigen::VectorXd params = testing::CameraParams(type);
      Pose pose = Poses()[1];
      pose.t_C_W.z() -= 5.0;
      const CornerReprojection<Model> analytic(kCorners[2], Eigen::Vector2d(300.0, 200.0));
      const std::unique_ptr<ceres::CostFunction> autodiff =
          MakeAutoDiff<Model>(kCorners[2], Eigen::Vector2d(300.0, 200.0));
      const std::vector<double*> blocks = {params.data(), pose.q_C_W.coeffs().data(),
                                           pose.t_C_W.data()};
      EXPECT_FALSE(testing::EvaluateCost(analytic, blocks).ok);
      EXPECT_FALSE(testing::EvaluateCost(analytic, blocks, false).ok);
      EXPECT_FALSE(testing::EvaluateCost(*autodiff, blocks).ok);
    });
  }
}

}  // namespace
}  // namespace ctcal
