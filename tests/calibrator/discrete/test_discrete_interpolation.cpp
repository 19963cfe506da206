// Pose interpolation between keyframes (appendix A) against the simulator's analytic trajectory.
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <cstdio>

#include "ctcal/calibrator/discrete/pose_interpolation.h"
#include "ctcal/sim/scenario.h"

namespace ctcal::discrete {
namespace {

const Eigen::Vector3d kGravityW(0.0, 0.0, -9.81);

struct Errors {
  double rot = 0, pos = 0;
};

// Maximum error over queries inside 30 intervals of the given spacing.
Errors GeodesicError(const sim::Trajectory& traj, double spacing) {
  Errors e;
  for (int n = 0; n < 30; ++n) {
    const double t_k = 2.0 + 0.173 * n, t_k1 = t_k + spacing;
    const sim::KinematicState a = traj.Evaluate(t_k), b = traj.Evaluate(t_k1);
    for (double u : {0.25, 0.5, 0.75}) {
      const double t = t_k + u * spacing;
      const sim::KinematicState x = traj.Evaluate(t);
      const auto pose =
          InterpolateGeodesic<double>(a.q_W_B, a.p_W_B, b.q_W_B, b.p_W_B, t_k, t_k1, t);
      e.rot = std::max(e.rot, RotationError<double>(pose.q_W_B, x.q_W_B).norm());
      e.pos = std::max(e.pos, (pose.p_W_B - x.p_W_B).norm());
    }
  }
  return e;
}

Errors KinematicError(const sim::Trajectory& traj, double s) {
  Errors e;
  for (int n = 0; n < 30; ++n) {
    const double t_k = 2.0 + 0.173 * n;
    const sim::KinematicState a = traj.Evaluate(t_k), x = traj.Evaluate(t_k + s);
    const Eigen::Vector3d a_B = a.q_W_B.conjugate() * (a.a_W - kGravityW);
    const auto pose =
        PropagateKinematic<double>(a.q_W_B, a.p_W_B, a.v_W, a.w_B, a_B, kGravityW, t_k, t_k + s);
    e.rot = std::max(e.rot, RotationError<double>(pose.q_W_B, x.q_W_B).norm());
    e.pos = std::max(e.pos, (pose.p_W_B - x.p_W_B).norm());
  }
  return e;
}

// Exact at the keyframes, and second order in the spacing: halving it divides the error by ~4.
TEST(DiscreteInterpolation, GeodesicErrorIsSecondOrderInKeyframeSpacing) {
  const auto traj = sim::MakeTrajectory(sim::Scenario::kFull, sim::Scene{});
  const sim::KinematicState a = traj->Evaluate(2.0), b = traj->Evaluate(2.1);
  const auto at_k1 = InterpolateGeodesic<double>(a.q_W_B, a.p_W_B, b.q_W_B, b.p_W_B, 2.0, 2.1, 2.1);
  EXPECT_LT(RotationError<double>(at_k1.q_W_B, b.q_W_B).norm(), 1e-12);
  EXPECT_LT((at_k1.p_W_B - b.p_W_B).norm(), 1e-12);
  Errors prev;
  for (double spacing : {0.1, 0.05, 0.025}) {
    const Errors e = GeodesicError(*traj, spacing);
    std::printf("A.2 spacing %.3f s: max rotation error %.2e rad, position %.2e m\n", spacing,
                e.rot, e.pos);
    if (prev.rot > 0) {
      EXPECT_NEAR(prev.rot / e.rot, 4.0, 1.0);
      EXPECT_NEAR(prev.pos / e.pos, 4.0, 1.0);
    }
    prev = e;
  }
}

// Rotation error second order and position third order in the distance to the keyframe.
TEST(DiscreteInterpolation, KinematicErrorOrdersNearAKeyframe) {
  const auto traj = sim::MakeTrajectory(sim::Scenario::kFull, sim::Scene{});
  Errors prev;
  for (double s : {0.02, 0.01, 0.005}) {
    const Errors e = KinematicError(*traj, s);
    std::printf("A.1 at %.3f s from the keyframe: rotation %.2e rad, position %.2e m\n", s, e.rot,
                e.pos);
    if (prev.rot > 0) {
      EXPECT_NEAR(prev.rot / e.rot, 4.0, 1.0);
      EXPECT_NEAR(prev.pos / e.pos, 8.0, 2.0);
    }
    prev = e;
  }
}

Errors MidpointError(const sim::Trajectory& traj, double s) {
  Errors e;
  for (int n = 0; n < 30; ++n) {
    const double t_k = 2.0 + 0.173 * n;
    const sim::KinematicState a = traj.Evaluate(t_k), mid = traj.Evaluate(t_k + 0.5 * s),
                              x = traj.Evaluate(t_k + s);
    const Eigen::Vector3d a_mid = mid.q_W_B.conjugate() * (mid.a_W - kGravityW);
    Eigen::Vector3d v;
    const auto pose = PropagateMidpoint<double>(a.q_W_B, a.p_W_B, a.v_W, mid.w_B, a_mid, kGravityW,
                                                t_k, t_k + s, &v);
    e.rot = std::max(e.rot, RotationError<double>(pose.q_W_B, x.q_W_B).norm());
    e.pos = std::max(e.pos, (pose.p_W_B - x.p_W_B).norm());
  }
  return e;
}

// The midpoint A.1 (the discrete problem's): rotation error third order in the distance to the
// keyframe, and far below the constant-reading A.1 at the time-offset shifts of table4 guesses.
TEST(DiscreteInterpolation, MidpointKinematicErrorIsThirdOrder) {
  const auto traj = sim::MakeTrajectory(sim::Scenario::kFull, sim::Scene{});
  Errors prev;
  for (double s : {0.02, 0.01, 0.005}) {
    const Errors e = MidpointError(*traj, s);
    const Errors constant = KinematicError(*traj, s);
    std::printf(
        "A.1 midpoint at %.3f s: rotation %.2e rad (constant reading %.2e), position %.2e m\n", s,
        e.rot, constant.rot, e.pos);
    EXPECT_LT(e.rot, 0.1 * constant.rot);
    EXPECT_LT(e.pos, constant.pos);
    if (prev.rot > 0) {
      EXPECT_NEAR(prev.rot / e.rot, 8.0, 2.5);
      EXPECT_NEAR(prev.pos / e.pos, 8.0, 2.5);
    }
    prev = e;
  }
}

// The Jet derivative with respect to the query time (time offsets) matches central differences.
TEST(DiscreteInterpolation, TimeDerivativeMatchesNumeric) {
  using J = ceres::Jet<double, 1>;
  const auto traj = sim::MakeTrajectory(sim::Scenario::kFull, sim::Scene{});
  const sim::KinematicState a = traj->Evaluate(3.0), b = traj->Evaluate(3.1);
  const double t = 3.037, eps = 1e-6;
  const auto pose = InterpolateGeodesic<J>(a.q_W_B.cast<J>(), a.p_W_B.cast<J>(), b.q_W_B.cast<J>(),
                                           b.p_W_B.cast<J>(), 3.0, 3.1, J(t, 0));
  const auto f = [&](double tt) {
    return InterpolateGeodesic<double>(a.q_W_B, a.p_W_B, b.q_W_B, b.p_W_B, 3.0, 3.1, tt);
  };
  const auto p = f(t + eps), m = f(t - eps);
  Eigen::Vector4d dq_num = (p.q_W_B.coeffs() - m.q_W_B.coeffs()) / (2 * eps);
  Eigen::Vector3d dp_num = (p.p_W_B - m.p_W_B) / (2 * eps);
  for (int i = 0; i < 4; ++i)
    EXPECT_NEAR(pose.q_W_B.coeffs()[i].v[0], dq_num[i], 1e-6);
  for (int i = 0; i < 3; ++i)
    EXPECT_NEAR(pose.p_W_B[i].v[0], dp_num[i], 1e-6);
  // The geodesic's angular velocity is the mean one, Log(R_k^T R_k1) / dt, close to the truth's.
  const Eigen::Vector3d w_mean =
      LogSO3<double>(Eigen::Quaterniond(a.q_W_B.conjugate() * b.q_W_B)) / 0.1;
  EXPECT_LT((w_mean - traj->Evaluate(3.05).w_B).norm(),
            0.05 * traj->Evaluate(3.05).w_B.norm() + 1e-3);
}

}  // namespace
}  // namespace ctcal::discrete
