// Pose of the base frame B between keyframe states of the discrete MVIS formulation (report
// appendix A), for measurements stamped between keyframes (camera corners, auxiliary sensors at
// t + time_offset). Templated on the scalar: with ceres::Jet the query time t (hence the time
// offsets) and the keyframe states are differentiated exactly.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "ctcal/spline/so3.h"

namespace ctcal::discrete {

template <typename T>
struct InterpolatedPose {
  QuatT<T> q_W_B = QuatT<T>::Identity();
  Vec3T<T> p_W_B = Vec3T<T>::Zero();
};

// A.2, pose-based: the geodesic of SO(3) x R^3 between keyframes k and k+1 at the fraction
// u = (t - t_k) / (t_k1 - t_k):
//   R(t) = R_k Exp(u Log(R_k^T R_k1)),   p(t) = p_k + u (p_k1 - p_k).
// Constant angular velocity in B and constant linear velocity over the interval: the error is
// O(dt^2) in the keyframe spacing (second derivatives of the motion), largest mid-interval.
template <typename T>
InterpolatedPose<T> InterpolateGeodesic(const QuatT<T>& q_W_Bk, const Vec3T<T>& p_k,
                                        const QuatT<T>& q_W_Bk1, const Vec3T<T>& p_k1, double t_k,
                                        double t_k1, const T& t) {
  const T u = (t - T(t_k)) / T(t_k1 - t_k);
  const Vec3T<T> phi = LogSO3<T>(QuatT<T>(q_W_Bk.conjugate() * q_W_Bk1));
  InterpolatedPose<T> out;
  out.q_W_B = q_W_Bk * ExpSO3<T>(Vec3T<T>(phi * u));
  out.p_W_B = p_k + (p_k1 - p_k) * u;
  return out;
}

// A.1, kinematic: propagation from keyframe k by s = t - t_k (either sign) with the corrected
// base IMU angular rate w_B and specific force a_B at t_k held constant:
//   R(t) = R_k Exp(w_B s),   p(t) = p_k + v_k s + (R_k a_B + g_W) s^2 / 2.
// Error O(s^2) in rotation and O(s^3) in position: better than A.2 close to a keyframe, and the
// only one that ties a measurement at a keyframe's time to that keyframe's velocity.
template <typename T>
InterpolatedPose<T> PropagateKinematic(const QuatT<T>& q_W_Bk, const Vec3T<T>& p_k,
                                       const Vec3T<T>& v_k, const Vec3T<T>& w_B,
                                       const Vec3T<T>& a_B, const Vec3T<T>& g_W, double t_k,
                                       const T& t) {
  const T s = t - T(t_k);
  InterpolatedPose<T> out;
  out.q_W_B = q_W_Bk * ExpSO3<T>(Vec3T<T>(w_B * s));
  out.p_W_B = p_k + v_k * s + (q_W_Bk * a_B + g_W) * (T(0.5) * s * s);
  return out;
}

// A.1 with the readings at the midpoint t_k + s/2 (w_mid, a_mid: corrected angular rate and
// specific force there), which the discrete problem uses:
//   R(t) = R_k Exp(w_mid s),   R_mid = R_k Exp(w_mid s / 2),
//   p(t) = p_k + v_k s + (R_mid a_mid + g_W) s^2 / 2,   v(t) = v_k + (R_mid a_mid + g_W) s.
// The midpoint rule makes the rotation error O(s^3) (PropagateKinematic's is O(s^2): 2e-4 rad at
// 5 ms on the "full" motion, the size of a camera's rotation sigma on 30 s, and a shifted time
// offset puts every corner of a camera at the same s from its keyframe, so the error is a bias).
template <typename T>
InterpolatedPose<T> PropagateMidpoint(const QuatT<T>& q_W_Bk, const Vec3T<T>& p_k,
                                      const Vec3T<T>& v_k, const Vec3T<T>& w_mid,
                                      const Vec3T<T>& a_mid, const Vec3T<T>& g_W, double t_k,
                                      const T& t, Vec3T<T>* v_W = nullptr) {
  const T s = t - T(t_k);
  const QuatT<T> q_mid = q_W_Bk * ExpSO3<T>(Vec3T<T>(w_mid * (T(0.5) * s)));
  const Vec3T<T> acc_W = q_mid * a_mid + g_W;
  InterpolatedPose<T> out;
  out.q_W_B = q_W_Bk * ExpSO3<T>(Vec3T<T>(w_mid * s));
  out.p_W_B = p_k + v_k * s + acc_W * (T(0.5) * s * s);
  if (v_W != nullptr)
    *v_W = v_k + acc_W * s;
  return out;
}

}  // namespace ctcal::discrete
