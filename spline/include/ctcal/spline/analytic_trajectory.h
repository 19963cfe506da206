// A smooth closed-form body trajectory with exact derivatives, the reference of the spline fit
// tests, the spline demo and the benchmarks. Not a spline: it checks splines.
//   R_W_B(t) = Exp(a(t) e_z) Exp(b(t) e_x),  a = A sin(wa t),  b = B sin(wb t + 0.3),
//   w_B = Rx(b)^T a' e_z + b' e_x,
//   alpha_B = Rx(b)^T a'' e_z - b' e_x x (Rx(b)^T a' e_z) + b'' e_x
//     (d/dt Rx(b)^T = -b' [e_x]x Rx(b)^T),
//   p_W_B(t) = (r cos(wp t), r sin(wp t), h sin(wh t)) + v0 t.
#pragma once

#include <Eigen/Geometry>
#include <cmath>

#include "ctcal/spline/se3_spline.h"

namespace ctcal {

struct AnalyticTrajectory {
  double A = 0.9, wa = 1.3;  // yaw amplitude (rad) and rate (rad/s)
  double B = 0.5, wb = 2.1;  // roll amplitude and rate
  double r = 0.8, wp = 1.1;  // horizontal circle radius (m) and rate
  double h = 0.3, wh = 2.5;  // vertical oscillation amplitude and rate
  Eigen::Vector3d v0{0.1, -0.05, 0.0};

  // Pose and derivatives up to acceleration at t seconds (dalpha_B and jerk_W left zero).
  Se3Kinematics<double> At(double t) const {
    using std::cos;
    using std::sin;
    const double a = A * sin(wa * t), da = A * wa * cos(wa * t), dda = -A * wa * wa * sin(wa * t);
    const double ph = wb * t + 0.3;
    const double b = B * sin(ph), db = B * wb * cos(ph), ddb = -B * wb * wb * sin(ph);
    const Eigen::Matrix3d Rz = Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Matrix3d Rx = Eigen::AngleAxisd(b, Eigen::Vector3d::UnitX()).toRotationMatrix();
    const Eigen::Vector3d ex = Eigen::Vector3d::UnitX();
    const Eigen::Vector3d yaw_rate_B = Rx.transpose() * (da * Eigen::Vector3d::UnitZ());
    Se3Kinematics<double> k;
    k.R_W_B = Rz * Rx;
    k.w_B = yaw_rate_B + db * ex;
    k.alpha_B =
        Rx.transpose() * (dda * Eigen::Vector3d::UnitZ()) - db * ex.cross(yaw_rate_B) + ddb * ex;
    const double c = cos(wp * t), s = sin(wp * t);
    k.p_W_B = Eigen::Vector3d(r * c, r * s, h * sin(wh * t)) + v0 * t;
    k.v_W = Eigen::Vector3d(-r * wp * s, r * wp * c, h * wh * cos(wh * t)) + v0;
    k.a_W = Eigen::Vector3d(-r * wp * wp * c, -r * wp * wp * s, -h * wh * wh * sin(wh * t));
    return k;
  }
};

}  // namespace ctcal
