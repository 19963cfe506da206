// Properties every camera model of SPEC section 4 must have, as typed tests over the model
// structs: analytic Jacobians against central differences, Jet autodiff against the analytic
// Jacobians, unproject/project round trips over the whole image, and the validity regions.
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "ctcal/sensors/camera_model.h"

namespace ctcal {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
constexpr double kNoBoundary = std::numeric_limits<double>::quiet_NaN();

// One parameter set of a model with the image it is tested on. The parameters are realistic
// (EuRoC, TUM-VI and Kalibr example calibrations) and chosen with a resolution whose every pixel
// lies in the model's valid region, so the whole-image round trip must succeed everywhere.
struct Case {
  std::vector<double> params;
  int width;
  int height;
  double max_angle;       // random test points have an incidence angle up to this (rad)
  double boundary_angle;  // incidence angle where validity ends along +x (NaN: not closed form)
};

template <class Model>
std::vector<Case> Cases();

template <>
std::vector<Case> Cases<PinholeRadtanModel>() {
  return {
      {{458.654, 457.296, 367.215, 248.375, -0.28340811, 0.07395907, 0.00019359, 1.76187114e-05},
       752,
       480,
       50 * kDeg,
       kNoBoundary}};
}

template <>
std::vector<Case> Cases<PinholeNoneModel>() {
  return {{{400.0, 410.0, 320.5, 239.0}, 640, 480, 60 * kDeg, 90 * kDeg}};
}

template <>
std::vector<Case> Cases<PinholeEquidistantModel>() {
  // TUM-VI 512 (cam0), on a 480x480 crop so that the corners stay inside theta_d's rising branch.
  return {
      {{190.978, 190.973, 239.5, 239.5, 0.0034823894, 0.000715034845, -0.0020532361, 0.000202935},
       480,
       480,
       100 * kDeg,
       kNoBoundary}};
}

template <>
std::vector<Case> Cases<OmniRadtanModel>() {
  return {{{0.9, 600.0, 602.0, 376.0, 240.0, -0.1, 0.02, 0.0005, -0.0003},
           752,
           480,
           60 * kDeg,
           kNoBoundary},
          {{1.7, 1100.0, 1098.0, 376.0, 240.0, -0.05, 0.01, 0.0002, 0.0001},
           752,
           480,
           55 * kDeg,
           kNoBoundary}};
}

template <>
std::vector<Case> Cases<OmniNoneModel>() {
  return {{{0.9, 300.0, 301.0, 376.0, 240.0}, 752, 480, 120 * kDeg, std::acos(-0.9)},
          {{1.5, 600.0, 600.0, 376.0, 240.0}, 752, 480, 120 * kDeg, std::acos(-1.0 / 1.5)}};
}

double DoubleSphereBoundary(double xi, double alpha) {
  const double w1 = alpha > 0.5 ? (1 - alpha) / alpha : alpha / (1 - alpha);
  const double w2 = (w1 + xi) / std::sqrt(2 * w1 * xi + xi * xi + 1);
  return std::acos(-w2);
}

template <>
std::vector<Case> Cases<DoubleSphereModel>() {
  return {{{-0.18, 0.59, 158.28, 158.27, 254.93, 256.89},
           512,
           512,
           110 * kDeg,
           DoubleSphereBoundary(-0.18, 0.59)},
          {{0.3, 0.4, 250.0, 251.0, 256.0, 255.0},
           512,
           512,
           120 * kDeg,
           DoubleSphereBoundary(0.3, 0.4)}};
}

// Along +x: z = -w rho with rho^2 = beta sin^2 + cos^2 gives tan^2(theta) = (1 - w^2)/(w^2 beta).
double EucmBoundary(double alpha, double beta) {
  const double w = alpha > 0.5 ? (1 - alpha) / alpha : alpha / (1 - alpha);
  return kPi - std::atan(std::sqrt((1 - w * w) / (w * w * beta)));
}

template <>
std::vector<Case> Cases<EucmModel>() {
  return {{{0.5903, 1.1275, 460.76, 459.41, 365.89, 249.33},
           752,
           480,
           110 * kDeg,
           EucmBoundary(0.5903, 1.1275)},
          {{0.4, 0.9, 300.0, 301.0, 376.0, 240.0}, 752, 480, 110 * kDeg, EucmBoundary(0.4, 0.9)}};
}

// Random points with incidence angle in [0, max_angle], any azimuth, depth 0.3 .. 5 m, plus the
// optical axis itself (the small-angle branch of the Kannala-Brandt model).
std::vector<Eigen::Vector3d> RandomPoints(double max_angle, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> angle(0.0, max_angle), azimuth(-kPi, kPi), range(0.3, 5.0);
  std::vector<Eigen::Vector3d> points{Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0, 0, 2.5)};
  for (int i = 0; i < n; ++i) {
    const double t = angle(rng), a = azimuth(rng), r = range(rng);
    points.emplace_back(r * std::sin(t) * std::cos(a), r * std::sin(t) * std::sin(a),
                        r * std::cos(t));
  }
  return points;
}

template <class Model>
class CameraProjectionTest : public ::testing::Test {};

using ModelTypes = ::testing::Types<PinholeRadtanModel, PinholeNoneModel, PinholeEquidistantModel,
                                    OmniRadtanModel, OmniNoneModel, DoubleSphereModel, EucmModel>;

class ModelNames {
 public:
  template <typename T>
  static std::string GetName(int) {
    return std::string(T::kCameraModel) + "_" + T::kDistortionModel;
  }
};
TYPED_TEST_SUITE(CameraProjectionTest, ModelTypes, ModelNames);

TYPED_TEST(CameraProjectionTest, ParamsAreValidAndNamed) {
  using Model = TypeParam;
  for (const Case& c : Cases<Model>()) {
    ASSERT_EQ(static_cast<int>(c.params.size()), Model::kNumParams);
    std::string why;
    EXPECT_TRUE(Model::CheckParams(c.params.data(), &why)) << why;
  }
  EXPECT_EQ(static_cast<int>(Model::ParamNames().size()), Model::kNumParams);

  // The test parameters lie inside the solver bounds, and the finite bounds themselves are valid
  // parameters (Ceres' bounds are inclusive).
  double lower[Model::kNumParams], upper[Model::kNumParams];
  Model::ParamBounds(lower, upper);
  for (const Case& c : Cases<Model>()) {
    for (int i = 0; i < Model::kNumParams; ++i) {
      EXPECT_GE(c.params[i], lower[i]) << Model::ParamNames()[i];
      EXPECT_LE(c.params[i], upper[i]) << Model::ParamNames()[i];
      for (double bound : {lower[i], upper[i]}) {
        if (!std::isfinite(bound))
          continue;
        std::vector<double> at_bound = c.params;
        at_bound[i] = bound;
        std::string why;
        EXPECT_TRUE(Model::CheckParams(at_bound.data(), &why))
            << Model::ParamNames()[i] << " = " << bound << ": " << why;
      }
    }
  }
}

// d uv / d p_C and d uv / d params against central differences. Step h = 1e-6 relative; the
// truncation error is O(h^2 * third derivative) and the rounding error O(eps |uv| / h) ~ 1e-7 px
// per unit step, so the tolerance is 1e-6 relative to the Jacobian's scale.
TYPED_TEST(CameraProjectionTest, JacobiansMatchCentralDifferences) {
  using Model = TypeParam;
  constexpr int K = Model::kNumParams;
  unsigned seed = 1;
  for (const Case& c : Cases<Model>()) {
    for (const Eigen::Vector3d& p : RandomPoints(c.max_angle, 200, seed++)) {
      Eigen::Vector2d uv;
      Eigen::Matrix<double, 2, 3> J_uv_p;
      Eigen::Matrix<double, 2, K> J_uv_params;
      ASSERT_TRUE(Model::Project(c.params.data(), p, &uv, &J_uv_p, &J_uv_params))
          << "p = " << p.transpose();

      Eigen::Matrix<double, 2, 3> J_num_p;
      for (int j = 0; j < 3; ++j) {
        const double h = 1e-6 * p.norm();
        Eigen::Vector3d pp = p, pm = p;
        pp(j) += h;
        pm(j) -= h;
        Eigen::Vector2d up, um;
        ASSERT_TRUE(Model::Project(c.params.data(), pp, &up));
        ASSERT_TRUE(Model::Project(c.params.data(), pm, &um));
        J_num_p.col(j) = (up - um) / (2 * h);
      }
      const double scale_p = 1.0 + J_uv_p.cwiseAbs().maxCoeff();
      EXPECT_LE((J_num_p - J_uv_p).cwiseAbs().maxCoeff(), 1e-6 * scale_p)
          << "p = " << p.transpose() << "\nanalytic\n"
          << J_uv_p << "\nnumeric\n"
          << J_num_p;

      Eigen::Matrix<double, 2, K> J_num_params;
      for (int j = 0; j < K; ++j) {
        const double h = 1e-6 * std::max(1.0, std::abs(c.params[j]));
        std::vector<double> qp = c.params, qm = c.params;
        qp[j] += h;
        qm[j] -= h;
        Eigen::Vector2d up, um;
        ASSERT_TRUE(Model::Project(qp.data(), p, &up));
        ASSERT_TRUE(Model::Project(qm.data(), p, &um));
        J_num_params.col(j) = (up - um) / (2 * h);
      }
      const double scale_k = 1.0 + J_uv_params.cwiseAbs().maxCoeff();
      EXPECT_LE((J_num_params - J_uv_params).cwiseAbs().maxCoeff(), 1e-6 * scale_k)
          << "p = " << p.transpose() << "\nanalytic\n"
          << J_uv_params << "\nnumeric\n"
          << J_num_params;
    }
  }
}

// The templated Project on ceres::Jet (the calibrator's autodiff path) gives the same value and
// the same derivatives as the analytic double path, to rounding.
TYPED_TEST(CameraProjectionTest, JetAutodiffEqualsAnalyticJacobian) {
  using Model = TypeParam;
  constexpr int K = Model::kNumParams;
  using Jet = ceres::Jet<double, 3 + K>;
  unsigned seed = 100;
  for (const Case& c : Cases<Model>()) {
    for (const Eigen::Vector3d& p : RandomPoints(c.max_angle, 100, seed++)) {
      Eigen::Vector2d uv;
      Eigen::Matrix<double, 2, 3> J_uv_p;
      Eigen::Matrix<double, 2, K> J_uv_params;
      ASSERT_TRUE(Model::Project(c.params.data(), p, &uv, &J_uv_p, &J_uv_params));

      Eigen::Matrix<Jet, 3, 1> p_jet;
      for (int i = 0; i < 3; ++i)
        p_jet(i) = Jet(p(i), i);
      std::vector<Jet> params_jet(K);
      for (int i = 0; i < K; ++i)
        params_jet[i] = Jet(c.params[i], 3 + i);
      Eigen::Matrix<Jet, 2, 1> uv_jet;
      ASSERT_TRUE(Model::Project(params_jet.data(), p_jet, &uv_jet));
      for (int r = 0; r < 2; ++r) {
        EXPECT_NEAR(uv_jet(r).a, uv(r), 1e-9);
        const double scale = 1.0 + uv_jet(r).v.cwiseAbs().maxCoeff();
        EXPECT_LE(
            (uv_jet(r).v.template head<3>().transpose() - J_uv_p.row(r)).cwiseAbs().maxCoeff(),
            1e-12 * scale)
            << "p = " << p.transpose();
        EXPECT_LE(
            (uv_jet(r).v.template tail<K>().transpose() - J_uv_params.row(r)).cwiseAbs().maxCoeff(),
            1e-12 * scale)
            << "p = " << p.transpose();
      }
    }
  }
}

// Every pixel of a grid covering the whole sensor, edges included, unprojects to a unit ray that
// projects back onto it within 1e-9 px.
TYPED_TEST(CameraProjectionTest, UnprojectProjectRoundTripOverWholeImage) {
  using Model = TypeParam;
  for (const Case& c : Cases<Model>()) {
    double worst = 0.0;
    constexpr int kNu = 60, kNv = 40;
    for (int i = 0; i <= kNu; ++i) {
      for (int j = 0; j <= kNv; ++j) {
        const Eigen::Vector2d uv(-0.5 + c.width * double(i) / kNu,
                                 -0.5 + c.height * double(j) / kNv);
        Eigen::Vector3d ray;
        ASSERT_TRUE(Model::Unproject(c.params.data(), uv, &ray)) << "uv = " << uv.transpose();
        EXPECT_NEAR(ray.norm(), 1.0, 1e-14);
        for (double depth : {0.5, 7.0}) {
          Eigen::Vector2d uv_back;
          ASSERT_TRUE(Model::Project(c.params.data(), Eigen::Vector3d(depth * ray), &uv_back));
          worst = std::max(worst, (uv_back - uv).norm());
        }
      }
    }
    EXPECT_LT(worst, 1e-9) << "worst round trip error " << worst << " px";
  }
}

// Project then unproject gives back the point's direction.
TYPED_TEST(CameraProjectionTest, ProjectUnprojectRecoversDirection) {
  using Model = TypeParam;
  unsigned seed = 200;
  for (const Case& c : Cases<Model>()) {
    for (const Eigen::Vector3d& p : RandomPoints(c.max_angle, 300, seed++)) {
      Eigen::Vector2d uv;
      ASSERT_TRUE(Model::Project(c.params.data(), p, &uv));
      Eigen::Vector3d ray;
      ASSERT_TRUE(Model::Unproject(c.params.data(), uv, &ray)) << "p = " << p.transpose();
      EXPECT_LT((ray - p.normalized()).norm(), 1e-11) << "p = " << p.transpose();
    }
  }
}

// No model projects the camera centre or a point straight behind the camera; where the validity
// boundary has a closed form, points just inside are accepted and points just outside rejected.
TYPED_TEST(CameraProjectionTest, InvalidPointsRejected) {
  using Model = TypeParam;
  for (const Case& c : Cases<Model>()) {
    Eigen::Vector2d uv;
    EXPECT_FALSE(Model::Project(c.params.data(), Eigen::Vector3d(0, 0, 0), &uv));
    EXPECT_FALSE(Model::Project(c.params.data(), Eigen::Vector3d(0, 0, -1), &uv));
    EXPECT_FALSE(Model::Project(c.params.data(), Eigen::Vector3d(1e-12, 0, -3), &uv));
    // Non-finite input is rejected, never propagated.
    const double nan = std::numeric_limits<double>::quiet_NaN();
    EXPECT_FALSE(Model::Project(c.params.data(), Eigen::Vector3d(nan, 0, 1), &uv));
    EXPECT_FALSE(Model::Project(c.params.data(), Eigen::Vector3d(0, 0, nan), &uv));
    Eigen::Vector3d ray;
    EXPECT_FALSE(Model::Unproject(c.params.data(), Eigen::Vector2d(nan, 10), &ray));
    EXPECT_FALSE(Model::Unproject(c.params.data(), Eigen::Vector2d(10, nan), &ray));
    if (std::isnan(c.boundary_angle))
      continue;
    for (double az : {0.0, 1.0, 2.5, -2.0}) {
      const auto dir = [&](double t) {
        return Eigen::Vector3d(std::sin(t) * std::cos(az), std::sin(t) * std::sin(az), std::cos(t));
      };
      EXPECT_TRUE(
          Model::Project(c.params.data(), Eigen::Vector3d(2.0 * dir(c.boundary_angle - 1e-6)), &uv))
          << "boundary " << c.boundary_angle / kDeg << " deg";
      EXPECT_FALSE(
          Model::Project(c.params.data(), Eigen::Vector3d(2.0 * dir(c.boundary_angle + 1e-6)), &uv))
          << "boundary " << c.boundary_angle / kDeg << " deg";
      // The Jet path applies the same region.
      using Jet = ceres::Jet<double, 1>;
      std::vector<Jet> params_jet(c.params.begin(), c.params.end());
      const Eigen::Vector3d outside = dir(c.boundary_angle + 1e-6);
      Eigen::Matrix<Jet, 2, 1> uv_jet;
      EXPECT_FALSE(Model::Project(params_jet.data(), Eigen::Matrix<Jet, 3, 1>(outside.cast<Jet>()),
                                  &uv_jet));
    }
  }
}

// A model whose theta_d(theta) turns back (k1 = -0.5: d theta_d / d theta < 0 beyond ~0.82 rad)
// rejects points past the turn and pixels beyond the largest theta_d.
TEST(PinholeEquidistant, RejectsFoldedRegion) {
  const double params[] = {300, 300, 320, 240, -0.5, 0.0, 0.0, 0.0};
  // theta_d = theta - 0.5 theta^3 turns at theta = sqrt(2/3) with theta_d = 0.544.
  const double theta_turn = std::sqrt(2.0 / 3.0);
  Eigen::Vector2d uv;
  const auto dir = [](double t) { return Eigen::Vector3d(std::sin(t), 0, std::cos(t)); };
  EXPECT_TRUE(PinholeEquidistantModel::Project(params, dir(theta_turn - 1e-6), &uv));
  EXPECT_FALSE(PinholeEquidistantModel::Project(params, dir(theta_turn + 1e-6), &uv));
  Eigen::Vector3d ray;
  const double thetad_max = theta_turn - 0.5 * std::pow(theta_turn, 3);
  EXPECT_TRUE(PinholeEquidistantModel::Unproject(
      params, Eigen::Vector2d(320 + 300 * (thetad_max - 1e-4), 240), &ray));
  EXPECT_FALSE(PinholeEquidistantModel::Unproject(
      params, Eigen::Vector2d(320 + 300 * (thetad_max + 1e-4), 240), &ray));
}

// Kalibr's equidistant distortion of (x/z, y/z) -- theta = atan(r), theta_d/r scaling -- and ours
// agree in front of the camera.
TEST(PinholeEquidistant, EqualsKalibrFormulation) {
  const double params[] = {190.978,      190.973,        254.93,        256.89,
                           0.0034823894, 0.000715034845, -0.0020532361, 0.000202935};
  for (const Eigen::Vector3d& p : RandomPoints(85 * kDeg, 100, 7)) {
    const double mx = p.x() / p.z(), my = p.y() / p.z();
    const double r = std::hypot(mx, my);
    const double t = std::atan(r);
    const double t2 = t * t;
    const double td = t * (1 + params[4] * t2 + params[5] * t2 * t2 + params[6] * std::pow(t2, 3) +
                           params[7] * std::pow(t2, 4));
    const double scale = r > 1e-8 ? td / r : 1.0;
    const Eigen::Vector2d expected(params[0] * mx * scale + params[2],
                                   params[1] * my * scale + params[3]);
    Eigen::Vector2d uv;
    ASSERT_TRUE(PinholeEquidistantModel::Project(params, p, &uv));
    EXPECT_LT((uv - expected).norm(), 1e-9);
  }
}

// Radtan folds over where det(d md / d m) <= 0; such points are rejected and such pixels have no
// undistortion.
TEST(RadTanDistortion, RejectsFoldedRegion) {
  // k1 = -0.5: md = m (1 - 0.5 |m|^2) turns at |m|^2 = 2/3.
  const double params[] = {300, 300, 320, 240, -0.5, 0.0, 0.0, 0.0};
  const double r_turn = std::sqrt(2.0 / 3.0);
  Eigen::Vector2d uv;
  EXPECT_TRUE(PinholeRadtanModel::Project(params, Eigen::Vector3d(r_turn - 1e-6, 0, 1), &uv));
  EXPECT_FALSE(PinholeRadtanModel::Project(params, Eigen::Vector3d(r_turn + 1e-6, 0, 1), &uv));
  const double rd_max = r_turn * (1 - 0.5 * r_turn * r_turn);
  Eigen::Vector3d ray;
  EXPECT_TRUE(PinholeRadtanModel::Unproject(
      params, Eigen::Vector2d(320 + 300 * (rd_max - 1e-4), 240), &ray));
  EXPECT_FALSE(PinholeRadtanModel::Unproject(
      params, Eigen::Vector2d(320 + 300 * (rd_max + 1e-4), 240), &ray));
}

// Radtan equals OpenCV's distortion formula with (k1, k2, p1, p2) = (k1, k2, r1, r2), written out
// independently here.
TEST(RadTanDistortion, EqualsOpenCvFormula) {
  const double k[] = {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05};
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.8, 0.8);
  for (int i = 0; i < 100; ++i) {
    const double x = u(rng), y = u(rng);
    const double r2 = x * x + y * y;
    const double radial = 1 + k[0] * r2 + k[1] * r2 * r2;
    const double xd = x * radial + 2 * k[2] * x * y + k[3] * (r2 + 2 * x * x);
    const double yd = y * radial + k[2] * (r2 + 2 * y * y) + 2 * k[3] * x * y;
    Eigen::Vector2d md;
    RadTanDistortion::Distort(k, Eigen::Vector2d(x, y), &md);
    EXPECT_NEAR(md.x(), xd, 1e-15);
    EXPECT_NEAR(md.y(), yd, 1e-15);
  }
}

// Omni with xi = 0 is the pinhole. EUCM with beta = 1 and DS with xi = 0 are the unified model in
// its alpha form: omni(xi, f) == eucm(alpha = xi / (1 + xi), beta = 1, f / (1 + xi)), since
// alpha d + (1 - alpha) z = (z + xi d) / (1 + xi).
TEST(CameraModelIdentities, SpecialCasesCoincide) {
  const double xi = 0.7;
  const double omni[] = {xi, 400, 410, 320, 240};
  const double pinhole[] = {400, 410, 320, 240};
  const double omni0[] = {0.0, 400, 410, 320, 240};
  const double alpha = xi / (1 + xi);
  const double eucm[] = {alpha, 1.0, 400 / (1 + xi), 410 / (1 + xi), 320, 240};
  const double ds[] = {0.0, alpha, 400 / (1 + xi), 410 / (1 + xi), 320, 240};
  for (const Eigen::Vector3d& p : RandomPoints(80 * kDeg, 50, 11)) {
    Eigen::Vector2d a, b, c, d, e;
    ASSERT_TRUE(OmniNoneModel::Project(omni0, p, &a));
    ASSERT_TRUE(PinholeNoneModel::Project(pinhole, p, &b));
    EXPECT_LT((a - b).norm(), 1e-9);
    ASSERT_TRUE(OmniNoneModel::Project(omni, p, &c));
    ASSERT_TRUE(EucmModel::Project(eucm, p, &d));
    ASSERT_TRUE(DoubleSphereModel::Project(ds, p, &e));
    EXPECT_LT((c - d).norm(), 1e-9);
    EXPECT_LT((c - e).norm(), 1e-9);
  }
}

// The models' closed forms against the geometric constructions they come from (Usenko et al.,
// section 3), written step by step: onto a unit sphere (omni, ds) or the ellipsoid
// beta (x^2 + y^2) + z^2 = 1 (eucm), for ds onto a second unit sphere shifted by xi, then a pinhole
// whose centre sits alpha / (1 - alpha) (omni: xi) behind the last surface's centre, with focal
// length f / (1 - alpha) in the alpha form.
TEST(CameraModelIdentities, GeometricConstructions) {
  const auto pinhole_from = [](const Eigen::Vector3d& s, double shift, double fu, double fv,
                               double pu, double pv) {
    return Eigen::Vector2d(fu * s.x() / (s.z() + shift) + pu, fv * s.y() / (s.z() + shift) + pv);
  };
  const double omni[] = {0.8, 350, 352, 320, 240};
  const double ds[] = {-0.18, 0.59, 158.28, 158.27, 254.93, 256.89};
  const double eucm[] = {0.59, 1.13, 460.76, 459.41, 365.89, 249.33};
  for (const Eigen::Vector3d& p : RandomPoints(100 * kDeg, 200, 21)) {
    Eigen::Vector2d uv;
    ASSERT_TRUE(OmniNoneModel::Project(omni, p, &uv));
    EXPECT_LT(
        (uv - pinhole_from(p.normalized(), omni[0], omni[1], omni[2], omni[3], omni[4])).norm(),
        1e-9);

    const double xi = ds[0], a = ds[1];
    const Eigen::Vector3d s2 = (p.normalized() + Eigen::Vector3d(0, 0, xi)).normalized();
    ASSERT_TRUE(DoubleSphereModel::Project(ds, p, &uv));
    EXPECT_LT(
        (uv - pinhole_from(s2, a / (1 - a), ds[2] / (1 - a), ds[3] / (1 - a), ds[4], ds[5])).norm(),
        1e-9);

    const double alpha = eucm[0], beta = eucm[1];
    const Eigen::Vector3d e = p / std::sqrt(beta * (p.x() * p.x() + p.y() * p.y()) + p.z() * p.z());
    ASSERT_TRUE(EucmModel::Project(eucm, p, &uv));
    EXPECT_LT((uv - pinhole_from(e, alpha / (1 - alpha), eucm[2] / (1 - alpha),
                                 eucm[3] / (1 - alpha), eucm[4], eucm[5]))
                  .norm(),
              1e-9);
  }
}

}  // namespace
}  // namespace ctcal
