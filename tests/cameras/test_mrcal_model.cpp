// mrcal interoperability: our projection against mrcal's own C implementation, and .cameramodel
// files written by us, by mrcal's C writer, and in the layout mrcal's Python writer uses.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <random>
#include <vector>

#include "ctcal/sensors/mrcal_model.h"

extern "C" {
#include <mrcal/mrcal.h>
}

namespace ctcal {
namespace {

constexpr double kPi = 3.14159265358979323846;

CameraModel EurocCam0() {
  return CameraModel::Create("pinhole", {458.654, 457.296, 367.215, 248.375}, "radtan",
                             {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05},
                             Eigen::Vector2i(752, 480));
}

CameraModel PlainPinhole() {
  return CameraModel::Create("pinhole", {1761.181055, 1761.250444, 1965.706996, 1087.518797},
                             "none", {}, Eigen::Vector2i(3840, 2160));
}

mrcal_lensmodel_t MrcalLens(const CameraModel& camera) {
  mrcal_lensmodel_t lens;
  std::memset(&lens, 0, sizeof(lens));
  lens.type = camera.type() == CameraModelType::kPinholeRadtan ? MRCAL_LENSMODEL_OPENCV4
                                                               : MRCAL_LENSMODEL_PINHOLE;
  return lens;
}

std::vector<Eigen::Vector3d> PointsInView(double max_angle, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> angle(0.0, max_angle), azimuth(-kPi, kPi),
      range(0.2, 20.0);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < n; ++i) {
    const double t = angle(rng), a = azimuth(rng), r = range(rng);
    points.emplace_back(r * std::sin(t) * std::cos(a), r * std::sin(t) * std::sin(a),
                        r * std::cos(t));
  }
  return points;
}

// Our projection, point Jacobian and intrinsics Jacobian equal mrcal_project's for both shared
// lens models, points up to 50 degrees off axis.
TEST(MrcalInterop, ProjectionEqualsMrcalProject) {
  for (const CameraModel& camera : {EurocCam0(), PlainPinhole()}) {
    const mrcal_lensmodel_t lens = MrcalLens(camera);
    ASSERT_EQ(mrcal_lensmodel_num_params(&lens), camera.NumParams());
    double worst_px = 0.0;
    for (const Eigen::Vector3d& p : PointsInView(50.0 * kPi / 180.0, 500, 5)) {
      Eigen::Vector2d uv;
      Eigen::Matrix<double, 2, 3> J_uv_p;
      Eigen::Matrix<double, 2, Eigen::Dynamic> J_uv_params;
      ASSERT_TRUE(camera.Project(p, &uv, &J_uv_p, &J_uv_params));

      mrcal_point3_t p_m = {{p.x(), p.y(), p.z()}};
      mrcal_point2_t q;
      mrcal_point3_t dq_dp[2];
      std::vector<double> dq_dintrinsics(2 * camera.NumParams());
      ASSERT_TRUE(
          mrcal_project(&q, dq_dp, dq_dintrinsics.data(), &p_m, 1, &lens, camera.params().data()));
      worst_px = std::max(worst_px, (uv - Eigen::Vector2d(q.x, q.y)).norm());
      for (int r = 0; r < 2; ++r) {
        for (int c = 0; c < 3; ++c)
          EXPECT_NEAR(J_uv_p(r, c), dq_dp[r].xyz[c], 1e-9 * (1 + std::abs(J_uv_p(r, c))));
        for (int c = 0; c < camera.NumParams(); ++c)
          EXPECT_NEAR(J_uv_params(r, c), dq_dintrinsics[r * camera.NumParams() + c],
                      1e-9 * (1 + std::abs(J_uv_params(r, c))));
      }
    }
    EXPECT_LT(worst_px, 1e-9) << camera.camera_model() << "-" << camera.distortion_model();
  }
}

// Our unprojection and mrcal_unproject give the same direction over the whole image.
TEST(MrcalInterop, UnprojectionEqualsMrcalUnproject) {
  for (const CameraModel& camera : {EurocCam0(), PlainPinhole()}) {
    const mrcal_lensmodel_t lens = MrcalLens(camera);
    for (int i = 0; i <= 20; ++i) {
      for (int j = 0; j <= 20; ++j) {
        const Eigen::Vector2d uv(-0.5 + camera.width() * i / 20.0,
                                 -0.5 + camera.height() * j / 20.0);
        Eigen::Vector3d ray;
        ASSERT_TRUE(camera.Unproject(uv, &ray));
        const mrcal_point2_t q = {{uv.x(), uv.y()}};
        mrcal_point3_t v;
        ASSERT_TRUE(mrcal_unproject(&v, &q, 1, &lens, camera.params().data()));
        const Eigen::Vector3d ray_mrcal = Eigen::Vector3d(v.x, v.y, v.z).normalized();
        // mrcal's iterative solver stops at ~1e-10 rad; ours round-trips to 1e-9 px.
        EXPECT_LT((ray - ray_mrcal).norm(), 1e-8) << "uv = " << uv.transpose();
      }
    }
  }
}

void ExpectSameCamera(const CameraModel& a, const CameraModel& b) {
  EXPECT_EQ(a.type(), b.type());
  EXPECT_EQ(a.resolution(), b.resolution());
  ASSERT_EQ(a.NumParams(), b.NumParams());
  for (int i = 0; i < a.NumParams(); ++i)
    EXPECT_EQ(a.params()(i), b.params()(i)) << "parameter " << i;
}

// What we write, we read back bit for bit (17 significant digits).
TEST(MrcalInterop, WrittenFileReadsBackExactly) {
  MrcalRt rt;
  rt << 0.1 / 3, -0.2, 0.3, 1.0 / 7, -2.5, 0.125;
  for (const CameraModel& camera : {EurocCam0(), PlainPinhole()}) {
    const std::string path = ::testing::TempDir() + "/ctcal_roundtrip.cameramodel";
    SaveMrcalCameraModel(path, camera, rt);
    const MrcalCameraModel back = LoadMrcalCameraModel(path);
    ExpectSameCamera(camera, back.camera);
    for (int i = 0; i < 6; ++i)
      EXPECT_EQ(back.rt_cam_ref(i), rt(i));
    std::remove(path.c_str());
  }
}

// mrcal's own C reader reads our files to the same values.
TEST(MrcalInterop, MrcalReadsOurFile) {
  MrcalRt rt;
  rt << 0.01, 0.02, -0.03, 0.1, 0.2, 0.3;
  for (const CameraModel& camera : {EurocCam0(), PlainPinhole()}) {
    const std::string text = EmitMrcalCameraModel(camera, rt);
    mrcal_cameramodel_t* m = mrcal_read_cameramodel_string(text.c_str(), 0);
    ASSERT_NE(m, nullptr) << text;
    EXPECT_EQ(m->lensmodel.type, MrcalLens(camera).type);
    EXPECT_EQ(static_cast<int>(m->imagersize[0]), camera.width());
    EXPECT_EQ(static_cast<int>(m->imagersize[1]), camera.height());
    for (int i = 0; i < camera.NumParams(); ++i)
      EXPECT_EQ(m->intrinsics[i], camera.params()(i));
    for (int i = 0; i < 6; ++i)
      EXPECT_EQ(m->rt_cam_ref[i], rt(i));
    mrcal_free_cameramodel(&m);
  }
}

// A file written by mrcal's C writer (mrcal_write_cameramodel_file prints "%f", so values are
// rounded to 1e-6) reads correctly.
TEST(MrcalInterop, ReadsFileWrittenByMrcal) {
  const CameraModel camera = EurocCam0();
  mrcal_cameramodel_t* m = static_cast<mrcal_cameramodel_t*>(
      std::calloc(1, sizeof(mrcal_cameramodel_t) + camera.NumParams() * sizeof(double)));
  ASSERT_NE(m, nullptr);
  m->lensmodel.type = MRCAL_LENSMODEL_OPENCV4;
  m->imagersize[0] = camera.width();
  m->imagersize[1] = camera.height();
  for (int i = 0; i < camera.NumParams(); ++i)
    m->intrinsics[i] = camera.params()(i);
  const double rt[6] = {0.1, -0.2, 0.3, 1.5, -2.5, 0.125};
  std::memcpy(m->rt_cam_ref, rt, sizeof(rt));
  const std::string path = ::testing::TempDir() + "/ctcal_by_mrcal.cameramodel";
  ASSERT_TRUE(mrcal_write_cameramodel_file(path.c_str(), m));
  std::free(m);

  const MrcalCameraModel back = LoadMrcalCameraModel(path);
  EXPECT_EQ(back.camera.type(), CameraModelType::kPinholeRadtan);
  EXPECT_EQ(back.camera.resolution(), camera.resolution());
  for (int i = 0; i < camera.NumParams(); ++i)
    EXPECT_NEAR(back.camera.params()(i), camera.params()(i), 5e-7) << "parameter " << i;
  for (int i = 0; i < 6; ++i)
    EXPECT_EQ(back.rt_cam_ref(i), rt[i]);
  std::remove(path.c_str());
}

// The layout mrcal's Python tools write (from mrcal's documentation data): header comments,
// trailing commas, a multi-line valid_intrinsics_region, icam_intrinsics and a base-85 bytes
// literal of optimization_inputs, which are parsed and ignored.
TEST(MrcalInterop, ReadsPythonWriterLayout) {
  const std::string text =
      R"(# generated on 2020-11-14 21:49:59 with   mrcal-calibrate-cameras --lensmodel LENSMODEL_OPENCV4
# # Npoints_all Npoints_ranged
{
    'lensmodel':  'LENSMODEL_OPENCV4',

    # intrinsics are fx,fy,cx,cy,distortion0,distortion1,....
    'intrinsics': [ 2073.872915, 2077.452267, 3004.686823, 1997.377253, 0.4791613797, 0.0266824914, 4.398264387e-05, -1.180073913e-05,],

    'valid_intrinsics_region': [
    [ 622, 0 ],
    [ 0, 634 ],
    [ 622, 0 ],
],

    # extrinsics are rt_fromref
    'extrinsics': [ -0.0002607587119, 0.0004066789617, 0.0002345698447, -0.1186314564, 0.001033891787, 0.01069658311,],

    'imagersize': [ 6016, 4016,],

    'icam_intrinsics': 0,

    # The optimization inputs contain all the data used to compute this model.
    'optimization_inputs': b'P)h>@6aWAK2mk;8AprP8D`%|$007_s000gE6aZ;%baH8Kb7^C9E^csn0RRvH-~a#s00000tpET300000o9q|r8xYCJP{vTLo|0OeT%>NLpl*|9p{}E#o|a!!Qk0k%pI?-c3K',
}
)";
  const MrcalCameraModel m = ParseMrcalCameraModel(text, "python.cameramodel");
  EXPECT_EQ(m.camera.type(), CameraModelType::kPinholeRadtan);
  EXPECT_EQ(m.camera.resolution(), Eigen::Vector2i(6016, 4016));
  const double intrinsics[] = {2073.872915,  2077.452267,  3004.686823,     1997.377253,
                               0.4791613797, 0.0266824914, 4.398264387e-05, -1.180073913e-05};
  for (int i = 0; i < 8; ++i)
    EXPECT_EQ(m.camera.params()(i), intrinsics[i]);
  EXPECT_EQ(m.rt_cam_ref(3), -0.1186314564);
  EXPECT_EQ(m.rt_cam_ref(5), 0.01069658311);

  // mrcal's own reader agrees on the same text.
  mrcal_cameramodel_t* ref = mrcal_read_cameramodel_string(text.c_str(), 0);
  ASSERT_NE(ref, nullptr);
  for (int i = 0; i < 8; ++i)
    EXPECT_EQ(ref->intrinsics[i], m.camera.params()(i));
  mrcal_free_cameramodel(&ref);

  // A pinhole written with double quotes and no comments.
  const MrcalCameraModel p = ParseMrcalCameraModel(
      R"({"lensmodel": "LENSMODEL_PINHOLE", "intrinsics": [500, 501.5, 319.5, 239.5],
          "extrinsics": [0,0,0,0,0,0], "imagersize": [640, 480]})",
      "pinhole.cameramodel");
  EXPECT_EQ(p.camera.type(), CameraModelType::kPinholeNone);
  EXPECT_EQ(p.camera.params()(1), 501.5);
}

std::string ParseError(const std::string& text) {
  try {
    ParseMrcalCameraModel(text, "bad.cameramodel");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "no error";
}

TEST(MrcalInterop, ErrorsNameTheFileLineAndProblem) {
  const std::string ok_tail = "'extrinsics': [0,0,0,0,0,0],\n'imagersize': [640, 480]}\n";
  EXPECT_EQ(ParseError("{'lensmodel': 'LENSMODEL_FISHEYE',\n'intrinsics': [1,1,1,1],\n" + ok_tail)
                .rfind("bad.cameramodel:1: unknown mrcal lens model 'LENSMODEL_FISHEYE' (expected "
                       "LENSMODEL_PINHOLE, ",
                       0),
            0u);
  EXPECT_EQ(ParseError("{'lensmodel': 'LENSMODEL_SPLINED_STEREOGRAPHIC_order=3',\n"
                       "'intrinsics': [1,1,1,1],\n" +
                       ok_tail),
            "bad.cameramodel:1: mrcal lens model 'LENSMODEL_SPLINED_STEREOGRAPHIC_order=3': "
            "missing or unreadable configuration (e.g. "
            "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=10_fov_x_deg=100)");
  EXPECT_EQ(
      ParseError("{'lensmodel': 'LENSMODEL_OPENCV8',\n'intrinsics': [500,500,320,240,0,0,0],\n" +
                 ok_tail),
      "bad.cameramodel:2: 'LENSMODEL_OPENCV8': mrcal lens model LENSMODEL_OPENCV8 needs 12 "
      "intrinsics, got 7");
  EXPECT_EQ(
      ParseError("{'lensmodel': 'LENSMODEL_OPENCV4',\n'intrinsics': [500,500,320,240,0,0,0],\n" +
                 ok_tail),
      "bad.cameramodel:2: 'LENSMODEL_OPENCV4': camera model 'pinhole' with distortion "
      "'radtan' needs 8 parameters (intrinsics and distortion_coeffs), got 7");
  EXPECT_EQ(ParseError("{'lensmodel': 'LENSMODEL_PINHOLE',\n'intrinsics': [500,500,320,240],\n"
                       "'imagersize': [640, 480]}"),
            "bad.cameramodel:1: missing key 'extrinsics' (a .cameramodel needs lensmodel, "
            "intrinsics, extrinsics, imagersize)");
  EXPECT_EQ(
      ParseError("{'lensmodel': 'LENSMODEL_PINHOLE',\n'intrinsics': [500,500,320,240]\n" + ok_tail),
      "bad.cameramodel:3: expected ',' or '}' in a dict, found '''");
  EXPECT_EQ(ParseError("{'lensmodel': 'LENSMODEL_PINHOLE',\n'intrinsics': [500,500,3x0,240],\n" +
                       ok_tail),
            "bad.cameramodel:2: '3x0' is not a finite number");
  EXPECT_EQ(ParseError("{'lensmodel': 'LENSMODEL_PINHOLE',\n'intrinsics': [500,500,320,240],\n"
                       "'extrinsics': [0,0,0,0,0,0],\n'imagersize': [640.5, 480]}"),
            "bad.cameramodel:4: 'imagersize' must hold integers, found a number");
  EXPECT_EQ(
      ParseError("{'lensmodel': 'LENSMODEL_PINHOLE',\n'intrinsics': [-500,500,320,240],\n" +
                 ok_tail),
      "bad.cameramodel:2: 'LENSMODEL_PINHOLE': camera model 'pinhole' with distortion 'none': "
      "focal lengths fu, fv must be positive, got -500, 500");
  EXPECT_EQ(ParseError("{'lensmodel': 'LENSMODEL_PINHOLE',\n'intrinsics': [500,500,320,240],\n" +
                       ok_tail + "junk"),
            "bad.cameramodel:5: unexpected text after the closing '}'");
  EXPECT_EQ(ParseError("{'lensmodel': 'LENSMODEL_PINHOLE',\n'intrinsics': [500,500,320,240],\n"
                       "'extrinsics': [0,0,0,0,0],\n'imagersize': [640, 480]}"),
            "bad.cameramodel:3: 'extrinsics' must hold 6 numbers (rt_cam_ref), found 5");
  EXPECT_EQ(ParseError(""), "bad.cameramodel:1: expected a value, found the end of the file");
  EXPECT_THROW(LoadMrcalCameraModel("/nonexistent/x.cameramodel"), std::runtime_error);
}

TEST(MrcalInterop, ModelsMrcalDoesNotShareAreRejected) {
  const CameraModel ds = CameraModel::Create("ds", {-0.18, 0.59, 158.28, 158.27, 254.93, 256.89},
                                             "none", {}, Eigen::Vector2i(512, 512));
  try {
    EmitMrcalCameraModel(ds);
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(),
                 "camera model 'ds' with distortion 'none' has no mrcal lens model (mrcal and "
                 "ctcal share LENSMODEL_OPENCV4 (pinhole + radtan) and LENSMODEL_PINHOLE "
                 "(pinhole + none))");
  }
  for (CameraModelType type : kAllCameraModelTypes) {
    if (type == CameraModelType::kPinholeRadtan || type == CameraModelType::kPinholeNone)
      EXPECT_EQ(FromMrcalLensModelName(MrcalLensModelName(type)), type);
    else
      EXPECT_THROW(MrcalLensModelName(type), std::invalid_argument);
  }
}

// rt_cam_ref <-> T_cam_ref: both map reference points into the camera, p_cam = R(r) p_ref + t,
// checked against mrcal's own transform_point_rt.
TEST(MrcalInterop, ExtrinsicsConvention) {
  MrcalRt rt;
  rt << 0.3, -0.2, 0.9, 1.0, 2.0, -3.0;
  const Eigen::Isometry3d T_cam_ref = TransformFromMrcalRt(rt);
  const Eigen::Vector3d p_ref(0.5, -1.5, 4.0);
  double x_out[3];
  mrcal_transform_point_rt_full(x_out, 0, nullptr, 0, 0, nullptr, 0, 0, rt.data(), 0, p_ref.data(),
                                0, false);
  EXPECT_LT(((T_cam_ref * p_ref) - Eigen::Vector3d(x_out[0], x_out[1], x_out[2])).norm(), 1e-12);
  EXPECT_LT((MrcalRtFromTransform(T_cam_ref) - rt).norm(), 1e-12);
}

}  // namespace
}  // namespace ctcal
