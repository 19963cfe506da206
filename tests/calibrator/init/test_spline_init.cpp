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

#include "../../../calibrator/src/problem/spline_trajectory_fit.h"
#include "../simulated_recording.h"
#include "ctcal/calibrator/calibration_state.h"
#include "ctcal/calibrator/spline_init.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig_yaml.h"
#include "ctcal/spline/so3.h"

// After Eigen (opencv2/core/eigen.hpp needs it first).
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

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

// The board views are solved per frame in parallel and handed from the coarse initialisation
// (solved at the calibrator's 8-corner threshold, its stages taking those with >= 12 inliers) to
// the calibrator: neither may change a bit of a pose. Checked on the guessed (table4) camera, as
// the calibrator runs them.
TEST(SplineInit, BoardViewsDoNotDependOnThreadsOrTheHandOver) {
  const std::string dir = test::SimulateOnce("ctcal_spline_init_22_" + std::to_string(::getpid()),
                                             test::FullTable4Args(22, 3.0));
  std::vector<std::string> warnings;
  const RigConfig rig = LoadRig(dir + "/rig.yaml", &warnings);
  const auto data = LoadDataset(dir, rig, &warnings);
  std::filesystem::remove_all(dir);
  const Board board(rig.target);
  const auto same = [](const BoardView& a, const BoardView& b) {
    return a.t_ns == b.t_ns && a.T_C_W.matrix() == b.T_C_W.matrix() && a.corners == b.corners &&
           a.inliers == b.inliers && a.rms_ray_error == b.rms_ray_error;
  };
  for (const char* name : {"cam0", "cam1"}) {
    const SensorConfig& c = *rig.Find(name);
    const CameraModel camera =
        CameraModel::Create(c.camera_model, c.intrinsics, c.distortion_model, c.distortion_coeffs,
                            Eigen::Vector2i(c.width, c.height));
    const auto& corners = data.at(name).corners;
    const std::vector<BoardView> serial = EstimateBoardViews(camera, board, corners, 8, 1);
    const std::vector<BoardView> parallel = EstimateBoardViews(camera, board, corners, 8, 2);
    ASSERT_GT(serial.size(), 40u) << name;
    ASSERT_EQ(serial.size(), parallel.size()) << name;
    for (std::size_t i = 0; i < serial.size(); ++i)
      EXPECT_TRUE(same(serial[i], parallel[i])) << name << " view " << i;
    // The stages' views: a 12-corner run equals the 8-corner views with >= 12 inliers.
    std::vector<BoardView> filtered;
    for (const BoardView& v : serial) {
      if (v.inliers >= 12)
        filtered.push_back(v);
    }
    const std::vector<BoardView> twelve = EstimateBoardViews(camera, board, corners, 12, 2);
    ASSERT_EQ(filtered.size(), twelve.size()) << name;
    for (std::size_t i = 0; i < twelve.size(); ++i)
      EXPECT_TRUE(same(filtered[i], twelve[i])) << name << " view " << i;
  }
}

// EstimateBoardViews refines each pose by its own Gauss-Newton on the normalised plane
// (RefinePoseOnPlane, spline_init.cpp) in place of OpenCV's SOLVEPNP_ITERATIVE (K = I), which
// minimises the same sum of squared normalised-plane errors: on every view without a gated corner
// the pose must be OpenCV's refined pose (to OpenCV's own stop at a relative step of FLT_EPSILON)
// and its cost no larger.
TEST(SplineInit, BoardPoseRefinementReachesOpenCvsOptimum) {
  const Simulated& sim = Simulation();
  const Board board(sim.truth.target);
  int compared = 0;
  double worst_deg = 0.0, worst_m = 0.0;
  for (const char* name : {"cam0", "cam1"}) {
    const SensorConfig& c = *sim.truth.Find(name);
    const CameraModel camera =
        CameraModel::Create(c.camera_model, c.intrinsics, c.distortion_model, c.distortion_coeffs,
                            Eigen::Vector2i(c.width, c.height));
    const auto& corners = sim.data.at(name).corners;
    const std::vector<BoardView> views = EstimateBoardViews(camera, board, corners, 8);
    ASSERT_GT(views.size(), 40u) << name;
    for (const BoardView& v : views) {
      std::vector<cv::Point3d> object;
      std::vector<cv::Point2d> image;
      for (const CornerObservation& o : corners) {
        Eigen::Vector3d ray;
        if (o.t_ns != v.t_ns || !camera.Unproject(Eigen::Vector2d(o.u, o.v), &ray) ||
            ray.z() < 0.05)
          continue;
        const Eigen::Vector3d& p = board.Corner(o.corner_id);
        object.emplace_back(p.x(), p.y(), p.z());
        image.emplace_back(ray.x() / ray.z(), ray.y() / ray.z());
      }
      if (static_cast<int>(object.size()) != v.inliers)
        continue;  // a corner was gated: OpenCV's pose on all of them is another problem
      cv::Mat rvec, tvec, R_cv;
      ASSERT_TRUE(cv::solvePnP(object, image, cv::Matx33d::eye(), cv::noArray(), rvec, tvec, false,
                               cv::SOLVEPNP_IPPE));
      cv::solvePnP(object, image, cv::Matx33d::eye(), cv::noArray(), rvec, tvec, true,
                   cv::SOLVEPNP_ITERATIVE);
      cv::Rodrigues(rvec, R_cv);
      Eigen::Matrix3d R;
      Eigen::Vector3d t;
      cv::cv2eigen(R_cv, R);
      cv::cv2eigen(tvec, t);
      const auto cost = [&](const Eigen::Matrix3d& R_C_W, const Eigen::Vector3d& t_C_W) {
        double sum = 0.0;
        for (std::size_t k = 0; k < object.size(); ++k) {
          const Eigen::Vector3d p_C =
              R_C_W * Eigen::Vector3d(object[k].x, object[k].y, object[k].z) + t_C_W;
          sum += (p_C.head<2>() / p_C.z() - Eigen::Vector2d(image[k].x, image[k].y)).squaredNorm();
        }
        return sum;
      };
      const double ours = cost(v.T_C_W.linear(), v.T_C_W.translation());
      EXPECT_LE(ours, cost(R, t) * (1.0 + 1e-9)) << name << " at " << v.t_ns;
      const double deg =
          RotationError<double>(Eigen::Quaterniond(v.T_C_W.linear()), Eigen::Quaterniond(R))
              .norm() *
          180.0 / M_PI;
      const double m = (v.T_C_W.translation() - t).norm();
      worst_deg = std::max(worst_deg, deg);
      worst_m = std::max(worst_m, m);
      EXPECT_LT(deg, 1e-6) << name << " at " << v.t_ns;
      EXPECT_LT(m, 1e-7) << name << " at " << v.t_ns;
      ++compared;
    }
  }
  EXPECT_GT(compared, 80);
  std::printf("board pose refinement vs OpenCV: %d views, worst %.2e deg, %.2e m\n", compared,
              worst_deg, worst_m);
}

// The trajectory fit's data on the true calibration: both cameras' base poses (sorted by time)
// and the base IMU's samples with the truth's intrinsics and the simulator's biases (the ground
// truth is stamped at the base IMU's samples).
struct FitData {
  std::vector<TimedPose> poses;
  std::vector<spline_internal::BaseRateSample> imu;
};

FitData TrueFitData(const Simulated& sim) {
  FitData d;
  for (const char* name : {"cam0", "cam1"}) {
    const std::vector<TimedPose> p = TrueBasePoses(sim, name);
    d.poses.insert(d.poses.end(), p.begin(), p.end());
  }
  std::sort(d.poses.begin(), d.poses.end(),
            [](const TimedPose& a, const TimedPose& b) { return a.t_ns < b.t_ns; });
  CalibrationState state(sim.truth);
  const SensorState& base = *state.Find(sim.truth.base_imu);
  std::map<std::int64_t, const GroundTruthState*> truth_at;
  for (const GroundTruthState& g : sim.gt)
    truth_at[g.t_ns] = &g;
  for (const ImuSample& s : sim.data.at(sim.truth.base_imu).imu) {
    const auto it = truth_at.find(s.t_ns);
    if (it == truth_at.end()) {
      ADD_FAILURE() << "no ground truth at the base IMU's sample " << s.t_ns;
      continue;
    }
    spline_internal::BaseRateSample z;
    z.t_ns = s.t_ns;
    base.imu->TrueFromRaw(s.w_m, s.a_m, it->second->b_g, it->second->b_a, &z.w_I, &z.a_I);
    d.imu.push_back(z);
  }
  return d;
}

// The initial trajectory fit (spline_trajectory_fit.h) on the true calibration: from knots at the
// nearest board-view pose (errors of degrees and centimetres between views), Gauss-Newton on the
// poses and the base IMU (corrected by its true intrinsics and biases) must recover the simulated
// trajectory to the IMU's precision between the views and gravity's direction.
TEST(SplineInit, TrajectoryFitRecoversTheMotionAndGravity) {
  const Simulated& sim = Simulation();
  const RigConfig& truth = sim.truth;
  const std::vector<GroundTruthState>& gt = sim.gt;
  const FitData data = TrueFitData(sim);
  const std::vector<TimedPose>& poses = data.poses;
  const std::vector<spline_internal::BaseRateSample>& imu = data.imu;
  ASSERT_GT(poses.size(), 80u);

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

// The fit's normal equations assembled on several threads (chunks of consecutive segments whose
// boundary rows and gravity block are summed in chunk order): 2, 3 and 64 threads (64: chunks
// narrower than a segment's N knots, some empty) must agree with 1 to rounding, and two runs on 2
// threads bit for bit. A chunk's samples dropped or counted twice, or its boundary rows lost,
// move the cost and the knots by far more.
TEST(SplineInit, TrajectoryFitOnThreadsAgreesWithOneThreadAndRepeatsItsBits) {
  const FitData data = TrueFitData(Simulation());
  ASSERT_GT(data.poses.size(), 80u);
  using Fit = spline_internal::TrajectoryFit<4, Se3Representation::kSplit>;
  struct Result {
    std::vector<double> knots;
    Eigen::Vector3d g_W;
    spline_internal::TrajectoryFitReport report;
  };
  const auto fit = [&](int threads) {
    const std::int64_t t0 = data.poses.front().t_ns, t1 = data.poses.back().t_ns;
    const std::int64_t dt = 30000000;
    Se3Spline<4> spline(KnotTiming{t0, dt}, static_cast<int>((t1 - t0) / dt) + 4);
    Fit::SeedKnots(data.poses, &spline);
    Result r;
    r.g_W = Eigen::Vector3d(0.0, 0.0, -9.81);
    spline_internal::TrajectoryFitOptions options;
    options.threads = threads;
    r.report = Fit(data.poses, data.imu, options).Run(&spline, &r.g_W);
    r.knots.assign(spline.KnotData(0), spline.KnotData(0) + 7 * spline.NumKnots());
    return r;
  };
  const Result one = fit(1);
  EXPECT_GT(one.report.iterations, 0);
  for (const int threads : {2, 3, 64}) {
    const Result r = fit(threads);
    EXPECT_EQ(r.report.iterations, one.report.iterations) << threads << " threads";
    EXPECT_NEAR(r.report.initial_cost, one.report.initial_cost, 1e-9 * one.report.initial_cost)
        << threads << " threads";
    EXPECT_NEAR(r.report.final_cost, one.report.final_cost, 1e-9 * one.report.final_cost)
        << threads << " threads";
    for (int i = 0; i < 3; ++i)
      EXPECT_NEAR(r.g_W[i], one.g_W[i], 1e-9 * one.g_W.norm()) << threads << " threads";
    ASSERT_EQ(r.knots.size(), one.knots.size());
    double worst = 0.0;
    for (std::size_t i = 0; i < r.knots.size(); ++i)
      worst = std::max(worst,
                       std::abs(r.knots[i] - one.knots[i]) / std::max(1.0, std::abs(one.knots[i])));
    EXPECT_LT(worst, 1e-9) << threads << " threads";
    std::printf("trajectory fit on %d threads vs 1: knots %.1e, cost %.1e relative\n", threads,
                worst, std::abs(r.report.final_cost / one.report.final_cost - 1.0));
  }
  const Result a = fit(2), b = fit(2);
  EXPECT_EQ(a.knots, b.knots);  // exact: the same partition sums in the same order
  EXPECT_EQ(a.g_W, b.g_W);
  EXPECT_EQ(a.report.initial_cost, b.report.initial_cost);
  EXPECT_EQ(a.report.final_cost, b.report.final_cost);
  EXPECT_EQ(a.report.iterations, b.report.iterations);
}

}  // namespace
}  // namespace ctcal
