// mrcal's lens models as ctcal cameras (camera_model mrcal): projection and Jacobians through
// CameraModel against numeric differentiation, unprojection, .cameramodel and rig-file round
// trips, the exports, and the projection difference of two fits (projection_diff.h).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "ctcal/report/lens_fit.h"
#include "ctcal/sensors/camera_model.h"
#include "ctcal/sensors/mrcal_lens.h"
#include "ctcal/sensors/mrcal_model.h"
#include "ctcal/sensors/projection_diff.h"
#include "ctcal/sensors/rig_yaml.h"
#include "ctcal/sim/default_rig.h"

namespace ctcal {
namespace {

const Eigen::Vector2i kSize(752, 480);
const std::string kSpline = "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=12_fov_x_deg=130";

// EuRoC cam0's radtan numbers; rational and thin-prism terms small but not zero.
std::vector<double> Opencv8() {
  return {458.654, 457.296, 367.215, 248.375, -0.2834, 0.07396,
          1.9e-4,  1.8e-5,  0.01,    0.02,    -0.03,   0.015};
}

// A splined lens: a stereographic core and control points of a few tenths of a pixel over f.
std::vector<double> Splined(unsigned seed) {
  const int n = MrcalLens::FromName(kSpline)->NumParams();
  std::vector<double> p(static_cast<std::size_t>(n));
  p[0] = 300.0;
  p[1] = 301.0;
  p[2] = 375.0;
  p[3] = 240.0;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-2e-3, 2e-3);
  for (int i = 4; i < n; ++i)
    p[static_cast<std::size_t>(i)] = u(rng);
  return p;
}

CameraModel Mrcal(const std::string& lensmodel, const std::vector<double>& params) {
  return CameraModel::Create("mrcal", params, lensmodel, {}, kSize);
}

std::vector<CameraModel> TestCameras() {
  return {Mrcal("LENSMODEL_OPENCV8", Opencv8()),
          Mrcal("LENSMODEL_OPENCV5", {458.6, 457.3, 367.2, 248.4, -0.28, 0.07, 2e-4, 2e-5, 0.01}),
          Mrcal("LENSMODEL_OPENCV12", {458.6, 457.3, 367.2, 248.4, -0.28, 0.07, 2e-4, 2e-5, 0.01,
                                       0.02, -0.03, 0.015, 1e-3, -1e-3, 2e-3, 5e-4}),
          Mrcal("LENSMODEL_STEREOGRAPHIC", {300.0, 301.0, 375.0, 240.0}),
          Mrcal("LENSMODEL_LONLAT", {400.0, 401.0, 375.0, 240.0}),
          Mrcal("LENSMODEL_CAHVOR", {458.6, 457.3, 367.2, 248.4, 0.01, -0.02, 0.0, -0.2, 0.05}),
          Mrcal(kSpline, Splined(3))};
}

// Points whose pixels cover the image (rays of pixels on a grid, at random depths).
std::vector<Eigen::Vector3d> PointsOverImage(const CameraModel& camera, int n) {
  std::vector<Eigen::Vector3d> points;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> depth(0.3, 10.0);
  for (int i = 0; i <= n; ++i) {
    for (int j = 0; j <= n; ++j) {
      const Eigen::Vector2d uv(10 + (camera.width() - 20.0) * i / n,
                               10 + (camera.height() - 20.0) * j / n);
      Eigen::Vector3d ray;
      if (camera.Unproject(uv, &ray))
        points.push_back(depth(rng) * ray);
    }
  }
  return points;
}

// d uv / d p_C and d uv / d params through CameraModel against central differences: mrcal's
// analytic gradients reach ctcal's interface in the right layout (row = u or v, column = input).
TEST(MrcalLens, JacobiansMatchCentralDifferences) {
  for (const CameraModel& camera : TestCameras()) {
    SCOPED_TRACE(camera.distortion_model());
    const std::vector<Eigen::Vector3d> points = PointsOverImage(camera, 8);
    ASSERT_GT(points.size(), 60u);
    for (const Eigen::Vector3d& p : points) {
      Eigen::Vector2d uv;
      Eigen::Matrix<double, 2, 3> J_p;
      Eigen::Matrix<double, 2, Eigen::Dynamic> J_params;
      ASSERT_TRUE(camera.Project(p, &uv, &J_p, &J_params));
      ASSERT_EQ(J_params.cols(), camera.NumParams());
      for (int k = 0; k < 3; ++k) {
        const double h = 1e-6 * p.norm();
        Eigen::Vector2d up, um;
        ASSERT_TRUE(camera.Project(p + h * Eigen::Vector3d::Unit(k), &up));
        ASSERT_TRUE(camera.Project(p - h * Eigen::Vector3d::Unit(k), &um));
        const Eigen::Vector2d numeric = (up - um) / (2 * h);
        EXPECT_LT((numeric - J_p.col(k)).norm(), 1e-5 * (1 + J_p.col(k).norm())) << k;
      }
      for (int k = 0; k < camera.NumParams(); ++k) {
        const double h = 1e-6 * std::max(1.0, std::abs(camera.params()(k)));
        Eigen::VectorXd plus = camera.params(), minus = camera.params();
        plus(k) += h;
        minus(k) -= h;
        CameraModel cp = camera, cm = camera;
        cp.SetParams(plus);
        cm.SetParams(minus);
        Eigen::Vector2d up, um;
        ASSERT_TRUE(cp.Project(p, &up));
        ASSERT_TRUE(cm.Project(p, &um));
        const Eigen::Vector2d numeric = (up - um) / (2 * h);
        EXPECT_LT((numeric - J_params.col(k)).norm(), 1e-5 * (1 + J_params.col(k).norm()))
            << camera.ParamNames()[static_cast<std::size_t>(k)];
      }
    }
  }
}

// Unproject then project returns the pixel over the whole image (mrcal_unproject, checked).
TEST(MrcalLens, UnprojectionRoundTrips) {
  for (const CameraModel& camera : TestCameras()) {
    SCOPED_TRACE(camera.distortion_model());
    double worst = 0.0;
    int n = 0;
    for (int i = 0; i <= 30; ++i) {
      for (int j = 0; j <= 20; ++j) {
        const Eigen::Vector2d uv(-0.5 + camera.width() * i / 30.0,
                                 -0.5 + camera.height() * j / 20.0);
        Eigen::Vector3d ray;
        ASSERT_TRUE(camera.Unproject(uv, &ray)) << uv.transpose();
        Eigen::Vector2d back;
        ASSERT_TRUE(camera.Project(ray, &back));
        worst = std::max(worst, (back - uv).norm());
        ++n;
      }
    }
    EXPECT_LT(worst, 1e-6);
  }
}

TEST(MrcalLens, DomainAndBadInput) {
  const CameraModel opencv = Mrcal("LENSMODEL_OPENCV8", Opencv8());
  Eigen::Vector2d uv;
  EXPECT_FALSE(opencv.Project(Eigen::Vector3d(0.1, 0.1, -1.0), &uv));  // behind a pinhole lens
  const CameraModel spline = Mrcal(kSpline, Splined(1));
  EXPECT_TRUE(spline.Project(Eigen::Vector3d(0.1, 0.1, 1.0), &uv));
  EXPECT_FALSE(spline.Project(Eigen::Vector3d(1.0, 0.0, 0.05), &uv));  // beyond the knots
  EXPECT_EQ(spline.ParamNames()[4], "x[0,0]");
  EXPECT_EQ(spline.ParamNames()[7], "y[1,0]");
  EXPECT_EQ(opencv.ParamNames()[8], "k3");
  EXPECT_EQ(opencv.camera_model(), "mrcal");
  EXPECT_EQ(opencv.intrinsics().size(), 12u);
  EXPECT_TRUE(opencv.distortion_coeffs().empty());

  auto message = [](auto&& f) {
    try {
      f();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message([] {
              Mrcal("LENSMODEL_OPENCV8", {1, 2, 3});
            }),
            "mrcal lens model LENSMODEL_OPENCV8 needs 12 intrinsics, got 3");
  EXPECT_EQ(message([] {
              Mrcal("LENSMODEL_PINHOLE", {-1, 2, 3, 4});
            }),
            "mrcal lens model LENSMODEL_PINHOLE: focal lengths fx, fy must be > 0");
  EXPECT_EQ(message([] {
              CameraModel::Create("mrcal", {1, 1, 1, 1}, "LENSMODEL_PINHOLE", {0.1},
                                  Eigen::Vector2i(10, 10));
            }),
            "camera model 'mrcal' takes all of mrcal's parameters as intrinsics; "
            "distortion_coeffs must be empty, got 1");
  EXPECT_EQ(message([] {
              MrcalLens::FromName(
                  "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=2_"
                  "Ny=10_fov_x_deg=100");
            }),
            "mrcal lens model 'LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=2_Ny=10_fov_x_deg=100': "
            "a splined model needs order 2 or 3, Nx and Ny >= order + 2 and 0 < fov_x_deg < 360");
}

// Every mrcal model round-trips through a .cameramodel bit for bit, and mrcal's own C reader
// agrees with what we wrote.
TEST(MrcalLens, CameraModelFileRoundTripIsExact) {
  MrcalRt rt;
  rt << 0.1 / 3, -0.2, 0.3, 1.0 / 7, -2.5, 0.125;
  for (const CameraModel& camera : TestCameras()) {
    SCOPED_TRACE(camera.distortion_model());
    const std::string path = ::testing::TempDir() + "/ctcal_mrcal_lens.cameramodel";
    SaveMrcalCameraModel(path, camera, rt);
    const MrcalCameraModel back = LoadMrcalCameraModel(path);
    EXPECT_EQ(back.camera.type(), CameraModelType::kMrcal);
    EXPECT_EQ(back.camera.distortion_model(), camera.distortion_model());
    EXPECT_EQ(back.camera.resolution(), camera.resolution());
    ASSERT_EQ(back.camera.NumParams(), camera.NumParams());
    for (int i = 0; i < camera.NumParams(); ++i)
      EXPECT_EQ(back.camera.params()(i), camera.params()(i)) << i;
    for (int i = 0; i < 6; ++i)
      EXPECT_EQ(back.rt_cam_ref(i), rt(i));
    std::remove(path.c_str());
  }
}

// A rig file with camera_model mrcal reads back exactly, and its camera builds.
TEST(MrcalLens, RigFileRoundTrip) {
  const std::string text = R"(base_imu: cam0
target: {target_type: aprilgrid, tagCols: 6, tagRows: 6, tagSize: 0.088, tagSpacing: 0.3}
sensors:
  cam0:
    type: camera
    camera_model: mrcal
    lensmodel: LENSMODEL_OPENCV8
    intrinsics: [458.654, 457.296, 367.215, 248.375, -0.2834, 0.07396, 1.9e-4, 1.8e-5, 0.01, 0.02, -0.03, 0.015]
    resolution: [752, 480]
    estimate: [intrinsics]
)";
  const std::string path = ::testing::TempDir() + "/ctcal_mrcal_rig.yaml";
  {
    std::ofstream f(path);
    f << text;
  }
  std::vector<std::string> warnings;
  const RigConfig rig = LoadRig(path, &warnings);
  const SensorConfig& s = *rig.Find("cam0");
  EXPECT_EQ(s.camera_model, "mrcal");
  EXPECT_EQ(s.distortion_model, "LENSMODEL_OPENCV8");
  EXPECT_EQ(s.intrinsics, Opencv8());
  SaveRig(rig, path);
  const RigConfig back = LoadRig(path, &warnings);
  EXPECT_EQ(back.Find("cam0")->intrinsics, Opencv8());
  EXPECT_EQ(back.Find("cam0")->distortion_model, "LENSMODEL_OPENCV8");

  // Bad input names the sensor and the problem.
  auto error = [&](const std::string& replace_from, const std::string& replace_to) {
    std::string bad = text;
    bad.replace(bad.find(replace_from), replace_from.size(), replace_to);
    std::ofstream(path) << bad;
    try {
      LoadRig(path, &warnings);
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error("LENSMODEL_OPENCV8", "LENSMODEL_OPENCV9")
                .find("unknown mrcal lens model "
                      "'LENSMODEL_OPENCV9'"),
            std::string::npos);
  EXPECT_NE(error(", 0.015]", "]").find("intrinsics of LENSMODEL_OPENCV8 are 12 numbers, got 11"),
            std::string::npos);
  EXPECT_NE(
      error("    lensmodel: LENSMODEL_OPENCV8\n", "").find("camera_model mrcal needs 'lensmodel'"),
      std::string::npos);
  std::remove(path.c_str());
}

// The exports write one .cameramodel per camera mrcal can hold (cam0 identity extrinsics, cam1
// T_C1_C0), and say why not for the others.
TEST(MrcalLens, ExportsEveryCameraMrcalHas) {
  RigConfig rig;
  rig.base_imu = "cam0";
  auto camera = [](const std::string& name, const std::string& model,
                   const std::vector<double>& intrinsics, const std::string& distortion,
                   const std::vector<double>& coeffs) {
    SensorConfig s;
    s.name = name;
    s.type = SensorType::kCamera;
    s.camera_model = model;
    s.intrinsics = intrinsics;
    s.distortion_model = distortion;
    s.distortion_coeffs = coeffs;
    s.width = kSize.x();
    s.height = kSize.y();
    return s;
  };
  rig.sensors.push_back(camera("cam0", "mrcal", Splined(5), kSpline, {}));
  rig.sensors.push_back(
      camera("cam1", "pinhole", {458, 457, 367, 248}, "radtan", {-0.28, 0.07, 2e-4, 2e-5}));
  rig.sensors.push_back(camera("cam2", "eucm", {0.6, 1.1, 380, 382, 376, 240}, "none", {}));
  Eigen::Isometry3d T_B_C1 = Eigen::Isometry3d::Identity();
  T_B_C1.linear() = Eigen::AngleAxisd(0.1, Eigen::Vector3d(0.2, 1, 0).normalized()).matrix();
  T_B_C1.translation() << 0.11, -0.002, 0.003;
  rig.sensors[1].T_B_S = T_B_C1.matrix();
  const std::string dir = ::testing::TempDir() + "/ctcal_mrcal_exports";
  std::filesystem::create_directories(dir);
  std::vector<std::string> notes;
  const std::vector<std::string> written = SaveMrcalCameraModels(rig, dir, &notes);
  ASSERT_EQ(written.size(), 2u);
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_EQ(notes[0].rfind("cam2.cameramodel not written: camera model 'eucm'", 0), 0u);
  const MrcalCameraModel m0 = LoadMrcalCameraModel(dir + "/cam0.cameramodel");
  const MrcalCameraModel m1 = LoadMrcalCameraModel(dir + "/cam1.cameramodel");
  EXPECT_EQ(m0.camera.distortion_model(), kSpline);
  EXPECT_EQ(m0.rt_cam_ref, MrcalRt::Zero());
  EXPECT_EQ(m1.camera.type(), CameraModelType::kPinholeRadtan);
  EXPECT_TRUE(TransformFromMrcalRt(m1.rt_cam_ref).isApprox(T_B_C1.inverse(), 1e-14));
  std::filesystem::remove_all(dir);
}

// The same lens in two models (pinhole-radtan and mrcal's OPENCV8 with its extra terms zero)
// differs by nothing. A focal length 0.2 % longer differs by exactly 0.002 |q - c| at every grid
// point (no rotation can absorb a scale, and with c at the image centre the grid is symmetric, so
// the fitted rotation is the identity). A lon-lat lens whose cx moves by 2 px is the same lens
// turned by 2 / fx rad about y: 2 px apart in the given frames, 0 after the fitted rotation,
// which is that turn.
TEST(ProjectionDiff, SameLensZeroKnownPerturbationKnownDifference) {
  const std::vector<double> k = {458.654, 457.296, 367.215, 248.375};
  const std::vector<double> d = {-0.2834, 0.07396, 1.9e-4, 1.8e-5};
  const CameraModel radtan = CameraModel::Create("pinhole", k, "radtan", d, kSize);
  std::vector<double> opencv8 = k;
  opencv8.insert(opencv8.end(), d.begin(), d.end());
  opencv8.resize(12, 0.0);
  const ProjectionDiff same = DiffProjections(radtan, Mrcal("LENSMODEL_OPENCV8", opencv8));
  EXPECT_LT(same.max_px, 1e-6);
  EXPECT_LT(same.rotation_deg, 1e-6);
  EXPECT_EQ(same.points, static_cast<int>(same.diff_px.size()));

  const double cx = 0.5 * (kSize.x() - 1), cy = 0.5 * (kSize.y() - 1);
  const CameraModel pinhole = CameraModel::Create("pinhole", {500, 500, cx, cy}, "none", {}, kSize);
  const double s = 0.002;
  const CameraModel longer = Mrcal("LENSMODEL_PINHOLE", {500 * (1 + s), 500 * (1 + s), cx, cy});
  const ProjectionDiff scaled = DiffProjections(pinhole, longer);
  EXPECT_LT(scaled.rotation_deg, 1e-9);
  double expected_mean = 0.0, expected_max = 0.0;
  const int ny = static_cast<int>(scaled.diff_px.rows()),
            nx = static_cast<int>(scaled.diff_px.cols());
  for (int r = 0; r < ny; ++r) {
    for (int c = 0; c < nx; ++c) {
      const Eigen::Vector2d q(-0.5 + kSize.x() * (c + 0.5) / nx, -0.5 + kSize.y() * (r + 0.5) / ny);
      const double e = s * (q - Eigen::Vector2d(cx, cy)).norm();
      EXPECT_NEAR(scaled.diff_px(r, c), e, 1e-9);
      expected_mean += e / (nx * ny);
      expected_max = std::max(expected_max, e);
    }
  }
  EXPECT_NEAR(scaled.mean_px, expected_mean, 1e-9);
  EXPECT_NEAR(scaled.max_px, expected_max, 1e-9);

  const CameraModel lonlat = Mrcal("LENSMODEL_LONLAT", {400, 401, cx, cy});
  const CameraModel turned = Mrcal("LENSMODEL_LONLAT", {400, 401, cx + 2.0, cy});
  ProjectionDiffOptions no_fit;
  no_fit.fit_rotation = false;
  const ProjectionDiff given = DiffProjections(lonlat, turned, no_fit);
  EXPECT_NEAR(given.mean_px, 2.0, 1e-9);
  EXPECT_NEAR(given.max_px, 2.0, 1e-9);
  const ProjectionDiff fitted = DiffProjections(lonlat, turned);
  EXPECT_LT(fitted.max_px, 1e-6);
  EXPECT_NEAR(fitted.rotation_deg, 2.0 / 400 * 180 / M_PI, 1e-7);

  // The observed part: only the cells holding an observed pixel count.
  ProjectionDiffOptions centre;
  for (int i = -4; i <= 4; ++i)
    for (int j = -4; j <= 4; ++j)
      centre.observed.emplace_back(cx + 10 * i, cy + 10 * j);
  const ProjectionDiff inner = DiffProjections(pinhole, longer, centre);
  EXPECT_GT(inner.points, 3);
  EXPECT_LT(inner.points, scaled.points / 10);
  EXPECT_LT(inner.max_px, s * 80);  // cells of 12.5 px around +-40 px
  centre.observed = {Eigen::Vector2d(376, 240)};
  EXPECT_THROW(DiffProjections(pinhole, longer, centre), std::invalid_argument);
  EXPECT_THROW(DiffProjections(pinhole, CameraModel::Create("pinhole", {500, 500, 10, 10}, "none",
                                                            {}, Eigen::Vector2i(20, 20))),
               std::invalid_argument);
}

// The lens-fit diagnosis (lens_fit.h) on synthetic residuals of a 752 x 480 pinhole-radtan camera:
// pure 0.3 px noise shows no pattern; the same noise plus a radial error growing to 1.5 px at the
// image corners (what a lens the model does not fit leaves) is significant, strongest at the
// border, and names a splined mrcal model whose knots hold the whole image.
TEST(LensFit, RadialPatternIsSignificantNoiseIsNot) {
  const SensorConfig cam = *sim::DefaultRig().Find("cam0");  // EuRoC's cam0
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.5, cam.width - 0.5), v(-0.5, cam.height - 0.5);
  std::normal_distribution<double> noise(0.0, 0.3);
  const Eigen::Vector2d c(375.5, 239.5);
  const double r_corner = c.norm();
  std::vector<report::CornerResidual> plain, pattern;
  for (int i = 0; i < 40000; ++i) {
    report::CornerResidual r;
    r.u = u(rng);
    r.v = v(rng);
    r.du = noise(rng);
    r.dv = noise(rng);
    plain.push_back(r);
    const Eigen::Vector2d d = Eigen::Vector2d(r.u, r.v) - c;
    const double rho = d.norm() / r_corner;
    r.du += 1.5 * rho * rho * rho * d.x() / std::max(d.norm(), 1e-9);
    r.dv += 1.5 * rho * rho * rho * d.y() / std::max(d.norm(), 1e-9);
    pattern.push_back(r);
  }
  const report::LensFitDiagnosis none = report::DiagnoseLensFit(cam, plain);
  EXPECT_FALSE(none.significant) << none.chi2 << " / " << none.dof << " p " << none.p_value;
  EXPECT_GT(none.p_value, 1e-3);
  EXPECT_NEAR(none.noise_px, 0.3, 0.01);
  EXPECT_TRUE(none.suggestion.empty());

  const report::LensFitDiagnosis bad = report::DiagnoseLensFit(cam, pattern);
  EXPECT_TRUE(bad.significant);
  EXPECT_LT(bad.p_value, 1e-12);
  EXPECT_NEAR(bad.noise_px, 0.3, 0.02);  // within-cell scatter: the pattern does not inflate it
  EXPECT_GT(bad.border_mean_px, 2.0 * bad.inner_mean_px);
  EXPECT_GT(bad.max_mean_px, 1.0);
  const std::string model = report::SuggestedSplinedModel(cam);
  EXPECT_NE(bad.suggestion.find(model), std::string::npos) << bad.suggestion;
  // The suggested spline's knots hold every pixel's ray of this camera.
  const CameraModel radtan = CameraModel::Create(
      cam.camera_model, cam.intrinsics, cam.distortion_model, cam.distortion_coeffs, kSize);
  const auto lens = MrcalLens::FromName(model);
  Eigen::VectorXd p = Eigen::VectorXd::Zero(lens->NumParams());
  p.head<4>() << 300, 300, 375.5, 239.5;
  for (int i = 0; i <= 20; ++i) {
    for (int j = 0; j <= 20; ++j) {
      Eigen::Vector3d ray;
      Eigen::Vector2d q;
      ASSERT_TRUE(radtan.Unproject(
          Eigen::Vector2d(-0.5 + cam.width * i / 20.0, -0.5 + cam.height * j / 20.0), &ray));
      EXPECT_TRUE(lens->Project(p.data(), ray, &q)) << i << " " << j;
    }
  }
  std::printf("suggested %s; chi2 %.0f / %d; border %.3f inner %.3f px\n", model.c_str(), bad.chi2,
              bad.dof, bad.border_mean_px, bad.inner_mean_px);
}

}  // namespace
}  // namespace ctcal
