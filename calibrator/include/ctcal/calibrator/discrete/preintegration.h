// Base IMU preintegration between two keyframe times for the discrete MVIS formulation
// (MVIS report eq. 32-37; Forster et al. 2017, "On-Manifold Preintegration", in their notation).
//
// Between keyframes i and j the corrected readings w(t), a(t) (ImuTrueFromRaw with the current
// intrinsics and biases, SPEC section 3) are integrated with the orientation of i as reference:
//   dR_ij = prod Exp(w h),   dv_ij = sum dR a h,   dp_ij = sum (dv h + 1/2 dR a h^2),
// so that, with the states (R, p, v) of B in W and the gravity g_W (SPEC: a = R^T (acc - g)),
//   R_i^T R_j = dR_ij,  R_i^T (v_j - v_i - g dt) = dv_ij,  R_i^T (p_j - p_i - v_i dt - g dt^2/2) =
//   dp_ij.
//
// Integration scheme (< 1e-6 rad over 0.1 s on the simulator's "full" motion, was 2.6e-5 with the
// midpoint rule). Two error sources: the reading between samples and the ODE step.
//  - Readings between samples: a cubic through the four raw samples around the sub-interval
//    (Lagrange on the actual stamps; fewer at the data's ends). Its quadrature error is
//    O(h^4) d4w/dt4 instead of the trapezoid's h^2/12 d2w/dt2, which alone was the 2.6e-5 rad.
//    The correction is affine in the raw reading, so interpolating raw readings equals
//    interpolating corrected ones.
//  - Step: classical RK4 on y = (q, v, p) with q' = q (x) (0, w) / 2, v' = R(q) a, p' = v, using
//    the readings at the start, middle and end of each sub-interval (local error O(h^5)).
// The clipped readings therefore hold 2n + 1 nodes for n sub-intervals: boundary, middle,
// boundary, ..., boundary (keyframes generally fall between samples; the boundary readings there
// are interpolated the same way).
//
// Noise: the raw readings carry white noise of density sigma_c (InertialNoise). The quadrature
// sums the samples with weights that add up to the interval's length (h/2, h, ..., h, h/2 for the
// trapezoid; the cubic moves ~h/24 between neighbours), so each sub-interval's mean reading is
// modelled as carrying noise of covariance sigma_c^2 / h (Forster's Cov(eta_d) = Cov(eta) / dt),
// mapped to the corrected reading through ImuTrueFromRaw's Jacobian. Right-perturbation error state
// (dphi, dv, dp): dR_true = dR Exp(dphi), dv_true = dv + dv_err, dp_true = dp + dp_err.
//
// Two ways to use it (eq. 36 vs 37):
//  - Intrinsics fixed: Preintegrate() once at a bias linearisation point b_bar; the residual
//    corrects the deltas to first order in db = b - b_bar with the bias Jacobians (eq. 36).
//  - Intrinsics estimated: IntegrateDeltas<T>() is templated on the scalar and recomputes the
//    deltas from the raw samples for the current intrinsics and biases; a residual calls it at
//    every evaluation with ceres::Jet (the report found that freezing the intrinsics'
//    linearisation point converges to a bad local minimum). Its covariance is the one of the
//    last Preintegrate() (it depends on the intrinsics only through the near-identity D, T_g).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <stdexcept>
#include <string>
#include <vector>

#include "ctcal/sensors/imu_intrinsics.h"
#include "ctcal/sensors/inertial_noise.h"
#include "ctcal/spline/so3.h"

namespace ctcal::discrete {

// One raw reading of the base IMU; t in seconds on the base clock.
struct RawImuSample {
  double t = 0.0;
  Eigen::Vector3d w_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_m = Eigen::Vector3d::Zero();
};

// The preintegrated deltas of one interval, any scalar.
template <typename T>
struct PreintegratedDeltas {
  QuatT<T> dR = QuatT<T>::Identity();
  Vec3T<T> dv = Vec3T<T>::Zero();
  Vec3T<T> dp = Vec3T<T>::Zero();
};

namespace detail {

// The raw reading at t from the cubic through samples k-1 .. k+2 (t in [t_k, t_k+1]; fewer points
// where the samples end). Lagrange form on the actual stamps (tolerates jitter).
RawImuSample InterpolateRaw(const std::vector<RawImuSample>& samples, std::size_t k, double t);

// The raw readings at the nodes of the integration: t_i, the middle of every sub-interval, the
// samples strictly inside, t_j (2n + 1 nodes for n sub-intervals). Throws std::invalid_argument
// naming the times when t_i >= t_j, the samples do not cover [t_i, t_j] or are not in increasing
// time order.
std::vector<RawImuSample> ClippedReadings(const std::vector<RawImuSample>& samples, double t_i,
                                          double t_j);

// The time derivative of y = (q, v, p) at corrected readings (w, a): q' = q (x) (0, w) / 2 (as
// coefficients x, y, z, w), v' = R(q) a, p' = v.
template <typename T>
struct Rk4Derivative {
  Eigen::Matrix<T, 4, 1> dq;
  Vec3T<T> dv, dp;
};

template <typename T>
Rk4Derivative<T> DeltaRate(const Eigen::Matrix<T, 4, 1>& q, const Vec3T<T>& v, const Vec3T<T>& w,
                           const Vec3T<T>& a) {
  const QuatT<T> qq(q(3), q(0), q(1), q(2));
  const QuatT<T> pure(T(0), w.x(), w.y(), w.z());
  Rk4Derivative<T> d;
  d.dq = T(0.5) * (qq * pure).coeffs();
  d.dv = qq.normalized() * a;
  d.dp = v;
  return d;
}

// One RK4 step of length h from the corrected readings at the start (0), middle (m), end (1).
template <typename T>
void Rk4Step(const Vec3T<T>& w0, const Vec3T<T>& a0, const Vec3T<T>& wm, const Vec3T<T>& am,
             const Vec3T<T>& w1, const Vec3T<T>& a1, double h, PreintegratedDeltas<T>* d) {
  const Eigen::Matrix<T, 4, 1> q0 = d->dR.coeffs();
  const Vec3T<T> v0 = d->dv, p0 = d->dp;
  const T hh(h), half(0.5 * h);
  const Rk4Derivative<T> k1 = DeltaRate<T>(q0, v0, w0, a0);
  const Rk4Derivative<T> k2 =
      DeltaRate<T>(Eigen::Matrix<T, 4, 1>(q0 + half * k1.dq), Vec3T<T>(v0 + half * k1.dv), wm, am);
  const Rk4Derivative<T> k3 =
      DeltaRate<T>(Eigen::Matrix<T, 4, 1>(q0 + half * k2.dq), Vec3T<T>(v0 + half * k2.dv), wm, am);
  const Rk4Derivative<T> k4 =
      DeltaRate<T>(Eigen::Matrix<T, 4, 1>(q0 + hh * k3.dq), Vec3T<T>(v0 + hh * k3.dv), w1, a1);
  const T sixth(h / 6.0);
  const Eigen::Matrix<T, 4, 1> q1 = q0 + sixth * (k1.dq + T(2) * (k2.dq + k3.dq) + k4.dq);
  d->dv = v0 + sixth * (k1.dv + T(2) * (k2.dv + k3.dv) + k4.dv);
  d->dp = p0 + sixth * (k1.dp + T(2) * (k2.dp + k3.dp) + k4.dp);
  d->dR = QuatT<T>(q1(3), q1(0), q1(1), q1(2)).normalized();
}

}  // namespace detail

// The deltas from t_i to t_j, re-integrated from the raw samples with the given intrinsics and
// biases (eq. 37). Any scalar: with ceres::Jet the derivatives with respect to intrinsics and
// biases come out exactly (of the discretised integral). `readings` are from ClippedReadings
// (computed once per interval: they do not depend on any estimated quantity).
template <typename T>
PreintegratedDeltas<T> IntegrateDeltas(const std::vector<RawImuSample>& readings,
                                       const ImuModelLayout& layout, const ImuBlocks<T>& blocks,
                                       const Vec3T<T>& b_g, const Vec3T<T>& b_a) {
  PreintegratedDeltas<T> d;
  if (readings.size() < 3)
    return d;
  std::vector<Vec3T<T>> w(readings.size()), a(readings.size());
  for (std::size_t k = 0; k < readings.size(); ++k)
    ImuTrueFromRaw<T>(layout, blocks, readings[k].w_m.cast<T>(), readings[k].a_m.cast<T>(), b_g,
                      b_a, &w[k], &a[k]);
  for (std::size_t k = 0; k + 2 < readings.size(); k += 2)
    detail::Rk4Step<T>(w[k], a[k], w[k + 1], a[k + 1], w[k + 2], a[k + 2],
                       readings[k + 2].t - readings[k].t, &d);
  return d;
}

// A preintegrated interval with its covariance and bias Jacobians at a linearisation point.
// Error-state order everywhere: [dphi (0-2), dv (3-5), dp (6-8)]; bias order [b_g, b_a].
class Preintegration {
 public:
  // Integrates the samples over [t_i, t_j] (t_i < t_j, both covered by the samples) with the
  // intrinsics and the bias linearisation point b_g, b_a. Throws std::invalid_argument naming the
  // times for an empty or uncovered interval, and the noise key for an invalid noise.
  Preintegration(const std::vector<RawImuSample>& samples, double t_i, double t_j,
                 const ImuIntrinsics& intrinsics, const InertialNoise& noise,
                 const Eigen::Vector3d& b_g, const Eigen::Vector3d& b_a);

  // Recomputes deltas, covariance and bias Jacobians for new intrinsics / linearisation point
  // (re-linearisation when the biases moved far from b_bar, or after an intrinsics update).
  void Reintegrate(const ImuIntrinsics& intrinsics, const Eigen::Vector3d& b_g,
                   const Eigen::Vector3d& b_a);

  double t_i() const { return t_i_; }
  double t_j() const { return t_j_; }
  double dt() const { return t_j_ - t_i_; }
  const PreintegratedDeltas<double>& deltas() const { return deltas_; }
  const Eigen::Matrix<double, 9, 9>& covariance() const { return covariance_; }
  // Lower-triangular S = L^-1 with covariance = L L^T (so S^T S = covariance^-1): the whitened
  // residual S r has identity covariance.
  const Eigen::Matrix<double, 9, 9>& sqrt_information() const { return sqrt_information_; }
  // d(delta)/d[b_g; b_a] at the linearisation point; the rotation rows are the right-perturbation
  // tangent: dR(b_bar + db) ~ dR(b_bar) Exp(J.topRows<3>() db).
  const Eigen::Matrix<double, 9, 6>& J_delta_bias() const { return J_delta_bias_; }
  const Eigen::Vector3d& b_g_bar() const { return b_g_bar_; }
  const Eigen::Vector3d& b_a_bar() const { return b_a_bar_; }
  const std::vector<RawImuSample>& readings() const { return readings_; }

  // The deltas corrected to first order for biases b (eq. 36).
  template <typename T>
  PreintegratedDeltas<T> Corrected(const Vec3T<T>& b_g, const Vec3T<T>& b_a) const;

 private:
  std::vector<RawImuSample> readings_;
  double t_i_ = 0.0, t_j_ = 0.0;
  InertialNoise noise_;
  Eigen::Vector3d b_g_bar_ = Eigen::Vector3d::Zero(), b_a_bar_ = Eigen::Vector3d::Zero();
  PreintegratedDeltas<double> deltas_;
  Eigen::Matrix<double, 9, 9> covariance_ = Eigen::Matrix<double, 9, 9>::Zero();
  Eigen::Matrix<double, 9, 9> sqrt_information_ = Eigen::Matrix<double, 9, 9>::Identity();
  Eigen::Matrix<double, 9, 6> J_delta_bias_ = Eigen::Matrix<double, 9, 6>::Zero();
};

template <typename T>
PreintegratedDeltas<T> Preintegration::Corrected(const Vec3T<T>& b_g, const Vec3T<T>& b_a) const {
  Eigen::Matrix<T, 6, 1> db;
  db << b_g - b_g_bar_.cast<T>(), b_a - b_a_bar_.cast<T>();
  const Eigen::Matrix<T, 9, 1> c = J_delta_bias_.cast<T>() * db;
  PreintegratedDeltas<T> out;
  out.dR = deltas_.dR.cast<T>() * ExpSO3<T>(Vec3T<T>(c.template head<3>()));
  out.dv = deltas_.dv.cast<T>() + c.template segment<3>(3);
  out.dp = deltas_.dp.cast<T>() + c.template tail<3>();
  return out;
}

}  // namespace ctcal::discrete
