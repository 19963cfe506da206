// An mrcal camera in the files of Kalibr, OpenVINS and basalt (kalibr_camera.h): OPENCV4 is
// pinhole-radtan exactly; a rational OPENCV8 is fitted, and the error the fit states is the error
// a user of the written file gets at pixels the fit never saw.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "ctcal/sensors/camera_model.h"
#include "ctcal/sensors/ecosystem_exports.h"
#include "ctcal/sensors/kalibr_camera.h"
#include "ctcal/sensors/kalibr_files.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal {
namespace {

SensorConfig MrcalCamera(const std::string& lens, const std::vector<double>& intrinsics) {
  SensorConfig c;
  c.name = "cam0";
  c.type = SensorType::kCamera;
  c.camera_model = "mrcal";
  c.distortion_model = lens;
  c.intrinsics = intrinsics;
  c.width = 752;
  c.height = 480;
  return c;
}

CameraModel ModelOf(const SensorConfig& c) {
  return CameraModel::Create(c.camera_model, c.intrinsics, c.distortion_model, c.distortion_coeffs,
                             {c.width, c.height});
}

// The pixel difference of two cameras at random pixels of `a` (rays through `a`, projected by
// `b`), over the pixels whose rays are at most ~78 degrees off the axis (the fit's domain).
std::vector<double> Differences(const CameraModel& a, const CameraModel& b, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.5, a.width() - 0.5), v(-0.5, a.height() - 0.5);
  std::vector<double> d;
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector2d uv(u(rng), v(rng));
    Eigen::Vector3d ray;
    Eigen::Vector2d uv_b;
    if (!a.Unproject(uv, &ray) || ray.z() <= 0.2 * ray.norm())
      continue;
    d.push_back(b.Project(ray, &uv_b) ? (uv_b - uv).norm() : 1e9);
  }
  return d;
}

const std::vector<double> kOpencv8 = {458.654, 457.296, 367.215, 248.375, -0.2834, 0.07396,
                                      1.9e-4,  1.8e-5,  0.01,    0.02,    -0.03,   0.015};

TEST(KalibrCamera, Opencv4IsPinholeRadtanExactly) {
  const SensorConfig c = MrcalCamera(
      "LENSMODEL_OPENCV4", {458.654, 457.296, 367.215, 248.375, -0.2834, 0.07396, 1.9e-4, 1.8e-5});
  const KalibrCamera k = AsKalibrCamera(c);
  EXPECT_TRUE(k.exact);
  EXPECT_EQ(k.camera.camera_model, "pinhole");
  EXPECT_EQ(k.camera.distortion_model, "radtan");
  EXPECT_EQ(KalibrCameraNote("camchain.yaml", k), "");
  const std::vector<double> d = Differences(ModelOf(c), ModelOf(k.camera), 1);
  ASSERT_GT(d.size(), 1000u);
  EXPECT_LT(*std::max_element(d.begin(), d.end()), 1e-6);
}

TEST(KalibrCamera, RationalLensIsFittedAndItsStatedErrorHoldsAtOtherPixels) {
  const SensorConfig c = MrcalCamera("LENSMODEL_OPENCV8", kOpencv8);
  const KalibrCamera k = AsKalibrCamera(c);
  EXPECT_FALSE(k.exact);
  EXPECT_EQ(k.camera.camera_model, "pinhole");
  EXPECT_EQ(k.camera.distortion_model, "radtan");
  EXPECT_EQ(k.lens, "LENSMODEL_OPENCV8");
  EXPECT_GT(k.points, 1000);
  std::printf("fit: RMS %.4f px, max %.4f px over %d pixels\n", k.rms_px, k.max_px, k.points);
  // The rational terms here bend the image edge by a few pixels; radtan absorbs most of it.
  EXPECT_LT(k.rms_px, 0.5);
  EXPECT_GE(k.max_px, k.rms_px);
  // Without the fit (the lens's own k1 k2 p1 p2 alone) the error is far larger: the fit did work.
  SensorConfig truncated = c;
  truncated.camera_model = "pinhole";
  truncated.distortion_model = "radtan";
  truncated.intrinsics = {kOpencv8.begin(), kOpencv8.begin() + 4};
  truncated.distortion_coeffs = {kOpencv8.begin() + 4, kOpencv8.begin() + 8};
  const std::vector<double> raw = Differences(ModelOf(c), ModelOf(truncated), 2);
  const std::vector<double> d = Differences(ModelOf(c), ModelOf(k.camera), 2);
  ASSERT_GT(d.size(), 1000u);
  double sq = 0.0, sq_raw = 0.0;
  for (std::size_t i = 0; i < d.size(); ++i) {
    sq += d[i] * d[i];
    sq_raw += raw[i] * raw[i];
  }
  const double rms = std::sqrt(sq / d.size()), rms_raw = std::sqrt(sq_raw / raw.size());
  EXPECT_LT(rms, 0.2 * rms_raw) << "fit " << rms << " px, the lens's own terms " << rms_raw;
  // The stated error is the error at pixels the fit did not see.
  EXPECT_NEAR(rms, k.rms_px, 0.25 * k.rms_px + 1e-3);
  EXPECT_LE(*std::max_element(d.begin(), d.end()), 1.1 * k.max_px + 1e-3);
}

TEST(KalibrCamera, EveryExportWritesTheStandInAndNotesTheFit) {
  std::vector<std::string> warnings;
  RigConfig rig = LoadRig(std::string(CTCAL_SOURCE_DIR) + "/configs/example_rig.yaml", &warnings);
  SensorConfig& cam0 = *rig.Find("cam0");
  const SensorConfig mrcal = MrcalCamera("LENSMODEL_OPENCV8", kOpencv8);
  cam0.camera_model = mrcal.camera_model;
  cam0.distortion_model = mrcal.distortion_model;
  cam0.intrinsics = mrcal.intrinsics;
  cam0.distortion_coeffs.clear();
  cam0.width = mrcal.width;
  cam0.height = mrcal.height;
  const KalibrCamera k = AsKalibrCamera(cam0);

  std::vector<std::string> notes;
  const YAML::Node camchain = YAML::Load(EmitKalibrCamchain(rig, {}, &notes));
  EXPECT_EQ(camchain["cam0"]["camera_model"].as<std::string>(), "pinhole");
  EXPECT_EQ(camchain["cam0"]["distortion_model"].as<std::string>(), "radtan");
  for (int i = 0; i < 4; ++i) {
    EXPECT_DOUBLE_EQ(camchain["cam0"]["intrinsics"][i].as<double>(),
                     k.camera.intrinsics[static_cast<std::size_t>(i)]);
    EXPECT_DOUBLE_EQ(camchain["cam0"]["distortion_coeffs"][i].as<double>(),
                     k.camera.distortion_coeffs[static_cast<std::size_t>(i)]);
  }
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("camchain-imucam.yaml: cam0's mrcal LENSMODEL_OPENCV8 written as its "
                          "nearest pinhole-radtan"),
            std::string::npos)
      << notes[0];

  std::string why;
  notes.clear();
  const std::optional<std::string> imucam = EmitOpenVinsImucamChain(rig, &why, &notes);
  ASSERT_TRUE(imucam.has_value()) << why;
  EXPECT_EQ(YAML::Load(*imucam)["cam0"]["distortion_model"].as<std::string>(), "radtan");
  const std::optional<std::string> basalt = EmitBasaltCalibration(rig, &why, &notes);
  ASSERT_TRUE(basalt.has_value()) << why;
  EXPECT_NE(basalt->find("pinhole-radtan8"), std::string::npos);
  ASSERT_EQ(notes.size(), 2u);
  EXPECT_EQ(notes[0].rfind("kalibr_imucam_chain.yaml: cam0's mrcal", 0), 0u) << notes[0];
  EXPECT_EQ(notes[1].rfind("calibration.json: cam0's mrcal", 0), 0u) << notes[1];
}

}  // namespace
}  // namespace ctcal
