#include "ctcal/sim/image_writer.h"

#include <filesystem>
#include <stdexcept>

#include "ctcal/sensors/camera_model.h"
#include "ctcal/sim/kinematics.h"
#include "ctcal/sim/random.h"
#include "ctcal/targets/board.h"
#include "ctcal/targets/image_file.h"
#include "ctcal/targets/renderer.h"

namespace ctcal::sim {

void RenderImages(const SimulatedDataset& data, const Trajectory& traj, const std::string& dir,
                  std::uint64_t seed,
                  const std::function<void(std::size_t, std::size_t)>& progress) {
  namespace fs = std::filesystem;
  const RigConfig& rig = data.truth;
  const Board board(rig.target);
  std::size_t total = 0, done = 0;
  for (const CameraData& cam : data.cameras)
    total += cam.frames_ns.size();

  for (std::size_t c = 0; c < data.cameras.size(); ++c) {
    const CameraData& cam = data.cameras[c];
    const SensorConfig& s = *rig.Find(cam.sensor);
    const CameraModel camera =
        CameraModel::Create(s.camera_model, s.intrinsics, s.distortion_model, s.distortion_coeffs,
                            Eigen::Vector2i(s.width, s.height));
    const bool is_base = s.name == rig.base_imu;
    const Eigen::Matrix3d R_B_C =
        is_base ? Eigen::Matrix3d::Identity() : Eigen::Matrix3d(s.T_B_S.topLeftCorner<3, 3>());
    const Eigen::Vector3d t_B_C =
        is_base ? Eigen::Vector3d::Zero() : Eigen::Vector3d(s.T_B_S.topRightCorner<3, 1>());
    const double offset = is_base ? 0.0 : s.time_offset;
    const BoardRenderer renderer(board, s.width, s.height,
                                 [&camera](const Eigen::Vector2d& uv, Eigen::Vector3d* ray) {
                                   return camera.Unproject(uv, ray);
                                 });
    const auto pose_at = [&](double t) {
      const Pose T = SensorPoseInWorld(traj.Evaluate(t), R_B_C, t_B_C);
      Eigen::Isometry3d T_W_C = Eigen::Isometry3d::Identity();
      T_W_C.linear() = T.R;
      T_W_C.translation() = T.t;
      return T_W_C;
    };
    const fs::path folder = fs::path(dir) / cam.sensor / "data";
    std::error_code ec;
    fs::create_directories(folder, ec);
    if (ec)
      throw std::runtime_error("cannot create folder " + folder.string() + ": " + ec.message());
    // Streams distinct from the simulator's (which use small stream numbers per sensor).
    const Random camera_rng = Random(seed).Fork(0x1a6e0000ULL + c);
    for (std::size_t k = 0; k < cam.frames_ns.size(); ++k) {
      const std::int64_t ns = cam.frames_ns[k];
      const double t_image = static_cast<double>(ns) * 1e-9 + offset;
      const std::uint64_t image_seed = camera_rng.Fork(k).Bits();
      cv::Mat image;
      if (s.line_delay > 0.0) {
        image = renderer.Render([&](int row) { return pose_at(t_image + row * s.line_delay); },
                                image_seed);
      } else {
        image = renderer.Render(pose_at(t_image), image_seed);
      }
      const fs::path file = folder / (std::to_string(ns) + ".png");
      WritePngFile(file.string(), image);  // throws "cannot write <file>: <why>"
      if (progress)
        progress(++done, total);
    }
  }
}

}  // namespace ctcal::sim
