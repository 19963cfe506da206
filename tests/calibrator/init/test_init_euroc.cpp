// Stages 1 and 2 of the coarse-guess initialisation on real detections: EuRoC's cam_april stereo
// recording (30 nearly alike views, 1.5 s). The guess is EuRoC's published calibration with the
// focal lengths 5 % short and no distortion (what `--perturb coarse` does to a simulated rig).
// Its views are too alike to pin the focal length (OpenCV lands ~20 px from the reference), so
// the tolerances here are those of the data, not of the method; the numbers are printed.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "ctcal/calibrator/init/camera_init.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;

TEST(InitEuroc, IntrinsicsAndStereoPoseFromCoarseGuess) {
  const fs::path dir = fs::path(CTCAL_SHARED_DATA_DIR) / "euroc_cam_april";
  if (!fs::exists(dir / "reference.yaml"))
    GTEST_SKIP() << "real data absent: " << dir.string();
  const RigConfig reference = LoadRig((dir / "reference.yaml").string());
  const std::map<std::string, SensorData> data = LoadDataset(dir.string(), reference);
  const Board board(reference.target);

  std::vector<BoardView> views[2];
  const std::string cams[2] = {"cam0", "cam1"};
  for (int i = 0; i < 2; ++i) {
    const SensorConfig& ref = *reference.Find(cams[i]);
    std::vector<double> intrinsics = ref.intrinsics;
    intrinsics[0] *= 0.95;
    intrinsics[1] *= 0.95;
    const CameraModel guess =
        CameraModel::Create(ref.camera_model, intrinsics, ref.distortion_model,
                            std::vector<double>(ref.distortion_coeffs.size(), 0.0),
                            Eigen::Vector2i(ref.width, ref.height));
    const IntrinsicsInitResult r =
        InitCameraIntrinsics(cams[i], guess, board, data.at(cams[i]).corners, {}, {});
    const std::vector<double> k = r.camera.intrinsics();
    const std::vector<double> d = r.camera.distortion_coeffs();
    std::printf(
        "%s: fu %.2f fv %.2f pu %.2f pv %.2f (reference %.2f %.2f %.2f %.2f), k1 %.4f "
        "k2 %.4f (reference %.4f %.4f), RMS %.3f px on %d views, %d outliers\n",
        cams[i].c_str(), k[0], k[1], k[2], k[3], ref.intrinsics[0], ref.intrinsics[1],
        ref.intrinsics[2], ref.intrinsics[3], d[0], d[1], ref.distortion_coeffs[0],
        ref.distortion_coeffs[1], r.rms_px, r.views, r.outliers);
    // Weakly determined by these views: within 5 % (the guess was 5 % off).
    EXPECT_NEAR(k[0] / ref.intrinsics[0], 1.0, 0.05) << cams[i];
    EXPECT_NEAR(k[1] / ref.intrinsics[1], 1.0, 0.05) << cams[i];
    EXPECT_NEAR(k[2], ref.intrinsics[2], 15.0) << cams[i];
    EXPECT_NEAR(k[3], ref.intrinsics[3], 15.0) << cams[i];
    EXPECT_LT(r.rms_px, 0.5) << cams[i];
    views[i] = InitBoardPoses(cams[i], r.camera, board, data.at(cams[i]).corners, 12, 3, {}).views;
  }
  const RelativePoseResult rel =
      InitCameraRelativePose("cam0", views[0], 0.0, "cam1", views[1], 0.0, {});
  Eigen::Isometry3d T_C0_C1;
  T_C0_C1.matrix() = reference.Find("cam1")->T_B_S;
  const double rot_deg =
      Eigen::AngleAxisd(rel.T_Ci_Cj.linear().transpose() * T_C0_C1.linear()).angle() * 180.0 / M_PI;
  const double trans_mm = (rel.T_Ci_Cj.translation() - T_C0_C1.translation()).norm() * 1e3;
  std::printf("T_cam0_cam1: %.4f deg, %.2f mm from the reference (baseline %.2f mm), %d pairs\n",
              rot_deg, trans_mm, rel.T_Ci_Cj.translation().norm() * 1e3, rel.pairs);
  EXPECT_LT(rot_deg, 0.5);
  // Board depths scale with the focal length, so the ~4 % focal error of these alike views puts
  // the camera positions, and the stereo translation, ~15 mm off (measured 15.0 mm).
  EXPECT_LT(trans_mm, 25.0);
}

}  // namespace
}  // namespace ctcal
