// Ground-truth motion of the base IMU frame B in the world (board) frame W: analytic functions of
// the base-clock time with exact first and second derivatives. Deliberately NOT a B-spline: the
// calibrator fits splines, and data generated from the same family would hide its approximation
// error. Every quantity (pose, velocity, acceleration, angular velocity and acceleration) comes
// from closed forms; nothing is differentiated numerically.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <vector>

namespace ctcal::sim {

// The motion state of B at one instant of the base clock.
struct KinematicState {
  Eigen::Quaterniond q_W_B = Eigen::Quaterniond::Identity();
  Eigen::Vector3d p_W_B = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();  // d/dt p_W_B
  Eigen::Vector3d a_W = Eigen::Vector3d::Zero();  // d2/dt2 p_W_B
  Eigen::Vector3d w_B = Eigen::Vector3d::Zero();  // angular velocity in B: dR_W_B/dt = R_W_B [w_B]x
  Eigen::Vector3d alpha_B = Eigen::Vector3d::Zero();  // d/dt w_B
};

class Trajectory {
 public:
  virtual ~Trajectory() = default;
  virtual KinematicState Evaluate(double t) const = 0;
};

// value + sum_k amplitude_k * sin(2 pi frequency_k t + phase_k), with its two derivatives.
struct Sinusoid {
  double amplitude = 0.0;
  double frequency_hz = 0.0;
  double phase = 0.0;  // rad
};

struct SmoothSignal {
  double offset = 0.0;
  std::vector<Sinusoid> terms;

  // d[0] = value, d[1] = first derivative, d[2] = second derivative at t.
  void Evaluate(double t, double d[3]) const;
};

// Yaw-pitch-roll angles (intrinsic z-y'-x'') with their exact body rates:
//   R(psi, theta, phi) = Rz(psi) * Ry(theta) * Rx(phi),
// and, from dR/dt = R [w]x,
//   w = [ phi' - psi' sin(theta),
//         theta' cos(phi) + psi' cos(theta) sin(phi),
//        -theta' sin(phi) + psi' cos(theta) cos(phi) ],
// alpha = dw/dt by the product rule (EulerZyxRates). Pitch must stay away from +-90 degrees,
// which every scenario does by a wide margin.
struct EulerZyxRates {
  Eigen::Matrix3d R;
  Eigen::Vector3d w;
  Eigen::Vector3d alpha;
};
// yaw, pitch, roll: value, rate, acceleration (d[0..2] of SmoothSignal::Evaluate).
EulerZyxRates EvaluateEulerZyx(const double yaw[3], const double pitch[3], const double roll[3]);

// Position and yaw-pitch-roll each a SmoothSignal; R_W_B = R_W_0 * R(yaw, pitch, roll) with a
// constant R_W_0 (which leaves w_B and alpha_B unchanged).
class SinusoidTrajectory : public Trajectory {
 public:
  SmoothSignal position[3];
  SmoothSignal yaw, pitch, roll;
  Eigen::Matrix3d R_W_0 = Eigen::Matrix3d::Identity();

  KinematicState Evaluate(double t) const override;
};

// A horizontal closed loop flown at constant horizontal speed with B's x axis kept tangent to it
// and level (pitch 0); roll about that x axis and the height are free SmoothSignals. W's z axis
// must be vertical (gravity along -z). Then B's x axis is the unit horizontal velocity direction
// and its specific force is
//   f_x = x_B . (a_W - g_W) = x_B . a_horizontal = d|v_h|/dt = 0,
// constant (the "constant a_x" degenerate motion of the intrinsic-calibration paper).
// The heading psi(t) = psi0 + A sin(w t) gives v_h = s (cos psi, sin psi), whose integral by the
// Jacobi-Anger expansions
//   cos(A sin u) = J0(A) + 2 sum_{k>=1} J_2k(A) cos(2k u)
//   sin(A sin u) =         2 sum_{k>=0} J_2k+1(A) sin((2k+1) u)
// is a closed form; with A = j_0,1 (the first zero of J0) the drift J0(A) s t vanishes and the
// path closes into a figure eight (x ~ sin 2wt, y ~ 1 - cos wt in the heading frame).
class ConstantSpeedLoop : public Trajectory {
 public:
  // centre: centre of the loop's horizontal extent; speed s (m/s); period 2 pi / w (s).
  ConstantSpeedLoop(const Eigen::Vector2d& centre, double heading0, double speed, double period,
                    SmoothSignal height, SmoothSignal roll);

  KinematicState Evaluate(double t) const override;

  static constexpr double kFirstZeroOfJ0 = 2.404825557695772768621631879;

 private:
  Eigen::Vector2d centre_;
  double heading0_;
  double speed_;
  double omega_;
  SmoothSignal height_;
  SmoothSignal roll_;
  std::vector<double> bessel_;  // J_n(A), n = 0..N
  double mean_s_ = 0.0;         // time mean of the sin-integral, removed to centre the loop
};

// J_n(x) from its power series, to double precision for |x| <= 4 (std::cyl_bessel_j is missing
// from some standard libraries).
double BesselJ(int n, double x);

}  // namespace ctcal::sim
