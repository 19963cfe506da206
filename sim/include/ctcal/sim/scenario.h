// The motions `ctcal simulate --scenario` offers, as analytic trajectories of the base IMU in the
// board frame W.
//
// Scene convention (docs/simulator.md): the board lies flat, printed side up, on a table: W's z
// axis points up (out of the printed face, SPEC section 5: x right, y up on the print, so z
// towards a viewer), and gravity is g_W = (0, 0, -g). The base IMU B is mounted with z up and
// the cameras look down along -z_B, so a rig held level above the board sees it. This choice lets
// the degenerate scenarios keep the board in view: a yaw-only rotation about the vertical spins
// the cameras about their optical axes, and the constant-a_x loop may turn through all headings.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "ctcal/sim/trajectory.h"
#include "ctcal/targets/target_config.h"

namespace ctcal::sim {

enum class Scenario { kFull, kYaw, kPlanar, kNoRotation, kConstAccelX, kStatic };

// "full", "yaw", "planar", "no-rotation", "const-accel-x", "static".
const std::vector<std::string>& ScenarioNames();
// Throws std::invalid_argument naming the word and the valid names.
Scenario ParseScenario(const std::string& name);
std::string ToString(Scenario s);

// Where the motion happens: above the board's printed area, at a working distance that scales
// with its size (0.75 m for the default 0.66 m AprilGrid).
struct Scene {
  Eigen::Vector3d board_centre_W = Eigen::Vector3d::Zero();
  double board_extent = 0.66;  // the larger side of the printed pattern (m)
  double height = 0.75;        // nominal camera height above the board (m)
};
Scene SceneFor(const TargetConfig& target);

// The unit direction of gravity in W (down = -z); g_W = gravity_magnitude * this.
inline Eigen::Vector3d GravityDirectionW() {
  return Eigen::Vector3d(0.0, 0.0, -1.0);
}

// The base trajectory T_W_B(t), defined for every t (the scenarios are sums of sinusoids with
// incommensurate frequencies, so a longer duration never repeats the same poses).
//  full          hand-held-like: roll/pitch +-0.3 rad, yaw +-0.55 rad, translation +-0.15 m
//                with a coupled tilt so the board stays in view, height 0.55-0.95 x scene.
//  yaw           z_B fixed along the vertical, rotation about it only; 3-D translation.
//  planar        yaw-only rotation; translation in the horizontal plane at constant height.
//  no-rotation   constant orientation (slightly tilted); 3-D translation.
//  const-accel-x ConstantSpeedLoop: x_B level and tangent to a figure-eight flown at constant
//                speed, with roll and height changes: x_B's specific force is constant (0).
//  static        constant pose.
std::unique_ptr<Trajectory> MakeTrajectory(Scenario scenario, const Scene& scene);

}  // namespace ctcal::sim
