// The camera-only frame block (board_frame_corners.h): its cost is the per-corner cost (with Huber:
// Ceres' HuberLoss summed over the corners) and its analytic Jacobians give the gradient of that
// cost on every block's manifold (central differences through the manifolds' Plus).
#include "ctcal/calibrator/camera_only/board_frame_corners.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <functional>
#include <random>
#include <vector>

#include "ctcal/sensors/camera_model.h"
#include "ctcal/sim/default_rig.h"
#include "ctcal/targets/board.h"

namespace ctcal {
namespace {

struct Frame {
  CameraModel camera;
  double T_W_B[7];  // q (x, y, z, w), p
  double q_B_C[4];
  double t_B_C[3];
  std::vector<CornerMeasurement> corners;
};

void SetPose(const Eigen::Quaterniond& q, const Eigen::Vector3d& p, double* q_out, double* p_out) {
  q_out[0] = q.x();
  q_out[1] = q.y();
  q_out[2] = q.z();
  q_out[3] = q.w();
  for (int i = 0; i < 3; ++i)
    p_out[i] = p(i);
}

// Camera `name` of the default rig looking at its board from ~1 m, T_B_C off the identity, 1 px
// noise and every 10th corner 8 px off (beyond the Huber threshold of 2 sigma).
Frame MakeFrame(const std::string& name) {
  const RigConfig rig = sim::DefaultRig();
  const SensorConfig& s = *rig.Find(name);
  Frame f{CameraModel::Create(s.camera_model, s.intrinsics, s.distortion_model, s.distortion_coeffs,
                              Eigen::Vector2i(s.width, s.height)),
          {},
          {},
          {},
          {}};
  const Board board(rig.target);
  const Eigen::Quaterniond q_B_C(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()));
  const Eigen::Vector3d t_B_C(0.05, -0.02, 0.01);
  // The camera 1.2 m in front of the board's centre, looking at it with a tilt.
  const Eigen::Vector3d centre = 0.5 * (board.Corner(0) + board.Corner(board.NumCorners() - 1));
  const Eigen::Matrix3d R_W_C = (Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()) *
                                 Eigen::AngleAxisd(0.25, Eigen::Vector3d(1, -1, 0).normalized()))
                                    .toRotationMatrix();
  const Eigen::Vector3d p_W_C = centre - R_W_C * Eigen::Vector3d(0.0, 0.0, 1.2);
  const Eigen::Matrix3d R_W_B = R_W_C * q_B_C.toRotationMatrix().transpose();
  const Eigen::Vector3d p_W_B = p_W_C - R_W_B * t_B_C;
  SetPose(Eigen::Quaterniond(R_W_B), p_W_B, f.T_W_B, f.T_W_B + 4);
  SetPose(q_B_C, t_B_C, f.q_B_C, f.t_B_C);
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (int id = 0; id < board.NumCorners(); ++id) {
    const Eigen::Vector3d p_C = R_W_C.transpose() * (board.Corner(id) - p_W_C);
    Eigen::Vector2d uv = Eigen::Vector2d::Zero();
    if (!f.camera.Project(p_C, &uv))
      continue;
    CornerMeasurement m;
    m.p_W = board.Corner(id);
    m.uv = uv + Eigen::Vector2d(noise(rng), noise(rng)) +
           (id % 10 == 0 ? 8.0 : 0.0) * Eigen::Vector2d(0.6, 0.8);
    m.sigma_px = 1.0;
    f.corners.push_back(m);
  }
  return f;
}

// Sum over the corners of rho(||e||^2) / 2 (rho = Ceres' HuberLoss(a), or s for a = 0): the
// per-corner blocks' cost.
double PerCornerCost(const Frame& f, const double* T_W_B, const double* q_B_C, const double* t_B_C,
                     const double* params, double a) {
  const Eigen::Matrix3d R_W_B = Eigen::Map<const Eigen::Quaterniond>(T_W_B).toRotationMatrix();
  const Eigen::Matrix3d R_B_C = Eigen::Map<const Eigen::Quaterniond>(q_B_C).toRotationMatrix();
  double cost = 0.0;
  return VisitCameraModel(f.camera.type(), [&](auto model) {
    using Model = decltype(model);
    for (const CornerMeasurement& m : f.corners) {
      const Eigen::Vector3d p_B =
          R_W_B.transpose() * (m.p_W - Eigen::Map<const Eigen::Vector3d>(T_W_B + 4));
      const Eigen::Vector3d p_C =
          R_B_C.transpose() * (p_B - Eigen::Map<const Eigen::Vector3d>(t_B_C));
      Eigen::Vector2d uv = Eigen::Vector2d::Zero();
      EXPECT_TRUE(Model::template Project<double>(params, p_C, &uv));
      const double s = ((uv - m.uv) / m.sigma_px).squaredNorm();
      cost += 0.5 * (a > 0.0 && s > a * a ? 2.0 * a * std::sqrt(s) - a * a : s);
    }
    return cost;
  });
}

void ExpectCostAndGradient(const std::string& name, double huber) {
  Frame f = MakeFrame(name);
  ASSERT_GT(f.corners.size(), 40u) << name;
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  BoardPoseManifold pose_manifold;
  So3LeftManifold so3;
  double* params = f.camera.mutable_params();
  problem.AddResidualBlock(MakeBoardFrameCorners(f.camera.type(), f.corners.data(),
                                                 static_cast<int>(f.corners.size()), huber),
                           nullptr, f.T_W_B, f.q_B_C, f.t_B_C, params);
  problem.SetManifold(f.T_W_B, &pose_manifold);
  problem.SetManifold(f.q_B_C, &so3);
  double cost = 0.0;
  std::vector<double> gradient;
  ASSERT_TRUE(problem.Evaluate({}, &cost, nullptr, &gradient, nullptr));
  const double reference = PerCornerCost(f, f.T_W_B, f.q_B_C, f.t_B_C, params, huber);
  EXPECT_NEAR(cost, reference, 1e-10 * reference) << name;

  // Central differences of the per-corner cost along every tangent coordinate, in Ceres' block
  // order (T_W_B 6, q_B_C 3, t_B_C 3, params).
  const int n_params = f.camera.NumParams();
  ASSERT_EQ(gradient.size(), static_cast<std::size_t>(12 + n_params));
  std::size_t k = 0;
  auto check = [&](int tangent, const std::function<double(int, double)>& cost_at, double h,
                   const char* block) {
    for (int i = 0; i < tangent; ++i, ++k) {
      const double numeric = (cost_at(i, h) - cost_at(i, -h)) / (2.0 * h);
      EXPECT_NEAR(gradient[k], numeric, 1e-6 * (1.0 + std::abs(numeric)))
          << name << " huber " << huber << " " << block << "[" << i << "]";
    }
  };
  check(
      6,
      [&](int i, double h) {
        double delta[6] = {}, x[7];
        delta[i] = h;
        pose_manifold.Plus(f.T_W_B, delta, x);
        return PerCornerCost(f, x, f.q_B_C, f.t_B_C, params, huber);
      },
      1e-6, "T_W_B");
  check(
      3,
      [&](int i, double h) {
        double delta[3] = {}, q[4];
        delta[i] = h;
        so3.Plus(f.q_B_C, delta, q);
        return PerCornerCost(f, f.T_W_B, q, f.t_B_C, params, huber);
      },
      1e-6, "q_B_C");
  check(
      3,
      [&](int i, double h) {
        double t[3] = {f.t_B_C[0], f.t_B_C[1], f.t_B_C[2]};
        t[i] += h;
        return PerCornerCost(f, f.T_W_B, f.q_B_C, t, params, huber);
      },
      1e-6, "t_B_C");
  check(
      n_params,
      [&](int i, double h) {
        std::vector<double> theta(params, params + n_params);
        theta[static_cast<std::size_t>(i)] +=
            h * std::max(1.0, std::abs(theta[static_cast<std::size_t>(i)]));
        return PerCornerCost(f, f.T_W_B, f.q_B_C, f.t_B_C, theta.data(), huber) /
               std::max(1.0, std::abs(params[i]));
      },
      1e-6, "params");
}

TEST(BoardFrameCorners, CostAndGradientArePerCornerOnesL2) {
  for (const char* name : {"cam0", "cam1"})
    ExpectCostAndGradient(name, 0.0);
}

TEST(BoardFrameCorners, CostAndGradientArePerCornerOnesHuber) {
  for (const char* name : {"cam0", "cam1"})
    ExpectCostAndGradient(name, 2.0);
}

}  // namespace
}  // namespace ctcal
