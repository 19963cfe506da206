// The report's distortion field (report/distortion_field.h) for every camera model of SPEC
// section 4: the pinhole family against the same camera without its coefficients, the others
// against the ideal equidistant lens of their paraxial focal length.
#include "ctcal/report/distortion_field.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "ctcal/sensors/camera_model.h"

namespace ctcal::report {
namespace {

SensorConfig Camera(const std::string& model, std::vector<double> intrinsics,
                    const std::string& distortion, std::vector<double> coeffs) {
  SensorConfig s;
  s.name = "camX";
  s.type = SensorType::kCamera;
  s.camera_model = model;
  s.intrinsics = std::move(intrinsics);
  s.distortion_model = distortion;
  s.distortion_coeffs = std::move(coeffs);
  s.width = 640;
  s.height = 480;
  return s;
}

CameraModel ModelOf(const SensorConfig& s) {
  return CameraModel::Create(s.camera_model, s.intrinsics, s.distortion_model, s.distortion_coeffs,
                             Eigen::Vector2i(s.width, s.height));
}

TEST(DistortionField, RadtanIsTheDisplacementFromTheIdealPinhole) {
  const SensorConfig s =
      Camera("pinhole", {458.0, 457.0, 330.0, 238.0}, "radtan", {-0.28, 0.07, 2e-4, 1e-5});
  const DistortionField d = ComputeDistortionField(s);
  const CameraModel cam = ModelOf(s);
  ASSERT_GT(d.model_uv.size(), 200u);  // 17 x 13 grid, the corners included
  EXPECT_NEAR(d.focal.x(), 458.0, 1e-6);
  EXPECT_NEAR(d.focal.y(), 457.0, 1e-6);
  EXPECT_NEAR(d.principal_point.x(), 330.0, 1e-9);
  for (std::size_t i = 0; i < d.model_uv.size(); ++i) {
    Eigen::Vector3d ray;
    ASSERT_TRUE(cam.Unproject(d.model_uv[i], &ray));
    const Eigen::Vector2d ideal(458.0 * ray.x() / ray.z() + 330.0,
                                457.0 * ray.y() / ray.z() + 238.0);
    EXPECT_NEAR((d.reference_uv[i] - ideal).norm(), 0.0, 1e-6) << i;
  }
  // Barrel distortion (k1 < 0): the image corners move inwards by tens of pixels.
  EXPECT_GT(d.max_magnitude, 20.0);
  EXPECT_LT(d.max_magnitude, 400.0);
  EXPECT_EQ(d.magnitude.cols(), 48);
  EXPECT_EQ(d.magnitude.rows(), 36);
}

TEST(DistortionField, ZeroCoefficientsOrNoDistortionGiveNoField) {
  const DistortionField eq = ComputeDistortionField(
      Camera("pinhole", {300.0, 300.0, 320.0, 240.0}, "equidistant", {0.0, 0.0, 0.0, 0.0}));
  ASSERT_FALSE(eq.model_uv.empty());
  EXPECT_LT(eq.max_magnitude, 1e-6);
  const DistortionField none =
      ComputeDistortionField(Camera("pinhole", {300.0, 300.0, 320.0, 240.0}, "none", {}));
  EXPECT_TRUE(none.model_uv.empty());
}

// Omni, double sphere and EUCM: the reference is the f-theta lens with the paraxial focal length
// (fu / (1 + xi), fu / (1 + xi), fu), so the field vanishes at the principal point and grows
// towards the edge; every reference pixel is the f-theta image of the model's ray.
TEST(DistortionField, WideAngleModelsAgainstTheEquidistantLens) {
  struct Case {
    SensorConfig cam;
    double focal;
  };
  const std::vector<Case> cases = {
      {Camera("omni", {0.8, 500.0, 500.0, 320.0, 240.0}, "none", {}), 500.0 / 1.8},
      {Camera("omni", {0.8, 500.0, 500.0, 320.0, 240.0}, "radtan", {-0.05, 0.01, 0.0, 0.0}),
       500.0 / 1.8},
      {Camera("ds", {-0.2, 0.6, 250.0, 250.0, 320.0, 240.0}, "none", {}), 250.0 / 0.8},
      {Camera("eucm", {0.6, 1.1, 250.0, 250.0, 320.0, 240.0}, "none", {}), 250.0},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.cam.camera_model + "/" + c.cam.distortion_model);
    const DistortionField d = ComputeDistortionField(c.cam);
    ASSERT_GT(d.model_uv.size(), 100u);
    EXPECT_NEAR(d.focal.x(), c.focal, 1e-5 * c.focal);
    EXPECT_NEAR(d.focal.y(), c.focal, 1e-5 * c.focal);
    EXPECT_NEAR(d.principal_point.x(), 320.0, 1e-9);
    EXPECT_NEAR(d.principal_point.y(), 240.0, 1e-9);
    const CameraModel cam = ModelOf(c.cam);
    double near_centre = 0.0, far = 0.0;
    for (std::size_t i = 0; i < d.model_uv.size(); ++i) {
      Eigen::Vector3d ray;
      ASSERT_TRUE(cam.Unproject(d.model_uv[i], &ray));
      const double theta = std::atan2(std::hypot(ray.x(), ray.y()), ray.z());
      const Eigen::Vector2d radial = d.model_uv[i] - d.principal_point;
      const double r_ref = (d.reference_uv[i] - d.principal_point).norm();
      EXPECT_NEAR(r_ref, c.focal * theta, 1e-6 * (1.0 + c.focal * theta)) << i;
      const double dist = radial.norm();
      const double mag = (d.model_uv[i] - d.reference_uv[i]).norm();
      if (dist < 60.0)
        near_centre = std::max(near_centre, mag);
      far = std::max(far, mag);
    }
    EXPECT_LT(near_centre, 0.05 * far);
    EXPECT_GT(far, 1.0);
  }
}

TEST(DistortionField, AnInvalidModelNamesTheSensor) {
  try {
    ComputeDistortionField(Camera("fisheye42", {1.0, 1.0, 1.0, 1.0}, "none", {}));
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("sensors.camX"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ctcal::report
