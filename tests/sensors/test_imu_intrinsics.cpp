// The IMU intrinsic models of SPEC section 3, every model x g_sensitivity: analytic Jacobians
// against central differences, Jet evaluation against double, correction(measurement(x)) = x,
// stored forms, the frame each model fixes, and rejection of bad stored forms.
#include "ctcal/sensors/imu_intrinsics.h"

#include <ceres/jet.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <ostream>
#include <random>
#include <string>
#include <tuple>

#include "imu_test_util.h"

namespace ctcal {

// Readable parameters in gtest's failure messages.
inline void PrintTo(ImuModel m, std::ostream* os) {
  *os << ToString(m);
}
inline void PrintTo(GSensitivity g, std::ostream* os) {
  *os << ToString(g);
}

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using test::CentralDifferences;
using test::RandomImuIntrinsics;
using test::RandomRotation;
using test::RandomVector;
using ::testing::HasSubstr;

enum class Direction { kRawFromTrue, kTrueFromRaw };

// One evaluation point: input pair (true or raw [w; a]) and the biases.
struct Point {
  Vector3d w, a, b_g, b_a;
};

Vec6 Evaluate(const ImuIntrinsics& x, Direction d, const Point& p, const ImuJacobians& J = {}) {
  Vector3d w, a;
  if (d == Direction::kRawFromTrue)
    x.RawFromTrue(p.w, p.a, p.b_g, p.b_a, &w, &a, J);
  else
    x.TrueFromRaw(p.w, p.a, p.b_g, p.b_a, &w, &a, J);
  Vec6 out;
  out << w, a;
  return out;
}

Point RandomPoint(std::mt19937& rng) {
  // Rates of a few rad/s and specific forces around gravity: what a hand-waved rig produces.
  return {RandomVector(rng, 3.0), RandomVector(rng, 12.0), RandomVector(rng, 0.05),
          RandomVector(rng, 0.3)};
}

using Case = std::tuple<ImuModel, GSensitivity>;

std::string CaseName(const ::testing::TestParamInfo<Case>& info) {
  return ToString(std::get<0>(info.param)) + "_g" + ToString(std::get<1>(info.param));
}

class ImuModelTest : public ::testing::TestWithParam<Case> {
 protected:
  ImuModel model() const { return std::get<0>(GetParam()); }
  GSensitivity g() const { return std::get<1>(GetParam()); }
  std::mt19937 rng_{20261121};
};

// Every analytic Jacobian of one direction against central differences on the block's tangent.
void CheckJacobians(const ImuIntrinsics& x0, Direction d, const Point& p0) {
  ImuMatrixJacobian J_Dw, J_Da, J_Tg;
  Eigen::Matrix<double, 6, 3> J_rot, J_bg, J_ba;
  Eigen::Matrix<double, 6, 6> J_in;
  ImuJacobians J;
  J.J_out_Dw = &J_Dw;
  J.J_out_Da = &J_Da;
  J.J_out_Tg = &J_Tg;
  J.J_out_rotation = &J_rot;
  J.J_out_bg = &J_bg;
  J.J_out_ba = &J_ba;
  J.J_out_in = &J_in;
  const Vec6 y0 = Evaluate(x0, d, p0, J);
  EXPECT_LT((y0 - Evaluate(x0, d, p0)).norm(), 1e-15 * (1.0 + y0.norm()))
      << "asking for Jacobians changed the value";

  const double h = 1e-6;
  // Truncation O(h^2 f''') plus rounding O(eps |f| / h): ~1e-9 for these magnitudes.
  const double tol = 1e-8;
  auto matrix_block = [&](int n, auto block) {
    return CentralDifferences<6>(n, h, [&](int k, double s) {
      ImuIntrinsics x = x0;
      block(x)[k] += s;
      return Vec6(Evaluate(x, d, p0));
    });
  };
  const ImuModelLayout& L = x0.layout();
  ASSERT_EQ(J_Dw.cols(), StoredSize(L.Dw));
  ASSERT_EQ(J_Da.cols(), StoredSize(L.Da));
  ASSERT_EQ(J_Tg.cols(), StoredSize(L.Tg));
  auto expect_close = [&](const ImuMatrixJacobian& analytic, int n, auto block, const char* name) {
    if (n == 0)
      return;
    const double err = (analytic - matrix_block(n, block)).cwiseAbs().maxCoeff();
    EXPECT_LT(err, tol) << name;
  };
  expect_close(
      J_Dw, x0.DwSize(), [](ImuIntrinsics& x) { return x.Dw(); }, "J_out_Dw");
  expect_close(
      J_Da, x0.DaSize(), [](ImuIntrinsics& x) { return x.Da(); }, "J_out_Da");
  expect_close(
      J_Tg, x0.TgSize(), [](ImuIntrinsics& x) { return x.Tg(); }, "J_out_Tg");

  // The rotation on So3LeftManifold's tangent: q <- Exp(d) q.
  Eigen::Matrix<double, 6, 3> num_rot = Eigen::Matrix<double, 6, 3>::Zero();
  if (L.HasRotation()) {
    num_rot = CentralDifferences<6>(3, h, [&](int k, double s) {
      ImuIntrinsics x = x0;
      Eigen::Map<Eigen::Quaterniond> q(x.q_rotation());
      q = (ExpSO3<double>(Vector3d::Unit(k) * s) * q).normalized();
      return Vec6(Evaluate(x, d, p0));
    });
  }
  EXPECT_LT((J_rot - num_rot).cwiseAbs().maxCoeff(), tol) << "J_out_rotation";

  auto vector_input = [&](Vector3d Point::*member) {
    return CentralDifferences<6>(3, h, [&](int k, double s) {
      Point p = p0;
      (p.*member)(k) += s;
      return Vec6(Evaluate(x0, d, p));
    });
  };
  EXPECT_LT((J_bg - vector_input(&Point::b_g)).cwiseAbs().maxCoeff(), tol) << "J_out_bg";
  EXPECT_LT((J_ba - vector_input(&Point::b_a)).cwiseAbs().maxCoeff(), tol) << "J_out_ba";
  EXPECT_LT((J_in.leftCols<3>() - vector_input(&Point::w)).cwiseAbs().maxCoeff(), tol)
      << "J_out_in (w)";
  EXPECT_LT((J_in.rightCols<3>() - vector_input(&Point::a)).cwiseAbs().maxCoeff(), tol)
      << "J_out_in (a)";
}

TEST_P(ImuModelTest, RawFromTrueJacobiansMatchCentralDifferences) {
  for (int trial = 0; trial < 5; ++trial)
    CheckJacobians(RandomImuIntrinsics(model(), g(), rng_), Direction::kRawFromTrue,
                   RandomPoint(rng_));
}

TEST_P(ImuModelTest, TrueFromRawJacobiansMatchCentralDifferences) {
  for (int trial = 0; trial < 5; ++trial)
    CheckJacobians(RandomImuIntrinsics(model(), g(), rng_), Direction::kTrueFromRaw,
                   RandomPoint(rng_));
}

// The templated model on ceres::Jet: its value equals the double evaluation, and its derivative
// part (the autodiff Jacobian the calibrator's Jet path would see) equals the analytic Jacobians.
TEST_P(ImuModelTest, JetEvaluationEqualsDoubleAndAnalyticJacobians) {
  constexpr int N = 42;  // 9 + 9 + 9 + 3 + 3 + 3 + 6 at most
  using Jet = ceres::Jet<double, N>;
  for (Direction d : {Direction::kRawFromTrue, Direction::kTrueFromRaw}) {
    const ImuIntrinsics x = RandomImuIntrinsics(model(), g(), rng_);
    const Point p = RandomPoint(rng_);
    const ImuModelLayout& L = x.layout();
    const ImuBlocks<double> b = x.blocks();

    int offset = 0;
    auto jets = [&](const double* v, int n, Jet* out) {
      for (int k = 0; k < n; ++k)
        out[k] = Jet(v[k], offset + k);
      offset += n;
    };
    Jet Dw[9], Da[9], Tg[9], q[4];
    const int off_Dw = offset;
    jets(b.Dw, x.DwSize(), Dw);
    const int off_Da = offset;
    jets(b.Da, x.DaSize(), Da);
    const int off_Tg = offset;
    jets(b.Tg, x.TgSize(), Tg);
    const int off_rot = offset;
    if (L.HasRotation()) {
      // q = Exp(delta) q_hat at delta = 0: the Jet derivatives are on the manifold's tangent.
      Vec3T<Jet> delta;
      for (int k = 0; k < 3; ++k)
        delta(k) = Jet(0.0, offset + k);
      offset += 3;
      const QuatT<Jet> q_jet =
          ExpSO3<Jet>(delta) * Eigen::Map<const Eigen::Quaterniond>(b.q_rotation).cast<Jet>();
      for (int k = 0; k < 4; ++k)
        q[k] = q_jet.coeffs()(k);
    }
    Vec3T<Jet> b_g, b_a, w, a;
    const int off_bg = offset;
    jets(p.b_g.data(), 3, b_g.data());
    const int off_ba = offset;
    jets(p.b_a.data(), 3, b_a.data());
    const int off_in = offset;
    jets(p.w.data(), 3, w.data());
    jets(p.a.data(), 3, a.data());
    ASSERT_LE(offset, N);

    ImuBlocks<Jet> bj;
    bj.Dw = x.DwSize() ? Dw : nullptr;
    bj.Da = x.DaSize() ? Da : nullptr;
    bj.Tg = x.TgSize() ? Tg : nullptr;
    bj.q_rotation = L.HasRotation() ? q : nullptr;
    Vec3T<Jet> out_w, out_a;
    if (d == Direction::kRawFromTrue)
      ImuRawFromTrue<Jet>(L, bj, w, a, b_g, b_a, &out_w, &out_a);
    else
      ImuTrueFromRaw<Jet>(L, bj, w, a, b_g, b_a, &out_w, &out_a);

    ImuMatrixJacobian J_Dw, J_Da, J_Tg;
    Eigen::Matrix<double, 6, 3> J_rot, J_bg, J_ba;
    Eigen::Matrix<double, 6, 6> J_in;
    ImuJacobians J{&J_Dw, &J_Da, &J_Tg, &J_rot, &J_bg, &J_ba, &J_in};
    const Vec6 y = Evaluate(x, d, p, J);
    Eigen::Matrix<double, 6, N> J_all = Eigen::Matrix<double, 6, N>::Zero();
    J_all.middleCols(off_Dw, x.DwSize()) = J_Dw;
    J_all.middleCols(off_Da, x.DaSize()) = J_Da;
    J_all.middleCols(off_Tg, x.TgSize()) = J_Tg;
    if (L.HasRotation())
      J_all.middleCols<3>(off_rot) = J_rot;
    J_all.middleCols<3>(off_bg) = J_bg;
    J_all.middleCols<3>(off_ba) = J_ba;
    J_all.middleCols<6>(off_in) = J_in;

    for (int r = 0; r < 6; ++r) {
      const Jet& o = r < 3 ? out_w(r) : out_a(r - 3);
      EXPECT_NEAR(o.a, y(r), 1e-13 * (1.0 + std::abs(y(r)))) << "row " << r;
      EXPECT_LT((o.v.transpose() - J_all.row(r)).cwiseAbs().maxCoeff(), 1e-12) << "row " << r;
    }
  }
}

TEST_P(ImuModelTest, CorrectionInvertsMeasurement) {
  for (int trial = 0; trial < 20; ++trial) {
    const ImuIntrinsics x = RandomImuIntrinsics(model(), g(), rng_);
    const Point p = RandomPoint(rng_);
    Vector3d w_m, a_m, w_I, a_I;
    x.RawFromTrue(p.w, p.a, p.b_g, p.b_a, &w_m, &a_m);
    x.TrueFromRaw(w_m, a_m, p.b_g, p.b_a, &w_I, &a_I);
    EXPECT_LT((w_I - p.w).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((a_I - p.a).cwiseAbs().maxCoeff(), 1e-12);
    // And the other way round, on the templated path.
    Vector3d w_m2, a_m2;
    ImuRawFromTrue<double>(x.layout(), x.blocks(), w_I, a_I, p.b_g, p.b_a, &w_m2, &a_m2);
    EXPECT_LT((w_m2 - w_m).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((a_m2 - a_m).cwiseAbs().maxCoeff(), 1e-12);
  }
}

// The model against SPEC section 3's equations written out with the public matrices.
TEST_P(ImuModelTest, MatchesSpecEquations) {
  const ImuIntrinsics x = RandomImuIntrinsics(model(), g(), rng_);
  const Point p = RandomPoint(rng_);
  const Matrix3d T_w = x.D_w().inverse(), T_a = x.D_a().inverse();
  const Vector3d w_m_spec = T_w * x.R_I_w().transpose() * p.w + x.T_g() * p.a + p.b_g;
  const Vector3d a_m_spec = T_a * x.R_I_a().transpose() * p.a + p.b_a;
  Vector3d w_m, a_m;
  x.RawFromTrue(p.w, p.a, p.b_g, p.b_a, &w_m, &a_m);
  EXPECT_LT((w_m - w_m_spec).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((a_m - a_m_spec).cwiseAbs().maxCoeff(), 1e-12);
  // Only imu1 has R_I_w and only imu2 R_I_a; the other matrices follow the layout.
  const bool r_w = model() == ImuModel::kImu1, r_a = model() == ImuModel::kImu2;
  EXPECT_EQ(x.R_I_w().isIdentity(0.0), !r_w);
  EXPECT_EQ(x.R_I_a().isIdentity(0.0), !r_a);
  EXPECT_EQ(x.T_g().isZero(0.0), g() == GSensitivity::kNone);
  EXPECT_EQ(x.D_w().isIdentity(0.0), model() == ImuModel::kNone);
}

TEST_P(ImuModelTest, StoredFormRoundTripsExactly) {
  const ImuIntrinsics x = RandomImuIntrinsics(model(), g(), rng_);
  const StoredImuIntrinsics s = x.ToStored();
  const ImuModelLayout& L = x.layout();
  EXPECT_EQ(static_cast<int>(s.Dw.size()), StoredSize(L.Dw));
  EXPECT_EQ(static_cast<int>(s.Da.size()), StoredSize(L.Da));
  EXPECT_EQ(static_cast<int>(s.Tg.size()), StoredSize(L.Tg));
  EXPECT_EQ(s.rotation.has_value(), L.HasRotation());
  const ImuIntrinsics y = ImuIntrinsics::FromStored(model(), g(), s);
  const StoredImuIntrinsics t = y.ToStored();
  EXPECT_EQ(s.Dw, t.Dw);
  EXPECT_EQ(s.Da, t.Da);
  EXPECT_EQ(s.Tg, t.Tg);
  EXPECT_EQ(x.D_w(), y.D_w());
  EXPECT_EQ(x.D_a(), y.D_a());
  EXPECT_EQ(x.T_g(), y.T_g());
  if (L.HasRotation()) {
    // Matrix -> quaternion -> matrix is exact up to rounding.
    EXPECT_LT((*s.rotation - *t.rotation).cwiseAbs().maxCoeff(), 4 * 2.3e-16);
    EXPECT_LT((s.rotation->transpose() * *s.rotation - Matrix3d::Identity()).norm(), 1e-15);
  }
  // Absent keys mean identity D, zero T_g and identity rotation.
  const ImuIntrinsics defaults = ImuIntrinsics::FromStored(model(), g(), {});
  EXPECT_TRUE(defaults.D_w().isIdentity(0.0));
  EXPECT_TRUE(defaults.D_a().isIdentity(0.0));
  EXPECT_TRUE(defaults.T_g().isZero(0.0));
  EXPECT_TRUE(defaults.R_I_w().isIdentity(0.0));
  EXPECT_TRUE(defaults.R_I_a().isIdentity(0.0));
}

// Each stored block is a Ceres parameter block: its pointer is present exactly when the model
// has it, and writing through it changes the model.
TEST_P(ImuModelTest, ParameterBlocksFollowTheLayout) {
  ImuIntrinsics x(model(), g());
  const ImuModelLayout& L = x.layout();
  EXPECT_EQ(x.Dw() != nullptr, L.Dw != MatrixForm::kAbsent);
  EXPECT_EQ(x.Da() != nullptr, L.Da != MatrixForm::kAbsent);
  EXPECT_EQ(x.Tg() != nullptr, L.Tg != MatrixForm::kAbsent);
  EXPECT_EQ(x.q_rotation() != nullptr, L.HasRotation());
  const int expected_Dw = model() == ImuModel::kNone ? 0 : (model() == ImuModel::kImu3 ? 9 : 6);
  const int expected_Da = model() == ImuModel::kNone ? 0 : (model() == ImuModel::kImu4 ? 9 : 6);
  const int expected_Tg = g() == GSensitivity::kNone ? 0 : (g() == GSensitivity::kUpper ? 6 : 9);
  EXPECT_EQ(x.DwSize(), expected_Dw);
  EXPECT_EQ(x.DaSize(), expected_Da);
  EXPECT_EQ(x.TgSize(), expected_Tg);
  if (x.Dw()) {
    x.Dw()[x.DwSize() - 1] = 2.0;  // d33 in both forms
    EXPECT_EQ(x.D_w()(2, 2), 2.0);
  }
}

INSTANTIATE_TEST_SUITE_P(
    AllModels, ImuModelTest,
    ::testing::Combine(::testing::Values(ImuModel::kNone, ImuModel::kImu1, ImuModel::kImu2,
                                         ImuModel::kImu3, ImuModel::kImu4),
                       ::testing::Values(GSensitivity::kNone, GSensitivity::kUpper,
                                         GSensitivity::kFull)),
    CaseName);

// --- Frames -------------------------------------------------------------------------------------

// imu2 with identity D: I is the gyroscope frame and the accelerometer reads a_a = R_a_I a_I, so
// the correction rotates its reading back by R_I_a.
TEST(ImuFrames, Imu2RotatesTheAccelerometerIntoTheGyroscopeFrame) {
  std::mt19937 rng(1);
  ImuIntrinsics x(ImuModel::kImu2);
  const Matrix3d R_I_a = RandomRotation(rng);
  x.SetRotation(R_I_a);
  const Vector3d w_m = RandomVector(rng, 2.0), a_m = RandomVector(rng, 10.0), zero(0, 0, 0);
  Vector3d w_I, a_I;
  x.TrueFromRaw(w_m, a_m, zero, zero, &w_I, &a_I);
  EXPECT_LT((a_I - R_I_a * a_m).norm(), 1e-14);
  EXPECT_LT((w_I - w_m).norm(), 1e-15);  // the gyroscope triad is the frame
}

// imu1: I is the accelerometer frame, and the gyroscope is the rotated triad.
TEST(ImuFrames, Imu1RotatesTheGyroscopeIntoTheAccelerometerFrame) {
  std::mt19937 rng(2);
  ImuIntrinsics x(ImuModel::kImu1);
  const Matrix3d R_I_w = RandomRotation(rng);
  x.SetRotation(R_I_w);
  const Vector3d w_m = RandomVector(rng, 2.0), a_m = RandomVector(rng, 10.0), zero(0, 0, 0);
  Vector3d w_I, a_I;
  x.TrueFromRaw(w_m, a_m, zero, zero, &w_I, &a_I);
  EXPECT_LT((w_I - R_I_w * w_m).norm(), 1e-14);
  EXPECT_LT((a_I - a_m).norm(), 1e-15);
}

// imu3 / imu4: the full D of one triad absorbs its rotation (D_w = R_I_w for a perfect gyroscope).
TEST(ImuFrames, FullDAbsorbsTheRotation) {
  std::mt19937 rng(3);
  const Matrix3d R = RandomRotation(rng);
  const Vector3d w_m = RandomVector(rng, 2.0), a_m = RandomVector(rng, 10.0), zero(0, 0, 0);
  Vector3d w_I, a_I;
  ImuIntrinsics x3(ImuModel::kImu3);
  x3.SetD_w(R);
  x3.TrueFromRaw(w_m, a_m, zero, zero, &w_I, &a_I);
  EXPECT_LT((w_I - R * w_m).norm(), 1e-14);
  ImuIntrinsics x4(ImuModel::kImu4);
  x4.SetD_a(R);
  x4.TrueFromRaw(w_m, a_m, zero, zero, &w_I, &a_I);
  EXPECT_LT((a_I - R * a_m).norm(), 1e-13);
}

// SPEC section 1: with an upper-triangular D, the frame's z axis is the triad's z (sensitive)
// axis and its y axis lies in the triad's y-z plane. So a true rate along I's x or y leaves the
// triad's z reading at zero, and a rate along I's x leaves its y reading at zero.
TEST(ImuFrames, UpperTriangularDFixesZAxisAndYzPlane) {
  std::mt19937 rng(4);
  ImuIntrinsics x(ImuModel::kImu2);
  x.SetD_w(test::RandomScaleMatrix(rng, MatrixForm::kUpper));
  const Vector3d zero(0, 0, 0);
  Vector3d w_m, a_m;
  x.RawFromTrue(Vector3d::UnitX(), zero, zero, zero, &w_m, &a_m);
  EXPECT_EQ(w_m.y(), 0.0);
  EXPECT_EQ(w_m.z(), 0.0);
  EXPECT_GT(w_m.x(), 0.0);
  x.RawFromTrue(Vector3d::UnitY(), zero, zero, zero, &w_m, &a_m);
  EXPECT_EQ(w_m.z(), 0.0);
  EXPECT_NE(w_m.x(), 0.0);  // the misalignment shows on the x triad axis
}

// g-sensitivity: a gyroscope at rest reads T_g a_I, nothing else.
TEST(ImuFrames, GSensitivityAddsTgTimesSpecificForce) {
  ImuIntrinsics x(ImuModel::kImu2, GSensitivity::kFull);
  Matrix3d T_g;
  T_g << 1e-3, 2e-3, 3e-3, 4e-3, 5e-3, 6e-3, 7e-3, 8e-3, 9e-3;
  x.SetT_g(T_g);
  const Vector3d a_I(0.0, 0.0, 9.81), zero(0, 0, 0);
  Vector3d w_m, a_m;
  x.RawFromTrue(zero, a_I, zero, zero, &w_m, &a_m);
  EXPECT_LT((w_m - Vector3d(3e-3, 6e-3, 9e-3) * 9.81).norm(), 1e-15);
}

// --- Bad stored forms ---------------------------------------------------------------------------

std::string ErrorOf(ImuModel m, GSensitivity g, const StoredImuIntrinsics& s) {
  try {
    ImuIntrinsics::FromStored(m, g, s);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(ImuStoredForm, RejectsWrongCounts) {
  StoredImuIntrinsics s;
  s.Dw = {1, 0, 1, 0, 0, 1, 0, 0, 0};
  EXPECT_THAT(ErrorOf(ImuModel::kImu2, GSensitivity::kNone, s),
              HasSubstr("Dw: expected 6 numbers (upper-triangular as 6 numbers [d11, d12, d22, "
                        "d13, d23, d33]), got 9"));
  s = {};
  s.Dw = {1, 0, 1, 0, 0, 1};
  EXPECT_THAT(ErrorOf(ImuModel::kImu3, GSensitivity::kNone, s),
              HasSubstr("Dw: expected 9 numbers (full as 9 numbers, row-major), got 6"));
  s = {};
  s.Tg = {0, 0, 0, 0, 0};
  EXPECT_THAT(ErrorOf(ImuModel::kImu2, GSensitivity::kFull, s),
              HasSubstr("Tg: expected 9 numbers"));
}

TEST(ImuStoredForm, RejectsBlocksTheModelDoesNotHave) {
  StoredImuIntrinsics s;
  s.Dw = {1, 0, 1, 0, 0, 1};
  EXPECT_THAT(ErrorOf(ImuModel::kNone, GSensitivity::kNone, s),
              HasSubstr("Dw: model none has no Dw"));
  s = {};
  s.Tg = {0, 0, 0, 0, 0, 0};
  EXPECT_THAT(ErrorOf(ImuModel::kImu2, GSensitivity::kNone, s),
              HasSubstr("Tg: g_sensitivity none has no Tg"));
  s = {};
  s.rotation = Matrix3d::Identity();
  EXPECT_THAT(ErrorOf(ImuModel::kImu3, GSensitivity::kNone, s),
              HasSubstr("model imu3 has no rotation"));
}

TEST(ImuStoredForm, RejectsNonFiniteNumbers) {
  StoredImuIntrinsics s;
  s.Da = {1, 0, 1, 0, std::numeric_limits<double>::quiet_NaN(), 1};
  EXPECT_THAT(ErrorOf(ImuModel::kImu2, GSensitivity::kNone, s),
              HasSubstr("Da[4] (d23) is not finite: nan"));
  s = {};
  s.Tg = {0, 0, 0, 0, 0, 0, 0, std::numeric_limits<double>::infinity(), 0};
  EXPECT_THAT(ErrorOf(ImuModel::kImu2, GSensitivity::kFull, s),
              HasSubstr("Tg[7] (row 3, column 2) is not finite: inf"));
}

TEST(ImuStoredForm, RejectsSingularAndReflectingD) {
  StoredImuIntrinsics s;
  s.Dw = {1, 0, 1, 0, 0, 0};
  EXPECT_THAT(ErrorOf(ImuModel::kImu2, GSensitivity::kNone, s), HasSubstr("Dw: is singular"));
  s.Dw = {1, 0, -1, 0, 0, 1};
  EXPECT_THAT(ErrorOf(ImuModel::kImu2, GSensitivity::kNone, s),
              HasSubstr("Dw: diagonal entry d22 = -1 must be positive"));
  s = {};
  s.Da = {1, 2, 3, 2, 4, 6, 0, 0, 1};  // rank 2
  EXPECT_THAT(ErrorOf(ImuModel::kImu4, GSensitivity::kNone, s), HasSubstr("Da: is singular"));
  s.Da = {0, 1, 0, 1, 0, 0, 0, 0, 1};  // a swap of two axes: a reflection
  EXPECT_THAT(ErrorOf(ImuModel::kImu4, GSensitivity::kNone, s),
              HasSubstr("Da: determinant -1 must be positive"));
}

TEST(ImuStoredForm, RejectsRotationsThatAreNotRotations) {
  StoredImuIntrinsics s;
  s.rotation = Matrix3d::Identity() * 1.01;
  EXPECT_THAT(ErrorOf(ImuModel::kImu2, GSensitivity::kNone, s),
              HasSubstr("R_I_a: is not a rotation (|R^T R - I| ="));
  s.rotation = Matrix3d(Vector3d(1, 1, -1).asDiagonal());
  EXPECT_THAT(ErrorOf(ImuModel::kImu1, GSensitivity::kNone, s),
              HasSubstr("R_I_w: is not a rotation (determinant -1, a reflection)"));
  s.rotation = Matrix3d::Identity();
  (*s.rotation)(0, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT(ErrorOf(ImuModel::kImu2, GSensitivity::kNone, s),
              HasSubstr("R_I_a: has a non-finite entry"));
}

TEST(ImuStoredForm, SettersRejectMatricesOutsideTheModel) {
  ImuIntrinsics x(ImuModel::kImu2, GSensitivity::kUpper);
  Matrix3d D = Matrix3d::Identity();
  D(2, 0) = 0.01;
  EXPECT_THROW(x.SetD_w(D), std::invalid_argument);
  Matrix3d T = Matrix3d::Zero();
  T(1, 0) = 1e-3;
  EXPECT_THROW(x.SetT_g(T), std::invalid_argument);
  ImuIntrinsics none(ImuModel::kNone);
  EXPECT_THROW(none.SetD_a(D), std::invalid_argument);
  EXPECT_NO_THROW(none.SetD_a(Matrix3d::Identity()));
}

}  // namespace
}  // namespace ctcal
