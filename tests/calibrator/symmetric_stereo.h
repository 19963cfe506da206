// A camera-only stereo recording of a checkerboard that looks the same after a half turn (4x6
// inner corners of 30 mm, as 5x7 squares; the case of issue 21: 640x480 radtan cameras 120 mm
// apart), each view's corner order turned by half a turn at random, as a detector that reads only
// the print reports it. Shared by the resolver's tests and the command's.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "ctcal/sensors/camera_model.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig.h"
#include "ctcal/targets/board.h"
#include "ctcal/targets/board_symmetry.h"

namespace ctcal::test {

struct SymmetricStereo {
  RigConfig rig;    // the guess: focal 3 % off, no distortion, cam1 1 deg and 10 mm off
  RigConfig truth;  // the recording's cameras
  std::map<std::string, SensorData> data;
  // Per camera, frame stamp -> whether its ids were turned by the half turn.
  std::map<std::string, std::map<std::int64_t, bool>> turned;
};

inline TargetConfig FourBySixCheckerboard() {
  TargetConfig t;
  t.type = TargetType::kCheckerboard;
  t.target_rows = 4;
  t.target_cols = 6;
  t.row_spacing_m = t.col_spacing_m = 0.03;
  return t;
}

// `turn_probability`: the chance that a view's ids are the half-turned ones.
inline SymmetricStereo MakeSymmetricStereo(unsigned seed, int views, double turn_probability,
                                           double pixel_sigma = 0.1) {
  SymmetricStereo s;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, pixel_sigma);
  const Board board(FourBySixCheckerboard());
  const std::vector<int> half = BoardSymmetries(board).at(0).turned_id;  // 4 x 6: the half turn

  RigConfig& truth = s.truth;
  truth.base_imu = "cam0";
  truth.target = board.config();
  for (int c = 0; c < 2; ++c) {
    SensorConfig cam;
    cam.name = "cam" + std::to_string(c);
    cam.type = SensorType::kCamera;
    cam.camera_model = "pinhole";
    cam.intrinsics = c == 0 ? std::vector<double>{526.0, 525.0, 322.0, 238.0}
                            : std::vector<double>{531.0, 530.0, 316.0, 244.0};
    cam.distortion_model = "radtan";
    cam.distortion_coeffs = c == 0 ? std::vector<double>{-0.36, 0.16, 0.0005, -0.0003}
                                   : std::vector<double>{-0.35, 0.15, -0.0004, 0.0002};
    cam.width = 640;
    cam.height = 480;
    cam.pixel_sigma = pixel_sigma;
    cam.estimate = {EstimateItem::kIntrinsics};
    if (c == 1) {
      cam.estimate.insert(EstimateItem::kExtrinsics);
      Eigen::Isometry3d T_B_C = Eigen::Isometry3d::Identity();  // cam1 in cam0: 120 mm right
      T_B_C.linear() =
          Eigen::AngleAxisd(0.02, Eigen::Vector3d(0.2, 1.0, 0.1).normalized()).matrix();
      T_B_C.translation() = Eigen::Vector3d(0.120, 0.002, -0.001);
      cam.T_B_S = T_B_C.matrix();
    }
    truth.sensors.push_back(cam);
  }
  const Eigen::Isometry3d T_C0_C1(truth.sensors[1].T_B_S);
  std::vector<CameraModel> models;
  for (const SensorConfig& c : truth.sensors)
    models.push_back(CameraModel::Create(c.camera_model, c.intrinsics, c.distortion_model,
                                         c.distortion_coeffs, Eigen::Vector2i(c.width, c.height)));

  // Board poses in front of the pair, spread over the image, tilted up to ~35 deg, any roll: the
  // whole board in both images (a checkerboard detector finds all corners or none).
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : board.Corners())
    centre += p / board.NumCorners();
  for (int k = 0, tries = 0; k < views && tries < 100000; ++tries) {
    const double z = 0.35 + 0.25 * (0.5 + 0.5 * uni(rng));
    const Eigen::Vector3d t(0.06 + 0.22 * z * uni(rng), 0.16 * z * uni(rng), z);
    const Eigen::Matrix3d R =
        (Eigen::AngleAxisd(0.6 * uni(rng), Eigen::Vector3d::UnitX()) *
         Eigen::AngleAxisd(0.6 * uni(rng), Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(3.14159265358979 * uni(rng), Eigen::Vector3d::UnitZ()) *
         Eigen::AngleAxisd(3.14159265358979, Eigen::Vector3d::UnitX()))  // print faces the camera
            .matrix();
    std::vector<std::vector<Eigen::Vector2d>> uv(2);
    bool inside = true;
    for (int c = 0; c < 2 && inside; ++c) {
      for (int id = 0; id < board.NumCorners() && inside; ++id) {
        const Eigen::Vector3d p_C0 = R * (board.Corner(id) - centre) + t;
        const Eigen::Vector3d p_C = c == 0 ? p_C0 : T_C0_C1.inverse() * p_C0;
        Eigen::Vector2d q;
        inside = p_C.z() > 0.1 && models[static_cast<std::size_t>(c)].Project(p_C, &q) &&
                 q.x() > 10 && q.y() > 10 && q.x() < 630 && q.y() < 470;
        uv[static_cast<std::size_t>(c)].push_back(q);
      }
    }
    if (!inside)
      continue;
    const std::int64_t t_ns = 1000000000LL + k * 500000000LL;
    for (int c = 0; c < 2; ++c) {
      const std::string name = "cam" + std::to_string(c);
      const bool turn = 0.5 + 0.5 * uni(rng) < turn_probability;
      s.turned[name][t_ns] = turn;
      std::vector<CornerObservation> frame;
      for (int id = 0; id < board.NumCorners(); ++id) {
        CornerObservation o;
        o.t_ns = t_ns;
        o.corner_id = turn ? half[static_cast<std::size_t>(id)] : id;
        o.u = uv[static_cast<std::size_t>(c)][static_cast<std::size_t>(id)].x() + noise(rng);
        o.v = uv[static_cast<std::size_t>(c)][static_cast<std::size_t>(id)].y() + noise(rng);
        frame.push_back(o);
      }
      std::sort(frame.begin(), frame.end(),
                [](const CornerObservation& a, const CornerObservation& b) {
                  return a.corner_id < b.corner_id;
                });
      SensorData& d = s.data[name];
      d.has_corners = true;
      d.corners.insert(d.corners.end(), frame.begin(), frame.end());
    }
    ++k;
  }

  s.rig = truth;
  for (SensorConfig& c : s.rig.sensors) {
    c.intrinsics[0] *= 1.03;
    c.intrinsics[1] *= 1.03;
    c.distortion_coeffs.assign(4, 0.0);
  }
  Eigen::Isometry3d guess = T_C0_C1;
  guess.linear() = guess.linear() * Eigen::AngleAxisd(0.017, Eigen::Vector3d::UnitY()).matrix();
  guess.translation() += Eigen::Vector3d(0.01, 0.0, 0.0);
  s.rig.sensors[1].T_B_S = guess.matrix();
  return s;
}

// The stereo pose error of a result against the truth: rotation (deg) and translation (m).
inline std::pair<double, double> StereoPoseError(const RigConfig& result, const RigConfig& truth) {
  const Eigen::Isometry3d a(result.Find("cam1")->T_B_S), b(truth.Find("cam1")->T_B_S);
  const Eigen::Isometry3d d = a.inverse() * b;
  return {Eigen::AngleAxisd(d.linear()).angle() * 180.0 / 3.14159265358979, d.translation().norm()};
}

}  // namespace ctcal::test
