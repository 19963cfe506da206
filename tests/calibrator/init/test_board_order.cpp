// The corner order of a symmetric board's views (init/board_order.h): a stereo pair whose views
// were turned by half a turn at random gets one order per instant and then the rendered truth's
// stereo pose; an IMU rig's views get one order over the whole recording (the gyroscope along
// time); boards with an order of their own are left alone; and real photos (opencv-doc's stereo
// pairs, cut to a symmetric 6x8 grid and turned at random) calibrate as unturned.
#include "ctcal/calibrator/init/board_order.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "../simulated_recording.h"
#include "../symmetric_stereo.h"
#include "ctcal/calibrator/camera_only/camera_only_calibrator.h"
#include "ctcal/sensors/rig_yaml.h"
#include "ctcal/targets/detector.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;

const InitLog kQuiet = [](const std::string&) {};

// Whether a frame's ids now are the half turn of the truth's: truth id 0 was labelled
// `turned ? half[0] : 0` in the recording; after renaming, label 0 is at that pixel or not.
bool EndsTurned(const std::vector<CornerObservation>& before,
                const std::vector<CornerObservation>& after, std::int64_t t_ns, bool turned,
                const std::vector<int>& half) {
  const int truth0 = turned ? half[0] : 0;
  Eigen::Vector2d uv0(0, 0), now(-1, -1);
  for (const CornerObservation& o : before)
    if (o.t_ns == t_ns && o.corner_id == truth0)
      uv0 = {o.u, o.v};
  for (const CornerObservation& o : after)
    if (o.t_ns == t_ns && o.corner_id == 0)
      now = {o.u, o.v};
  return (now - uv0).norm() > 1e-9;
}

TEST(BoardOrder, StereoViewsGetOneOrderPerInstant) {
  test::SymmetricStereo s = test::MakeSymmetricStereo(7, 24, 0.5);
  const auto before = s.data;
  BoardOrderResult r = ResolveBoardOrder(s.rig, &s.data, {}, kQuiet);
  EXPECT_EQ(r.symmetries, 1);
  EXPECT_EQ(r.dropped["cam0"] + r.dropped["cam1"], 0);
  EXPECT_GT(r.turned["cam1"], 0);
  const std::vector<int> half = BoardSymmetries(Board(s.rig.target)).at(0).turned_id;
  int instants = 0;
  for (const auto& [t_ns, turned0] : s.turned["cam0"]) {
    const bool a =
        EndsTurned(before.at("cam0").corners, s.data.at("cam0").corners, t_ns, turned0, half);
    const bool b = EndsTurned(before.at("cam1").corners, s.data.at("cam1").corners, t_ns,
                              s.turned["cam1"][t_ns], half);
    EXPECT_EQ(a, b) << "instant " << t_ns;
    ++instants;
  }
  EXPECT_EQ(instants, 24);
}

CameraOnlyResult CalibrateQuietly(const test::SymmetricStereo& s) {
  CameraOnlyOptions options;
  std::ostringstream log;
  return CalibrateCameraOnly(s.rig, s.data, options, log);
}

// The done-when bar of issue 21: stereo pose within 0.3 deg and 2 mm, focal lengths within 4 px.
// Unresolved, the same views give a pose tens of degrees off (or no calibration).
TEST(BoardOrder, SymmetricStereoRecoversTheStereoPose) {
  test::SymmetricStereo s = test::MakeSymmetricStereo(11, 20, 0.5);
  bool wrong_unresolved = true;
  try {
    const auto [deg, m] = test::StereoPoseError(CalibrateQuietly(s).rig, s.truth);
    wrong_unresolved = deg > 1.0 || m > 0.01;
  } catch (const std::exception&) {
  }
  EXPECT_TRUE(wrong_unresolved) << "the turned views calibrate without resolution: no test";
  ResolveBoardOrder(s.rig, &s.data, {}, kQuiet);
  const CameraOnlyResult result = CalibrateQuietly(s);
  const auto [deg, m] = test::StereoPoseError(result.rig, s.truth);
  std::printf("symmetric stereo (20 views, random half turns): stereo pose %.4f deg, %.3f mm\n",
              deg, 1e3 * m);
  EXPECT_LT(deg, 0.3);
  EXPECT_LT(m, 0.002);
  for (const SensorConfig& c : result.rig.sensors) {
    const SensorConfig& t = *s.truth.Find(c.name);
    EXPECT_NEAR(c.intrinsics[0], t.intrinsics[0], 4.0) << c.name;
    EXPECT_NEAR(c.intrinsics[1], t.intrinsics[1], 4.0) << c.name;
  }
}

TEST(BoardOrder, BoardsWithAnOrderOfTheirOwnAreLeftAlone) {
  test::SymmetricStereo s = test::MakeSymmetricStereo(5, 6, 0.0);
  for (TargetConfig target : {TargetConfig{}, test::FourBySixCheckerboard()}) {
    if (target.type == TargetType::kCheckerboard)
      target.target_cols = 5;  // 4 x 5: rows + cols odd, the detector reads the colours
    RigConfig rig = s.rig;
    rig.target = target;
    auto data = s.data;
    const BoardOrderResult r = ResolveBoardOrder(rig, &data, {}, kQuiet);
    EXPECT_EQ(r.symmetries, 0);
    EXPECT_TRUE(r.views.empty());
    for (const auto& [name, d] : data) {
      ASSERT_EQ(d.corners.size(), s.data.at(name).corners.size());
      for (std::size_t i = 0; i < d.corners.size(); ++i)
        EXPECT_EQ(d.corners[i].corner_id, s.data.at(name).corners[i].corner_id);
    }
  }
}

// An IMU rig (the default rig's two cameras, 12 s of the full scenario) recording a 6x8
// checkerboard; every view of each camera turned at random. The board is one world, so every
// view must end in one order: across cameras at an instant and along time by the gyroscope.
TEST(BoardOrder, ImuRigViewsGetOneOrderOverTheRecording) {
  RigConfig truth = LoadRig(std::string(CTCAL_SOURCE_DIR) + "/configs/default_rig_truth.yaml");
  truth.target = test::FourBySixCheckerboard();
  truth.target.target_rows = 6;
  truth.target.target_cols = 8;
  truth.target.row_spacing_m = truth.target.col_spacing_m = 0.06;
  const fs::path rig_path = fs::path(::testing::TempDir()) /
                            ("ctcal_board_order_rig_" + std::to_string(::getpid()) + ".yaml");
  SaveRig(truth, rig_path.string());
  test::Recording rec = test::LoadRecording(
      test::SimulateOnce("ctcal_board_order_imu_" + std::to_string(::getpid()),
                         "--scenario full --seed 31 --duration 12 --rig " + rig_path.string()));
  const Board board(rec.rig.target);
  const std::vector<int> half = BoardSymmetries(board).at(0).turned_id;
  std::mt19937 rng(3);
  std::map<std::string, std::map<std::int64_t, bool>> turned;
  for (auto& [name, d] : rec.data) {
    for (CornerObservation& o : d.corners) {
      const auto [it, inserted] = turned[name].emplace(o.t_ns, false);
      if (inserted)
        it->second = rng() % 2 == 1;
      if (it->second)
        o.corner_id = half[static_cast<std::size_t>(o.corner_id)];
    }
  }
  const auto before = rec.data;
  const BoardOrderResult r = ResolveBoardOrder(rec.rig, &rec.data, {}, kQuiet);
  int views = 0, dropped = 0;
  for (const auto& [name, n] : r.views) {
    views += n;
    dropped += r.dropped.at(name);
  }
  EXPECT_GT(views, 300);
  EXPECT_LE(dropped, views / 100);
  // One order over both cameras and the whole recording (which one is the group's choice).
  std::set<bool> orders;
  for (const auto& [name, frames] : turned) {
    if (!rec.data.at(name).has_corners)
      continue;
    std::set<std::int64_t> kept;
    for (const CornerObservation& o : rec.data.at(name).corners)
      kept.insert(o.t_ns);
    for (const auto& [t_ns, was_turned] : frames) {
      bool has_zero = false;
      for (const CornerObservation& o : before.at(name).corners)
        has_zero |= o.t_ns == t_ns && o.corner_id == (was_turned ? half[0] : 0);
      if (kept.count(t_ns) && has_zero)
        orders.insert(
            EndsTurned(before.at(name).corners, rec.data.at(name).corners, t_ns, was_turned, half));
    }
  }
  EXPECT_EQ(orders.size(), 1u);
}

// Real photos: opencv-doc's 13 stereo pairs (9x6 inner corners, an order of their own), cut to
// their first 8 columns (6x8: rows + cols even, a board that looks the same turned) and each
// view's ids turned by half at random. Resolved, the stereo calibration is the unturned one's.
TEST(BoardOrder, RealStereoPhotosTurnedAtRandomCalibrateAsUnturned) {
  const std::string dir = "/usr/share/doc/opencv-doc/examples/data/";
  if (!fs::exists(dir + "left01.jpg"))
    GTEST_SKIP() << dir << "left01.jpg is absent (Debian's opencv-doc not installed)";
  TargetConfig nine_by_six = test::FourBySixCheckerboard();
  nine_by_six.target_rows = 6;
  nine_by_six.target_cols = 9;
  nine_by_six.row_spacing_m = nine_by_six.col_spacing_m = 0.025;
  const Board board(nine_by_six);
  const Detector detector(board);
  test::SymmetricStereo s;
  s.rig.base_imu = "cam0";
  s.rig.target = nine_by_six;
  s.rig.target.target_cols = 8;
  const std::vector<int> half = BoardSymmetries(Board(s.rig.target)).at(0).turned_id;
  std::mt19937 rng(5);
  for (int c = 0; c < 2; ++c) {
    SensorConfig cam;
    cam.name = "cam" + std::to_string(c);
    cam.type = SensorType::kCamera;
    cam.camera_model = "pinhole";
    cam.intrinsics = {540.0, 540.0, 320.0, 240.0};
    cam.distortion_model = "radtan";
    cam.distortion_coeffs = {0.0, 0.0, 0.0, 0.0};
    cam.width = 640;
    cam.height = 480;
    cam.pixel_sigma = 0.2;
    cam.estimate = {EstimateItem::kIntrinsics};
    if (c == 1) {
      cam.estimate.insert(EstimateItem::kExtrinsics);
      cam.T_B_S(0, 3) = -0.08;
    }
    s.rig.sensors.push_back(cam);
  }
  int pairs = 0;
  for (int i = 1; i <= 14; ++i) {
    char name[2][32];
    std::snprintf(name[0], sizeof name[0], "left%02d.jpg", i);
    std::snprintf(name[1], sizeof name[1], "right%02d.jpg", i);
    if (!fs::exists(dir + name[0]) || !fs::exists(dir + name[1]))
      continue;
    std::vector<DetectionResult> found;
    for (const char* n : name)
      found.push_back(detector.Detect(cv::imread(dir + n, cv::IMREAD_UNCHANGED)));
    if (!found[0].board_found || !found[1].board_found)
      continue;
    ++pairs;
    for (int c = 0; c < 2; ++c) {
      const std::string cam = "cam" + std::to_string(c);
      const bool turn = rng() % 2 == 1;
      std::vector<CornerObservation> frame;
      for (const DetectedCorner& d : found[static_cast<std::size_t>(c)].corners) {
        if (d.id % 9 == 8)
          continue;  // the 9th column: not on the 6x8 grid
        CornerObservation o;
        o.t_ns = 1000000000LL * i;
        const int id = d.id / 9 * 8 + d.id % 9;
        o.corner_id = turn ? half[static_cast<std::size_t>(id)] : id;
        o.u = d.uv.x();
        o.v = d.uv.y();
        frame.push_back(o);
      }
      std::sort(frame.begin(), frame.end(),
                [](const auto& a, const auto& b) { return a.corner_id < b.corner_id; });
      s.turned[cam][1000000000LL * i] = turn;
      s.data[cam].has_corners = true;
      s.data[cam].corners.insert(s.data[cam].corners.end(), frame.begin(), frame.end());
    }
  }
  ASSERT_GE(pairs, 10);
  // The reference: the same corners in the photos' own order.
  test::SymmetricStereo unturned = s;
  for (auto& [cam, d] : unturned.data) {
    for (CornerObservation& o : d.corners)
      if (s.turned[cam][o.t_ns])
        o.corner_id = half[static_cast<std::size_t>(o.corner_id)];  // the half turn is its inverse
  }
  const RigConfig reference = CalibrateQuietly(unturned).rig;
  BoardOrderResult r = ResolveBoardOrder(s.rig, &s.data, {}, kQuiet);
  // A pair whose two PnP rotations disagree with the others' by more than the tolerance is dropped
  // (measured: 1 of 13), which moves the calibration a little from the unturned one's.
  EXPECT_LE(r.dropped["cam0"] + r.dropped["cam1"], 1);
  const RigConfig resolved = CalibrateQuietly(s).rig;
  const auto [deg, m] = test::StereoPoseError(resolved, reference);
  const double baseline =
      Eigen::Vector3d(Eigen::Isometry3d(reference.Find("cam1")->T_B_S).translation()).norm();
  std::printf(
      "opencv-doc stereo, %d pairs cut to 6x8 and turned at random: baseline %.1f mm, "
      "stereo pose vs unturned %.5f deg, %.4f mm\n",
      pairs, 1e3 * baseline, deg, 1e3 * m);
  EXPECT_LT(deg, 0.1);  // a third of issue 21's bar (0.3 deg, 2 mm)
  EXPECT_LT(m, 5e-4);
}

}  // namespace
}  // namespace ctcal
