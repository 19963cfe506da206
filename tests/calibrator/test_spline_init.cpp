// Initialisation from a close guess: the board pose of every simulated camera frame, turned into a
// base pose with the TRUE extrinsics and time offset, must match the simulator's ground-truth base
// pose within the single-frame PnP precision of 1 px noise (< 1.5 deg, < 2.5 cm; the wrong branch
// of the planar pose ambiguity is off by several degrees).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>

#include "../../calibrator/src/spline_trajectory_fit.h"
#include "ctcal/calibrator/calibration_state.h"
#include "ctcal/calibrator/spline_init.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig_yaml.h"
#include "ctcal/spline/so3.h"
#include "simulated_recording.h"

namespace ctcal {
namespace {

// A 3 s recording of the default rig's full scenario, simulated once per process: the truth, the
// data, the ground truth.
struct Simulated {
  RigConfig truth;
  std::map<std::string, SensorData> data;
  std::vector<GroundTruthState> gt;
};

const Simulated& Simulation() {
  static const Simulated sim = [] {
    const std::string dir = test::SimulateOnce("ctcal_spline_init_21_" + std::to_string(::getpid()),
                                               "--scenario full --seed 21 --duration 3");
    Simulated s;
    std::vector<std::string> warnings;
    s.truth = LoadRig(dir + "/truth.yaml", &warnings);
    s.data = LoadDataset(dir, s.truth, &warnings);
    s.gt = ReadGroundTruthCsv(dir + "/groundtruth/data.csv");
    std::filesystem::remove_all(dir);
    return s;
  }();
  return sim;
}

// The board views of a camera with its TRUE intrinsics, turned into base poses with its true
// extrinsics and time offset; *num_views counts the views.
std::vector<TimedPose> TrueBasePoses(const Simulated& sim, const std::string& name,
                                     std::size_t* num_views = nullptr) {
  const SensorConfig& c = *sim.truth.Find(name);
  const CameraModel camera =
      CameraModel::Create(c.camera_model, c.intrinsics, c.distortion_model, c.distortion_coeffs,
                          Eigen::Vector2i(c.width, c.height));
  const std::vector<BoardView> views =
      EstimateBoardViews(camera, Board(sim.truth.target), sim.data.at(name).corners, 8);
  if (num_views)
    *num_views = views.size();
  Eigen::Isometry3d T_B_C = Eigen::Isometry3d::Identity();
  T_B_C.matrix() = c.T_B_S;
  return BasePosesFromViews(views, T_B_C, c.time_offset);
}

TEST(SplineInit, BoardViewsGiveTheTrueBasePoses) {
  const Simulated& sim = Simulation();
  for (const char* name : {"cam0", "cam1"}) {
    std::size_t views = 0;
    const std::vector<TimedPose> poses = TrueBasePoses(sim, name, &views);
    ASSERT_GT(views, 40u) << name;
    int compared = 0;
    for (const TimedPose& p : poses) {
      // The ground truth is at the base IMU's samples (4 ms apart): take the nearest one, within
      // 2 ms, and its pose at the view's time by its velocity (the rotation moves < 0.2 deg).
      for (const GroundTruthState& g0 : sim.gt) {
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

// The initial trajectory fit (spline_trajectory_fit.h) on the true calibration: from knots at the
// nearest board-view pose (errors of degrees and centimetres between views), Gauss-Newton on the
// poses and the base IMU (corrected by its true intrinsics and biases) must recover the simulated
// trajectory to the IMU's precision between the views and gravity's direction.
TEST(SplineInit, TrajectoryFitRecoversTheMotionAndGravity) {
  const Simulated& sim = Simulation();
  const RigConfig& truth = sim.truth;
  const std::vector<GroundTruthState>& gt = sim.gt;
  std::vector<TimedPose> poses;
  for (const char* name : {"cam0", "cam1"}) {
    const std::vector<TimedPose> p = TrueBasePoses(sim, name);
    poses.insert(poses.end(), p.begin(), p.end());
  }
  std::sort(poses.begin(), poses.end(),
            [](const TimedPose& a, const TimedPose& b) { return a.t_ns < b.t_ns; });
  ASSERT_GT(poses.size(), 80u);

  // The base IMU's samples with the truth's intrinsics and the simulator's biases (the ground
  // truth is stamped at the base IMU's samples).
  CalibrationState state(truth);
  const SensorState& base = *state.Find(truth.base_imu);
  std::map<std::int64_t, const GroundTruthState*> truth_at;
  for (const GroundTruthState& g : gt)
    truth_at[g.t_ns] = &g;
  std::vector<spline_internal::BaseRateSample> imu;
  for (const ImuSample& s : sim.data.at(truth.base_imu).imu) {
    const auto it = truth_at.find(s.t_ns);
    ASSERT_NE(it, truth_at.end()) << s.t_ns;
    spline_internal::BaseRateSample z;
    z.t_ns = s.t_ns;
    base.imu->TrueFromRaw(s.w_m, s.a_m, it->second->b_g, it->second->b_a, &z.w_I, &z.a_I);
    imu.push_back(z);
  }

  using Fit = spline_internal::TrajectoryFit<4, Se3Representation::kSplit>;
  const std::int64_t t0 = poses.front().t_ns, t1 = poses.back().t_ns;
  const std::int64_t dt = 30000000;  // 30 ms, the demo's spacing: < 2 views per knot interval
  Se3Spline<4> spline(KnotTiming{t0, dt}, static_cast<int>((t1 - t0) / dt) + 4);
  Fit::SeedKnots(poses, &spline);
  Eigen::Vector3d g_W(0.0, 0.0, -9.81);
  const spline_internal::TrajectoryFitReport report =
      Fit(poses, imu, spline_internal::TrajectoryFitOptions{}).Run(&spline, &g_W);
  EXPECT_LT(report.final_cost, 1e-2 * report.initial_cost);
  EXPECT_GT(report.iterations, 0);

  double max_deg = 0.0, max_m = 0.0;
  for (const GroundTruthState& g : gt) {
    if (g.t_ns < spline.MinTimeNs() || g.t_ns > spline.MaxTimeNs())
      continue;
    const Se3Kinematics<double> kin = spline.Evaluate(g.t_ns, 0);
    max_deg =
        std::max(max_deg, RotationError<double>(Eigen::Quaterniond(kin.R_W_B), g.q_W_B).norm() *
                              180.0 / M_PI);
    max_m = std::max(max_m, (kin.p_W_B - g.p_W_B).norm());
  }
  // PnP poses are ~0.3 deg / ~5 mm apart from the truth each; the fit averages them under the
  // IMU's shape.
  EXPECT_LT(max_deg, 0.3);
  EXPECT_LT(max_m, 0.01);
  ASSERT_TRUE(truth.gravity_W.has_value());
  const double g_deg =
      std::acos(std::min(1.0, g_W.normalized().dot(truth.gravity_W->normalized()))) * 180.0 / M_PI;
  EXPECT_LT(g_deg, 0.1);
  EXPECT_NEAR(g_W.norm(), truth.gravity_W->norm(), 0.05);
  std::printf(
      "trajectory fit: max rotation error %.3f deg, position %.2f mm, gravity %.3f deg, "
      "%d iterations\n",
      max_deg, 1e3 * max_m, g_deg, report.iterations);
}

}  // namespace
}  // namespace ctcal
