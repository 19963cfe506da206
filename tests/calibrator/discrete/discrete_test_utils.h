// Shared set-up of the discrete problem's residual tests (test_discrete_residuals.cpp,
// test_discrete_frame_corners.cpp): random draws, two keyframes with random states and a base IMU
// whose scale, misalignment and rotation are away from identity.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <random>

#include "ctcal/calibrator/discrete/discrete_residuals.h"
#include "ctcal/sensors/imu_intrinsics.h"
#include "ctcal/spline/so3.h"

namespace ctcal::discrete::test {

// Uniform in [-s, s]^3.
inline Eigen::Vector3d Rand3(std::mt19937* rng, double s) {
  std::uniform_real_distribution<double> u(-s, s);
  return Eigen::Vector3d(u(*rng), u(*rng), u(*rng));
}

inline void SetQuat(std::array<double, 4>* q, const Eigen::Quaterniond& r) {
  *q = {r.x(), r.y(), r.z(), r.w()};
}

inline void Set3(std::array<double, 3>* a, const Eigen::Vector3d& v) {
  *a = {v.x(), v.y(), v.z()};
}

// k0 at t = 1 s and k1 at 1 s + dt, each with a rotation of up to `angle` rad per axis, a
// position within `position` of `centre`, and a velocity, biases and a raw base reading of a
// hand-held rig (|v| ~0.5 m/s, |w| ~1 rad/s, gravity along +z of the reading).
inline void RandomKeyframes(std::mt19937* rng, double angle, double position,
                            const Eigen::Vector3d& centre, double dt, Keyframe* k0, Keyframe* k1) {
  for (Keyframe* k : {k0, k1}) {
    SetQuat(&k->q_W_B, ExpSO3<double>(Rand3(rng, angle)));
    Set3(&k->p_W_B, Rand3(rng, position) + centre);
    Set3(&k->v_W, Rand3(rng, 0.5));
    Set3(&k->b_g, Rand3(rng, 0.01));
    Set3(&k->b_a, Rand3(rng, 0.1));
    k->raw.w_m = Rand3(rng, 1.0);
    k->raw.a_m = Rand3(rng, 3.0) + Eigen::Vector3d(0, 0, 9.8);
  }
  k0->t = 1.0;
  k1->t = 1.0 + dt;
  k0->raw.t = k0->t;
  k1->raw.t = k1->t;
}

// Percent scale errors and milliradian misalignments (D_a = 0.99 D_w) and an IMU rotation of
// ~25 mrad: every block the corner and inertial residuals read from the base is away from its
// identity.
inline void SetBaseScaleAndRotation(ImuIntrinsics* base) {
  Eigen::Matrix3d D;
  D << 1.01, 0.004, -0.003, 0, 0.99, 0.002, 0, 0, 1.005;
  base->SetD_w(D);
  base->SetD_a(D * 0.99);
  base->SetRotation(ExpSO3<double>(Eigen::Vector3d(0.01, -0.02, 0.015)).toRotationMatrix());
}

}  // namespace ctcal::discrete::test
