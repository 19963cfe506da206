#include "ctcal/sim/trajectory.h"

#include <cmath>

namespace ctcal::sim {

void SmoothSignal::Evaluate(double t, double d[3]) const {
  d[0] = offset;
  d[1] = 0.0;
  d[2] = 0.0;
  for (const Sinusoid& s : terms) {
    const double w = 2.0 * M_PI * s.frequency_hz;
    const double arg = w * t + s.phase;
    const double sn = std::sin(arg);
    const double cs = std::cos(arg);
    d[0] += s.amplitude * sn;
    d[1] += s.amplitude * w * cs;
    d[2] -= s.amplitude * w * w * sn;
  }
}

EulerZyxRates EvaluateEulerZyx(const double yaw[3], const double pitch[3], const double roll[3]) {
  const double sp = std::sin(roll[0]), cp = std::cos(roll[0]);
  const double st = std::sin(pitch[0]), ct = std::cos(pitch[0]);
  const double dphi = roll[1], dtheta = pitch[1], dpsi = yaw[1];
  const double ddphi = roll[2], ddtheta = pitch[2], ddpsi = yaw[2];

  EulerZyxRates out;
  out.R = (Eigen::AngleAxisd(yaw[0], Eigen::Vector3d::UnitZ()) *
           Eigen::AngleAxisd(pitch[0], Eigen::Vector3d::UnitY()) *
           Eigen::AngleAxisd(roll[0], Eigen::Vector3d::UnitX()))
              .toRotationMatrix();
  out.w = Eigen::Vector3d(dphi - dpsi * st, dtheta * cp + dpsi * ct * sp,
                          -dtheta * sp + dpsi * ct * cp);
  // Product rule on each component of w, with d(sin phi) = cos phi phi', etc.
  out.alpha = Eigen::Vector3d(ddphi - ddpsi * st - dpsi * ct * dtheta,
                              ddtheta * cp - dtheta * sp * dphi + ddpsi * ct * sp -
                                  dpsi * st * dtheta * sp + dpsi * ct * cp * dphi,
                              -ddtheta * sp - dtheta * cp * dphi + ddpsi * ct * cp -
                                  dpsi * st * dtheta * cp - dpsi * ct * sp * dphi);
  return out;
}

KinematicState SinusoidTrajectory::Evaluate(double t) const {
  KinematicState x;
  for (int i = 0; i < 3; ++i) {
    double d[3];
    position[i].Evaluate(t, d);
    x.p_W_B[i] = d[0];
    x.v_W[i] = d[1];
    x.a_W[i] = d[2];
  }
  double y[3], p[3], r[3];
  yaw.Evaluate(t, y);
  pitch.Evaluate(t, p);
  roll.Evaluate(t, r);
  const EulerZyxRates e = EvaluateEulerZyx(y, p, r);
  x.q_W_B = Eigen::Quaterniond(R_W_0 * e.R).normalized();
  x.w_B = e.w;
  x.alpha_B = e.alpha;
  return x;
}

double BesselJ(int n, double x) {
  // J_n(x) = sum_m (-1)^m / (m! (m+n)!) (x/2)^(2m+n); for |x| <= 4 the terms fall below 1e-17
  // of the largest within 30 terms and never cancel catastrophically.
  const double h = 0.5 * x;
  double term = 1.0;
  for (int k = 1; k <= n; ++k)
    term *= h / k;
  double sum = term;
  for (int m = 1; m < 60; ++m) {
    term *= -h * h / (static_cast<double>(m) * (m + n));
    sum += term;
    if (std::abs(term) < 1e-18 * std::abs(sum) + 1e-300)
      break;
  }
  return sum;
}

ConstantSpeedLoop::ConstantSpeedLoop(const Eigen::Vector2d& centre, double heading0, double speed,
                                     double period, SmoothSignal height, SmoothSignal roll)
    : centre_(centre),
      heading0_(heading0),
      speed_(speed),
      omega_(2.0 * M_PI / period),
      height_(std::move(height)),
      roll_(std::move(roll)) {
  // J_n(j01) < 1e-19 beyond n = 24.
  for (int n = 0; n <= 24; ++n)
    bessel_.push_back(BesselJ(n, kFirstZeroOfJ0));
  for (int n = 1; n < static_cast<int>(bessel_.size()); n += 2)
    mean_s_ += 2.0 * bessel_[n] / (n * omega_);
}

KinematicState ConstantSpeedLoop::Evaluate(double t) const {
  const double A = kFirstZeroOfJ0;
  const double u = omega_ * t;
  // Heading and its derivatives.
  const double psi = heading0_ + A * std::sin(u);
  const double dpsi = A * omega_ * std::cos(u);
  const double ddpsi = -A * omega_ * omega_ * std::sin(u);

  // Integrals of cos(A sin w tau) and sin(A sin w tau) from 0 to t (class comment).
  double c_int = bessel_[0] * t;
  double s_int = -mean_s_;
  for (int n = 1; n < static_cast<int>(bessel_.size()); ++n) {
    if (n % 2 == 0)
      c_int += 2.0 * bessel_[n] * std::sin(n * u) / (n * omega_);
    else
      s_int += 2.0 * bessel_[n] * (1.0 - std::cos(n * u)) / (n * omega_);
  }
  const double c0 = std::cos(heading0_), s0 = std::sin(heading0_);
  // v_h = s R(psi0) (cos(A sin u), sin(A sin u)), so p_h = centre + s R(psi0) (c_int, s_int).
  KinematicState x;
  double z[3];
  height_.Evaluate(t, z);
  x.p_W_B = Eigen::Vector3d(centre_.x() + speed_ * (c0 * c_int - s0 * s_int),
                            centre_.y() + speed_ * (s0 * c_int + c0 * s_int), z[0]);
  x.v_W = Eigen::Vector3d(speed_ * std::cos(psi), speed_ * std::sin(psi), z[1]);
  x.a_W = Eigen::Vector3d(-speed_ * dpsi * std::sin(psi), speed_ * dpsi * std::cos(psi), z[2]);

  const double yaw[3] = {psi, dpsi, ddpsi};
  const double pitch[3] = {0.0, 0.0, 0.0};
  double roll[3];
  roll_.Evaluate(t, roll);
  const EulerZyxRates e = EvaluateEulerZyx(yaw, pitch, roll);
  x.q_W_B = Eigen::Quaterniond(e.R).normalized();
  x.w_B = e.w;
  x.alpha_B = e.alpha;
  return x;
}

}  // namespace ctcal::sim
