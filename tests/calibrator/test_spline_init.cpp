// Initialisation from a close guess: the board pose of every simulated camera frame, turned into a
// base pose with the TRUE extrinsics and time offset, must match the simulator's ground-truth base
// pose within the single-frame PnP precision of 1 px noise (< 1.5 deg, < 2.5 cm; the wrong branch
// of the planar pose ambiguity is off by several degrees).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "ctcal/calibrator/spline_init.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig_yaml.h"
#include "ctcal/spline/so3.h"

namespace ctcal {
namespace {

TEST(SplineInit, BoardViewsGiveTheTrueBasePoses) {
  const std::string dir = ::testing::TempDir() + "/ctcal_spline_init_21";
  const std::string cmd = std::string(CTCAL_BINARY) +
                          " simulate --scenario full --seed 21 --duration 3 --out " + dir +
                          " > /dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::vector<std::string> warnings;
  const RigConfig truth = LoadRig(dir + "/truth.yaml", &warnings);
  const auto data = LoadDataset(dir, truth, &warnings);
  const std::vector<GroundTruthState> gt = ReadGroundTruthCsv(dir + "/groundtruth/data.csv");
  const Board board(truth.target);
  for (const char* name : {"cam0", "cam1"}) {
    const SensorConfig& c = *truth.Find(name);
    const CameraModel camera =
        CameraModel::Create(c.camera_model, c.intrinsics, c.distortion_model, c.distortion_coeffs,
                            Eigen::Vector2i(c.width, c.height));
    const std::vector<BoardView> views =
        EstimateBoardViews(camera, board, data.at(name).corners, 8);
    ASSERT_GT(views.size(), 40u) << name;
    Eigen::Isometry3d T_B_C = Eigen::Isometry3d::Identity();
    T_B_C.matrix() = c.T_B_S;
    const std::vector<TimedPose> poses = BasePosesFromViews(views, T_B_C, c.time_offset);
    int compared = 0;
    for (const TimedPose& p : poses) {
      // The ground truth is at the base IMU's samples (4 ms apart): take the nearest one, within
      // 2 ms, and its pose at the view's time by its velocity (the rotation moves < 0.2 deg).
      for (const GroundTruthState& g0 : gt) {
        if (std::llabs(g0.t_ns - p.t_ns) > 2000000)
          continue;
        GroundTruthState g = g0;
        g.p_W_B += g.v_W * 1e-9 * static_cast<double>(p.t_ns - g.t_ns);
        const double angle_deg = RotationError<double>(p.q_W_B, g.q_W_B).norm() * 180.0 / M_PI;
        EXPECT_LT(angle_deg, 1.5) << name << " at " << p.t_ns;
        EXPECT_LT((p.p_W_B - g.p_W_B).norm(), 0.025) << name << " at " << p.t_ns;
        ++compared;
      }
    }
    EXPECT_GT(compared, 0) << name;
  }
}

}  // namespace
}  // namespace ctcal
