// What ideal sensors rigidly mounted on the base frame B perceive of a KinematicState.
#pragma once

#include <Eigen/Core>

#include "ctcal/sim/trajectory.h"

namespace ctcal::sim {

// Angular velocity and specific force in the frame S of an ideal inertial sensor at T_B_S.
// The point S moves on p_W_S = p_W_B + R_W_B t_B_S; differentiating twice with dR_W_B/dt =
// R_W_B [w_B]x,
//   acc_W_S = a_W + R_W_B (alpha_B x t_B_S + w_B x (w_B x t_B_S)),
// so its specific force (SPEC section 1) in S is
//   a_S = R_B_S^T (R_W_B^T (a_W - g_W) + alpha_B x t_B_S + w_B x (w_B x t_B_S)),
// and every point of a rigid body has the same angular velocity: w_S = R_B_S^T w_B.
struct InertialTruth {
  Eigen::Vector3d w_S = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_S = Eigen::Vector3d::Zero();
};

inline InertialTruth IdealInertial(const KinematicState& x, const Eigen::Vector3d& g_W,
                                   const Eigen::Matrix3d& R_B_S, const Eigen::Vector3d& t_B_S) {
  const Eigen::Vector3d f_B = x.q_W_B.conjugate() * (x.a_W - g_W);
  const Eigen::Vector3d lever =
      x.alpha_B.cross(t_B_S) + x.w_B.cross(Eigen::Vector3d(x.w_B.cross(t_B_S)));
  InertialTruth out;
  out.w_S = R_B_S.transpose() * x.w_B;
  out.a_S = R_B_S.transpose() * (f_B + lever);
  return out;
}

// T_W_S of a sensor at T_B_S, as a rotation and a translation.
struct Pose {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
};

inline Pose SensorPoseInWorld(const KinematicState& x, const Eigen::Matrix3d& R_B_S,
                              const Eigen::Vector3d& t_B_S) {
  const Eigen::Matrix3d R_W_B = x.q_W_B.toRotationMatrix();
  return Pose{R_W_B * R_B_S, x.p_W_B + R_W_B * t_B_S};
}

}  // namespace ctcal::sim
