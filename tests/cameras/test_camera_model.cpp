// The runtime CameraModel: the factory from a rig file's fields and its errors, the dispatch to
// the model structs, the image bounds and the rolling-shutter row time.
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "ctcal/sensors/camera_model.h"

namespace ctcal {
namespace {

struct RigFields {
  std::string camera_model;
  std::vector<double> intrinsics;
  std::string distortion_model;
  std::vector<double> distortion_coeffs;
};

// One valid set of rig-file fields per type of SPEC section 4.
std::vector<std::pair<CameraModelType, RigFields>> ValidFields() {
  return {
      {CameraModelType::kPinholeRadtan,
       {"pinhole", {458.654, 457.296, 367.215, 248.375}, "radtan", {-0.28, 0.07, 0.0002, 1.7e-5}}},
      {CameraModelType::kPinholeEquidistant,
       {"pinhole", {190.9, 190.9, 254.9, 256.8}, "equidistant", {0.0034, 0.0007, -0.002, 0.0002}}},
      {CameraModelType::kPinholeNone, {"pinhole", {400, 410, 320, 240}, "none", {}}},
      {CameraModelType::kOmniRadtan,
       {"omni", {0.9, 600, 602, 376, 240}, "radtan", {-0.1, 0.02, 0.0005, -0.0003}}},
      {CameraModelType::kOmniNone, {"omni", {1.5, 600, 600, 376, 240}, "none", {}}},
      {CameraModelType::kDoubleSphere,
       {"ds", {-0.18, 0.59, 158.3, 158.3, 254.9, 256.9}, "none", {}}},
      {CameraModelType::kEucm, {"eucm", {0.59, 1.13, 460.8, 459.4, 365.9, 249.3}, "none", {}}},
  };
}

std::string CreateError(const RigFields& f, Eigen::Vector2i resolution = {640, 480}) {
  try {
    CameraModel::Create(f.camera_model, f.intrinsics, f.distortion_model, f.distortion_coeffs,
                        resolution);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "no error";
}

TEST(CameraModelFactory, CreatesEveryModelOfTheSpec) {
  for (const auto& entry : ValidFields()) {
    // Not a structured binding: the lambda below reads f (C++17 cannot capture a binding).
    const CameraModelType type = entry.first;
    const auto& f = entry.second;
    const CameraModel cam = CameraModel::Create(f.camera_model, f.intrinsics, f.distortion_model,
                                                f.distortion_coeffs, Eigen::Vector2i(640, 480));
    EXPECT_EQ(cam.type(), type);
    EXPECT_EQ(cam.camera_model(), f.camera_model);
    EXPECT_EQ(cam.distortion_model(), f.distortion_model);
    EXPECT_EQ(cam.intrinsics(), f.intrinsics);
    EXPECT_EQ(cam.distortion_coeffs(), f.distortion_coeffs);
    EXPECT_EQ(cam.NumIntrinsics(), static_cast<int>(f.intrinsics.size()));
    EXPECT_EQ(cam.NumDistortionCoeffs(), static_cast<int>(f.distortion_coeffs.size()));
    EXPECT_EQ(cam.NumParams(), static_cast<int>(f.intrinsics.size() + f.distortion_coeffs.size()));
    EXPECT_EQ(static_cast<int>(cam.ParamNames().size()), cam.NumParams());
    EXPECT_EQ(ParseCameraModelType(f.camera_model, f.distortion_model), type);
    EXPECT_EQ(cam.width(), 640);
    EXPECT_EQ(cam.height(), 480);
  }
}

TEST(CameraModelFactory, ParameterNamesFollowKalibr) {
  const auto names = [](CameraModelType type) {
    return VisitCameraModel(type, [](auto model) {
      const auto n = decltype(model)::ParamNames();
      return std::vector<std::string>(n.begin(), n.end());
    });
  };
  using V = std::vector<std::string>;
  EXPECT_EQ(names(CameraModelType::kPinholeRadtan),
            (V{"fu", "fv", "pu", "pv", "k1", "k2", "r1", "r2"}));
  EXPECT_EQ(names(CameraModelType::kPinholeEquidistant),
            (V{"fu", "fv", "pu", "pv", "k1", "k2", "k3", "k4"}));
  EXPECT_EQ(names(CameraModelType::kOmniRadtan),
            (V{"xi", "fu", "fv", "pu", "pv", "k1", "k2", "r1", "r2"}));
  EXPECT_EQ(names(CameraModelType::kDoubleSphere), (V{"xi", "alpha", "fu", "fv", "pu", "pv"}));
  EXPECT_EQ(names(CameraModelType::kEucm), (V{"alpha", "beta", "fu", "fv", "pu", "pv"}));
}

TEST(CameraModelFactory, WrongCountsAreClearErrors) {
  EXPECT_EQ(CreateError({"pinhole", {458, 457, 367, 248}, "radtan", {-0.28, 0.07, 0.0002}}),
            "camera model 'pinhole' with distortion 'radtan' needs 4 distortion_coeffs, got 3");
  EXPECT_EQ(CreateError({"pinhole", {458, 457, 367}, "none", {}}),
            "camera model 'pinhole' with distortion 'none' needs 4 intrinsics, got 3");
  EXPECT_EQ(CreateError({"omni", {458, 457, 367, 248}, "none", {}}),
            "camera model 'omni' with distortion 'none' needs 5 intrinsics, got 4");
  EXPECT_EQ(CreateError({"ds", {-0.2, 0.6, 158, 158, 254, 256}, "none", {0.1}}),
            "camera model 'ds' with distortion 'none' needs 0 distortion_coeffs, got 1");
  EXPECT_EQ(CreateError({"eucm", {0.6, 1.1, 460, 459, 365}, "none", {}}),
            "camera model 'eucm' with distortion 'none' needs 6 intrinsics, got 5");
}

TEST(CameraModelFactory, UnknownNamesAreClearErrors) {
  EXPECT_EQ(CreateError({"fisheye", {1, 1, 1, 1}, "none", {}}),
            "unknown camera_model 'fisheye' (expected pinhole, omni, ds, eucm or mrcal)");
  EXPECT_EQ(CreateError({"pinhole", {1, 1, 1, 1}, "equi", {0, 0, 0, 0}}),
            "camera model 'pinhole' does not take distortion_model 'equi' (expected radtan, "
            "equidistant, none)");
  EXPECT_EQ(CreateError({"omni", {1, 1, 1, 1, 1}, "equidistant", {0, 0, 0, 0}}),
            "camera model 'omni' does not take distortion_model 'equidistant' (expected radtan, "
            "none)");
  EXPECT_EQ(CreateError({"ds", {0, 0.5, 1, 1, 1, 1}, "radtan", {0, 0, 0, 0}}),
            "camera model 'ds' does not take distortion_model 'radtan' (expected none)");
}

TEST(CameraModelFactory, ParametersOutsideTheDomainAreClearErrors) {
  EXPECT_EQ(CreateError({"pinhole", {-458, 457, 367, 248}, "none", {}}),
            "camera model 'pinhole' with distortion 'none': focal lengths fu, fv must be "
            "positive, got -458, 457");
  EXPECT_EQ(CreateError({"omni", {-0.1, 600, 600, 376, 240}, "none", {}}),
            "camera model 'omni' with distortion 'none': omni xi must be >= 0, got -0.1");
  EXPECT_EQ(CreateError({"ds", {-0.2, 1.5, 158, 158, 254, 256}, "none", {}}),
            "camera model 'ds' with distortion 'none': ds needs xi in [-1, 1] and alpha in [0, 1], "
            "got xi -0.2, alpha 1.5");
  EXPECT_EQ(CreateError({"eucm", {0.6, 0.0, 460, 459, 365, 249}, "none", {}}),
            "camera model 'eucm' with distortion 'none': eucm needs alpha in [0, 1] and beta > 0, "
            "got alpha 0.6, beta 0");
  EXPECT_EQ(CreateError({"pinhole", {458, 457, std::nan(""), 248}, "none", {}}),
            "camera model 'pinhole' with distortion 'none': parameter 2 is not finite");
  EXPECT_EQ(CreateError({"pinhole", {458, 457, 367, 248}, "none", {}}, Eigen::Vector2i(0, 480)),
            "camera resolution must be [width, height] > 0, got [0, 480]");

  CameraModel cam =
      CameraModel::Create("pinhole", {400, 410, 320, 240}, "none", {}, Eigen::Vector2i(640, 480));
  EXPECT_THROW(cam.SetParams(Eigen::Vector3d(1, 2, 3)), std::invalid_argument);
  EXPECT_THROW(cam.SetParams(Eigen::Vector4d(0, 410, 320, 240)), std::invalid_argument);
  cam.SetParams(Eigen::Vector4d(500, 510, 321, 241));
  EXPECT_EQ(cam.params(), Eigen::Vector4d(500, 510, 321, 241));
}

// The runtime class and the visitor reach the same model struct: identical projections,
// Jacobians and unprojections.
TEST(CameraModel, RuntimeDispatchEqualsModelStructs) {
  const Eigen::Vector3d p_C(0.3, -0.2, 1.7);
  for (const auto& entry : ValidFields()) {
    // Not a structured binding: the lambda below reads f (C++17 cannot capture a binding).
    const CameraModelType type = entry.first;
    const auto& f = entry.second;
    const CameraModel cam = CameraModel::Create(f.camera_model, f.intrinsics, f.distortion_model,
                                                f.distortion_coeffs, Eigen::Vector2i(640, 480));
    Eigen::Vector2d uv;
    Eigen::Matrix<double, 2, 3> J_uv_p;
    Eigen::Matrix<double, 2, Eigen::Dynamic> J_uv_params;
    ASSERT_TRUE(cam.Project(p_C, &uv, &J_uv_p, &J_uv_params));
    ASSERT_EQ(J_uv_params.cols(), cam.NumParams());
    VisitCameraModel(type, [&](auto model) {
      using Model = decltype(model);
      ASSERT_EQ(Model::kNumParams, cam.NumParams());
      EXPECT_EQ(Model::kCameraModel, f.camera_model);
      Eigen::Vector2d uv_direct;
      Eigen::Matrix<double, 2, Model::kNumParams> J_direct;
      ASSERT_TRUE(Model::Project(cam.params().data(), p_C, &uv_direct, nullptr, &J_direct));
      EXPECT_EQ(uv_direct, uv);
      EXPECT_EQ(Eigen::MatrixXd(J_direct), Eigen::MatrixXd(J_uv_params));
    });
    Eigen::Vector3d ray;
    ASSERT_TRUE(cam.Unproject(uv, &ray));
    EXPECT_LT((ray - p_C.normalized()).norm(), 1e-11);
    Eigen::Vector2d uv_only;
    ASSERT_TRUE(cam.Project(p_C, &uv_only));
    EXPECT_EQ(uv_only, uv);
  }
}

TEST(CameraModel, IsInImageUsesPixelCentreConvention) {
  const CameraModel cam =
      CameraModel::Create("pinhole", {400, 410, 320, 240}, "none", {}, Eigen::Vector2i(640, 480));
  EXPECT_TRUE(cam.IsInImage({0.0, 0.0}));
  EXPECT_TRUE(cam.IsInImage({-0.5, -0.5}));
  EXPECT_TRUE(cam.IsInImage({639.5, 479.5}));
  EXPECT_FALSE(cam.IsInImage({-0.51, 10}));
  EXPECT_FALSE(cam.IsInImage({10, 479.51}));
  EXPECT_FALSE(cam.IsInImage({639.6, 10}));
  EXPECT_FALSE(cam.IsInImage({std::nan(""), 10}));
  EXPECT_TRUE(cam.IsInImage({10, 10}, 10.5));
  EXPECT_FALSE(cam.IsInImage({9.9, 10}, 10.5));
  EXPECT_FALSE(cam.IsInImage({629.1, 10}, 10.5));
}

// SPEC section 2: t = t_S + v * line_delay, differentiable in line_delay and t_S.
TEST(RollingShutter, RowTime) {
  EXPECT_DOUBLE_EQ(RollingShutterRowTime(10.0, 240.0, 3e-5), 10.0 + 240.0 * 3e-5);
  EXPECT_DOUBLE_EQ(RollingShutterRowTime(10.0, 0.0, 3e-5), 10.0);
  EXPECT_DOUBLE_EQ(RollingShutterRowTime(10.0, 479.0, 0.0), 10.0);
  using Jet = ceres::Jet<double, 2>;
  const Jet t = RollingShutterRowTime(Jet(10.0, 0), 240.0, Jet(3e-5, 1));
  EXPECT_DOUBLE_EQ(t.a, 10.0 + 240.0 * 3e-5);
  EXPECT_DOUBLE_EQ(t.v(0), 1.0);
  EXPECT_DOUBLE_EQ(t.v(1), 240.0);
}

}  // namespace
}  // namespace ctcal
