#include "ctcal/sim/scenario.h"

#include <algorithm>
#include <stdexcept>

namespace ctcal::sim {
namespace {

const std::vector<std::pair<Scenario, std::string>>& Table() {
  static const std::vector<std::pair<Scenario, std::string>> table = {
      {Scenario::kFull, "full"},
      {Scenario::kYaw, "yaw"},
      {Scenario::kPlanar, "planar"},
      {Scenario::kNoRotation, "no-rotation"},
      {Scenario::kConstAccelX, "const-accel-x"},
      {Scenario::kStatic, "static"},
  };
  return table;
}

SmoothSignal Constant(double value) {
  return SmoothSignal{value, {}};
}

SmoothSignal Signal(double offset, std::vector<Sinusoid> terms, double scale = 1.0) {
  for (Sinusoid& s : terms)
    s.amplitude *= scale;
  return SmoothSignal{offset, std::move(terms)};
}

// The yaw motion shared by `yaw` and `planar`: one slow large swing and a faster small one.
SmoothSignal YawSwing() {
  return Signal(0.3, {{0.9, 0.3, 0.2}, {0.25, 0.85, 1.4}});
}

// A 3-D translation about the scene point; `vertical` false keeps the height constant.
void Translation(const Scene& scene, double k, bool vertical, SinusoidTrajectory* traj) {
  traj->position[0] = Signal(scene.board_centre_W.x(), {{0.10, 0.21, 0.5}, {0.03, 0.8, 1.0}}, k);
  traj->position[1] = Signal(scene.board_centre_W.y(), {{0.08, 0.27, 2.0}, {0.03, 0.95, 0.3}}, k);
  traj->position[2] = vertical ? Signal(scene.height, {{0.10, 0.17, 1.2}, {0.03, 0.7, 0.4}}, k)
                               : Constant(scene.height);
}

}  // namespace

const std::vector<std::string>& ScenarioNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const auto& [s, name] : Table())
      n.push_back(name);
    return n;
  }();
  return names;
}

Scenario ParseScenario(const std::string& name) {
  for (const auto& [s, n] : Table()) {
    if (n == name)
      return s;
  }
  std::string all;
  for (const std::string& n : ScenarioNames())
    all += (all.empty() ? "" : ", ") + n;
  throw std::invalid_argument("unknown scenario '" + name + "' (one of: " + all + ")");
}

std::string ToString(Scenario s) {
  for (const auto& [sc, n] : Table()) {
    if (sc == s)
      return n;
  }
  return "?";
}

Scene SceneFor(const TargetConfig& target) {
  double size_x = 0.0, size_y = 0.0;
  if (target.type == TargetType::kAprilGrid) {
    size_x = target.tag_size * (target.tag_cols + (target.tag_cols - 1) * target.tag_spacing);
    size_y = target.tag_size * (target.tag_rows + (target.tag_rows - 1) * target.tag_spacing);
  } else if (target.type == TargetType::kCharuco) {
    // The inner corners span squareLength .. (squares - 1) squareLength: centred on the print.
    size_x = target.squares_x * target.square_length_m;
    size_y = target.squares_y * target.square_length_m;
  } else {
    // SPEC section 5: x grows with the row index.
    size_x = (target.target_rows - 1) * target.row_spacing_m;
    size_y = (target.target_cols - 1) * target.col_spacing_m;
  }
  Scene scene;
  scene.board_centre_W = Eigen::Vector3d(0.5 * size_x, 0.5 * size_y, 0.0);
  scene.board_extent = std::max(size_x, size_y);
  // 0.75 m for the 0.66 m default board; never closer than 0.3 m.
  scene.height = std::max(0.3, 0.75 * scene.board_extent / 0.66);
  return scene;
}

std::unique_ptr<Trajectory> MakeTrajectory(Scenario scenario, const Scene& scene) {
  // Translation amplitudes scale with the working distance.
  const double k = scene.height / 0.75;
  const Eigen::Vector3d& c = scene.board_centre_W;
  switch (scenario) {
    case Scenario::kFull: {
      auto traj = std::make_unique<SinusoidTrajectory>();
      traj->roll = Signal(0.0, {{0.25, 0.7, 0.3}, {0.06, 1.6, 2.1}});
      traj->pitch = Signal(0.0, {{0.25, 0.55, 1.9}, {0.06, 1.9, 0.5}});
      traj->yaw = Signal(0.0, {{0.45, 0.35, 0.7}, {0.10, 1.1, 2.0}});
      traj->position[0] = Signal(c.x(), {{0.10, 0.23, 0.4}, {0.03, 0.9, 2.2}}, k);
      traj->position[1] = Signal(c.y(), {{0.08, 0.29, 1.3}, {0.03, 1.2, 0.1}}, k);
      traj->position[2] = Signal(scene.height, {{0.12, 0.19, 0.9}, {0.04, 1.0, 2.7}}, k);
      // A hand-held user keeps the board in view by moving against the tilt. For small angles
      // the downward optical axis hits the board at (p_x - h pitch, p_y + h roll), so each
      // tilt sinusoid gets a translation twin that cancels 85 % of that shift.
      const double kc = 0.85 * scene.height;
      for (const Sinusoid& s : traj->pitch.terms)
        traj->position[0].terms.push_back({kc * s.amplitude, s.frequency_hz, s.phase});
      for (const Sinusoid& s : traj->roll.terms)
        traj->position[1].terms.push_back({-kc * s.amplitude, s.frequency_hz, s.phase});
      // Users of wide-angle cameras sweep the board out to the edge of the field of view on
      // purpose: the higher distortion terms (theta^5..theta^9 of a fisheye) only differ from
      // the lower ones there. A slow tilt that nobody compensates carries the board centre up
      // to ~0.6 rad off the optical axis, so its corners reach 1.1-1.3 rad (cam1 of the default
      // rig: 90 % of the corners within 0.9 rad, where they were within 0.56 rad).
      traj->roll.terms.push_back({0.5, 0.13, 0.9});
      traj->pitch.terms.push_back({0.5, 0.17, 2.4});
      return traj;
    }
    case Scenario::kYaw: {
      auto traj = std::make_unique<SinusoidTrajectory>();
      traj->yaw = YawSwing();
      Translation(scene, k, /*vertical=*/true, traj.get());
      return traj;
    }
    case Scenario::kPlanar: {
      auto traj = std::make_unique<SinusoidTrajectory>();
      traj->yaw = YawSwing();
      Translation(scene, k, /*vertical=*/false, traj.get());
      return traj;
    }
    case Scenario::kNoRotation: {
      auto traj = std::make_unique<SinusoidTrajectory>();
      // Tilted so that gravity loads all three accelerometer axes.
      traj->yaw = Constant(0.3);
      traj->pitch = Constant(0.12);
      traj->roll = Constant(-0.1);
      Translation(scene, k, /*vertical=*/true, traj.get());
      return traj;
    }
    case Scenario::kConstAccelX: {
      // A 4 s figure eight at 0.25 m/s (x 0.07 m, y 0.17 m about the centre for the default
      // board), heading swinging +-138 deg, centripetal a_y up to 0.9 m/s^2.
      return std::make_unique<ConstantSpeedLoop>(
          Eigen::Vector2d(c.x(), c.y()), 0.3, 0.25 * k, 4.0,
          Signal(scene.height, {{0.08, 0.31, 0.6}}, k),
          Signal(0.0, {{0.15, 0.43, 0.2}, {0.05, 1.3, 1.0}}));
    }
    case Scenario::kStatic: {
      auto traj = std::make_unique<SinusoidTrajectory>();
      traj->yaw = Constant(0.3);
      traj->pitch = Constant(0.08);
      traj->roll = Constant(-0.05);
      traj->position[0] = Constant(c.x() + 0.02 * k);
      traj->position[1] = Constant(c.y() - 0.03 * k);
      traj->position[2] = Constant(scene.height);
      return traj;
    }
  }
  throw std::logic_error("MakeTrajectory: unhandled scenario");
}

}  // namespace ctcal::sim
