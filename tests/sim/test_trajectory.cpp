// The analytic trajectories: their closed-form derivatives against central differences of the
// closed-form values, and the properties each scenario promises.
#include <gtest/gtest.h>

#include <cmath>

#include "ctcal/sim/kinematics.h"
#include "ctcal/sim/scenario.h"
#include "ctcal/sim/trajectory.h"
#include "ctcal/spline/so3.h"

namespace ctcal::sim {
namespace {

const Eigen::Vector3d kGravityW = 9.81 * GravityDirectionW();

Scene DefaultScene() {
  return SceneFor(TargetConfig{});
}

// d/dt of the rotation seen in B: Log(R(t-h)^T R(t+h)) / 2h = w_B(t) + O(h^2).
Eigen::Vector3d NumericRate(const Trajectory& traj, double t, double h) {
  const Eigen::Quaterniond q0 = traj.Evaluate(t - h).q_W_B;
  const Eigen::Quaterniond q1 = traj.Evaluate(t + h).q_W_B;
  return LogSO3<double>(q0.conjugate() * q1) / (2.0 * h);
}

class EveryScenario : public ::testing::TestWithParam<std::string> {};

TEST_P(EveryScenario, ClosedFormDerivativesMatchCentralDifferences) {
  const auto traj = MakeTrajectory(ParseScenario(GetParam()), DefaultScene());
  const double h = 1e-4;
  for (double t = -0.3; t < 20.0; t += 0.731) {
    const KinematicState x = traj->Evaluate(t);
    const KinematicState xm = traj->Evaluate(t - h);
    const KinematicState xp = traj->Evaluate(t + h);
    // Central differences are accurate to h^2 * (third derivative) ~ 1e-8 * 100.
    EXPECT_LT(((xp.p_W_B - xm.p_W_B) / (2 * h) - x.v_W).norm(), 1e-6) << "t " << t;
    EXPECT_LT(((xp.v_W - xm.v_W) / (2 * h) - x.a_W).norm(), 1e-5) << "t " << t;
    EXPECT_LT((NumericRate(*traj, t, h) - x.w_B).norm(), 1e-6) << "t " << t;
    EXPECT_LT(((xp.w_B - xm.w_B) / (2 * h) - x.alpha_B).norm(), 1e-5) << "t " << t;
    EXPECT_NEAR(x.q_W_B.norm(), 1.0, 1e-14);
  }
}

INSTANTIATE_TEST_SUITE_P(Sim, EveryScenario, ::testing::ValuesIn(ScenarioNames()),
                         [](const ::testing::TestParamInfo<std::string>& p) {
                           std::string n = p.param;
                           for (char& c : n)
                             c = (c == '-') ? '_' : c;
                           return n;
                         });

TEST(EulerZyx, RatesOfLargeAnglesMatchDifferences) {
  // Far from the small scenario angles, to exercise every coupling term of the closed form.
  SinusoidTrajectory traj;
  traj.yaw = {0.4, {{2.0, 0.3, 0.1}, {0.5, 1.7, 1.0}}};
  traj.pitch = {-0.2, {{1.0, 0.45, 0.7}}};
  traj.roll = {0.3, {{1.5, 0.6, 2.0}, {0.2, 2.3, 0.4}}};
  traj.R_W_0 = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const double h = 1e-5;
  for (double t = 0.0; t < 10.0; t += 0.377) {
    const KinematicState x = traj.Evaluate(t);
    EXPECT_LT((NumericRate(traj, t, h) - x.w_B).norm(), 1e-7 * (1 + x.w_B.norm()));
    const Eigen::Vector3d dw = (traj.Evaluate(t + h).w_B - traj.Evaluate(t - h).w_B) / (2 * h);
    EXPECT_LT((dw - x.alpha_B).norm(), 1e-6 * (1 + x.alpha_B.norm()));
  }
}

TEST(BesselJ, MatchesReferenceValuesAndTheZero) {
  // Abramowitz & Stegun table 9.1.
  EXPECT_NEAR(BesselJ(0, 1.0), 0.765197686557967, 1e-15);
  EXPECT_NEAR(BesselJ(1, 2.0), 0.576724807756873, 1e-15);
  EXPECT_NEAR(BesselJ(2, 3.0), 0.486091260585891, 1e-15);
  EXPECT_NEAR(BesselJ(0, ConstantSpeedLoop::kFirstZeroOfJ0), 0.0, 1e-15);
}

TEST(ConstantSpeedLoop, ClosesAfterEachPeriodAndKeepsItsSpeed) {
  const ConstantSpeedLoop loop(Eigen::Vector2d(0.3, 0.4), 0.3, 0.25, 4.0, {0.7, {}}, {0.0, {}});
  for (double t = 0.0; t < 8.0; t += 0.29) {
    const KinematicState a = loop.Evaluate(t);
    const KinematicState b = loop.Evaluate(t + 4.0 * 12);
    EXPECT_LT((a.p_W_B - b.p_W_B).norm(), 1e-13);
    EXPECT_NEAR(a.v_W.head<2>().norm(), 0.25, 1e-15);
    // x_B is the unit direction of travel.
    const Eigen::Vector3d x_B = a.q_W_B * Eigen::Vector3d::UnitX();
    EXPECT_LT((x_B - a.v_W / 0.25).norm(), 1e-14);
  }
}

// Root mean square over 60 s of a quantity of the state, sampled at 200 Hz.
template <class F>
double Rms(const Trajectory& traj, F f) {
  double sum = 0.0;
  int n = 0;
  for (double t = 0.0; t < 60.0; t += 0.005, ++n)
    sum += f(traj.Evaluate(t));
  return std::sqrt(sum / n);
}

TEST(Scenarios, FullExcitesEveryAxis) {
  const auto traj = MakeTrajectory(Scenario::kFull, DefaultScene());
  const double w_rms = Rms(*traj, [](const KinematicState& x) { return x.w_B.squaredNorm(); });
  const double alpha_rms =
      Rms(*traj, [](const KinematicState& x) { return x.alpha_B.squaredNorm(); });
  EXPECT_GE(w_rms, 1.0);
  EXPECT_GE(alpha_rms, 3.0);
  // Specific force and angular rate vary on every axis (standard deviation over the run).
  for (int axis = 0; axis < 3; ++axis) {
    double sf = 0, sf2 = 0, sw = 0, sw2 = 0;
    int n = 0;
    for (double t = 0.0; t < 60.0; t += 0.01, ++n) {
      const KinematicState x = traj->Evaluate(t);
      const double f =
          IdealInertial(x, kGravityW, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero())
              .a_S[axis];
      sf += f;
      sf2 += f * f;
      sw += x.w_B[axis];
      sw2 += x.w_B[axis] * x.w_B[axis];
    }
    EXPECT_GT(std::sqrt(sf2 / n - (sf / n) * (sf / n)), 0.5) << "specific force axis " << axis;
    EXPECT_GT(std::sqrt(sw2 / n - (sw / n) * (sw / n)), 0.3) << "angular rate axis " << axis;
  }
  // The camera stays at a working distance above the board.
  for (double t = 0.0; t < 60.0; t += 0.1) {
    const double z = traj->Evaluate(t).p_W_B.z();
    EXPECT_GT(z, 0.5);
    EXPECT_LT(z, 1.0);
  }
}

TEST(Scenarios, YawKeepsTheZAxisVerticalAndRotatesAboutItOnly) {
  const auto traj = MakeTrajectory(Scenario::kYaw, DefaultScene());
  double z_span_min = 1e9, z_span_max = -1e9;
  for (double t = 0.0; t < 60.0; t += 0.05) {
    const KinematicState x = traj->Evaluate(t);
    EXPECT_LT((x.q_W_B * Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitZ()).norm(), 1e-15);
    EXPECT_LT(x.w_B.head<2>().norm(), 1e-15);
    EXPECT_LT(x.alpha_B.head<2>().norm(), 1e-15);
    z_span_min = std::min(z_span_min, x.p_W_B.z());
    z_span_max = std::max(z_span_max, x.p_W_B.z());
  }
  EXPECT_GT(z_span_max - z_span_min, 0.1);  // translation is 3-D
  // z_B is parallel to gravity.
  EXPECT_LT(GravityDirectionW().cross(Eigen::Vector3d::UnitZ()).norm(), 1e-15);
}

TEST(Scenarios, PlanarMovesHorizontallyWithYawOnly) {
  const auto traj = MakeTrajectory(Scenario::kPlanar, DefaultScene());
  const double z0 = traj->Evaluate(0.0).p_W_B.z();
  for (double t = 0.0; t < 60.0; t += 0.05) {
    const KinematicState x = traj->Evaluate(t);
    EXPECT_EQ(x.p_W_B.z(), z0);
    EXPECT_EQ(x.v_W.z(), 0.0);
    EXPECT_LT(x.w_B.head<2>().norm(), 1e-15);
  }
}

TEST(Scenarios, NoRotationAndStatic) {
  const auto no_rot = MakeTrajectory(Scenario::kNoRotation, DefaultScene());
  const auto fixed = MakeTrajectory(Scenario::kStatic, DefaultScene());
  const Eigen::Quaterniond q0 = no_rot->Evaluate(0.0).q_W_B;
  const Eigen::Vector3d p0 = fixed->Evaluate(0.0).p_W_B;
  double travel = 0.0;
  for (double t = 0.0; t < 60.0; t += 0.05) {
    const KinematicState x = no_rot->Evaluate(t);
    EXPECT_EQ(x.w_B.norm(), 0.0);
    EXPECT_LT(q0.angularDistance(x.q_W_B), 1e-15);
    travel = std::max(travel, (x.p_W_B - no_rot->Evaluate(0.0).p_W_B).norm());
    const KinematicState s = fixed->Evaluate(t);
    EXPECT_EQ((s.p_W_B - p0).norm(), 0.0);
    EXPECT_EQ(s.v_W.norm() + s.a_W.norm() + s.w_B.norm() + s.alpha_B.norm(), 0.0);
  }
  EXPECT_GT(travel, 0.1);
}

TEST(Scenarios, ConstAccelXHoldsTheXSpecificForceConstant) {
  const auto traj = MakeTrajectory(Scenario::kConstAccelX, DefaultScene());
  double y_min = 1e9, y_max = -1e9;
  for (double t = 0.0; t < 60.0; t += 0.01) {
    const KinematicState x = traj->Evaluate(t);
    const Eigen::Vector3d f =
        IdealInertial(x, kGravityW, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero()).a_S;
    EXPECT_NEAR(f.x(), 0.0, 1e-13) << "t " << t;
    y_min = std::min(y_min, f.y());
    y_max = std::max(y_max, f.y());
  }
  // ... while the other axes are excited.
  EXPECT_GT(y_max - y_min, 1.0);
}

TEST(Kinematics, LeverArmSpecificForceMatchesTheSecondDerivativeOfTheSensorPosition) {
  const auto traj = MakeTrajectory(Scenario::kFull, DefaultScene());
  const Eigen::Matrix3d R_B_S =
      Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -1, 0.5).normalized()).toRotationMatrix();
  const Eigen::Vector3d t_B_S(0.12, -0.07, 0.05);
  const double h = 1e-4;
  for (double t = 0.5; t < 10.0; t += 0.93) {
    const auto p = [&](double s) { return SensorPoseInWorld(traj->Evaluate(s), R_B_S, t_B_S).t; };
    const Eigen::Vector3d acc_W = (p(t + h) - 2.0 * p(t) + p(t - h)) / (h * h);
    const Pose T_W_S = SensorPoseInWorld(traj->Evaluate(t), R_B_S, t_B_S);
    const Eigen::Vector3d expected = T_W_S.R.transpose() * (acc_W - kGravityW);
    const InertialTruth got = IdealInertial(traj->Evaluate(t), kGravityW, R_B_S, t_B_S);
    EXPECT_LT((got.a_S - expected).norm(), 1e-5);
    EXPECT_LT((got.w_S - R_B_S.transpose() * traj->Evaluate(t).w_B).norm(), 1e-15);
  }
}

}  // namespace
}  // namespace ctcal::sim
