// The gyroscope-only model (SPEC section 3, type gyro) for every model none|upper|full: analytic
// Jacobians against central differences, Jet against double, round trips, stored forms.
#include "ctcal/sensors/gyro_intrinsics.h"

#include <ceres/jet.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <limits>
#include <ostream>
#include <random>
#include <string>

#include "imu_test_util.h"

namespace ctcal {

inline void PrintTo(GyroModel m, std::ostream* os) {
  *os << ToString(m);
}

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using test::CentralDifferences;
using test::RandomScaleMatrix;
using test::RandomVector;
using ::testing::HasSubstr;

GyroIntrinsics RandomGyro(GyroModel m, std::mt19937& rng) {
  GyroIntrinsics g(m);
  if (m != GyroModel::kNone)
    g.SetD_w(RandomScaleMatrix(rng, GyroDwForm(m)));
  return g;
}

class GyroModelTest : public ::testing::TestWithParam<GyroModel> {
 protected:
  std::mt19937 rng_{7};
};

TEST_P(GyroModelTest, JacobiansMatchCentralDifferences) {
  const double h = 1e-6, tol = 1e-8;
  for (bool raw_from_true : {true, false}) {
    for (int trial = 0; trial < 5; ++trial) {
      const GyroIntrinsics g0 = RandomGyro(GetParam(), rng_);
      const Vector3d in0 = RandomVector(rng_, 3.0), b0 = RandomVector(rng_, 0.05);
      auto eval = [&](const GyroIntrinsics& g, const Vector3d& in, const Vector3d& b,
                      const GyroJacobians& J = {}) {
        return raw_from_true ? g.RawFromTrue(in, b, J) : g.TrueFromRaw(in, b, J);
      };
      GyroMatrixJacobian J_Dw;
      Matrix3d J_bg, J_in;
      eval(g0, in0, b0, GyroJacobians{&J_Dw, &J_bg, &J_in});
      ASSERT_EQ(J_Dw.cols(), g0.DwSize());
      if (g0.DwSize() > 0) {
        const auto num = CentralDifferences<3>(g0.DwSize(), h, [&](int k, double s) {
          GyroIntrinsics g = g0;
          g.Dw()[k] += s;
          return Vector3d(eval(g, in0, b0));
        });
        EXPECT_LT((J_Dw - num).cwiseAbs().maxCoeff(), tol);
      }
      const auto num_b = CentralDifferences<3>(3, h, [&](int k, double s) {
        return Vector3d(eval(g0, in0, b0 + s * Vector3d::Unit(k)));
      });
      const auto num_in = CentralDifferences<3>(3, h, [&](int k, double s) {
        return Vector3d(eval(g0, in0 + s * Vector3d::Unit(k), b0));
      });
      EXPECT_LT((J_bg - num_b).cwiseAbs().maxCoeff(), tol);
      EXPECT_LT((J_in - num_in).cwiseAbs().maxCoeff(), tol);
    }
  }
}

TEST_P(GyroModelTest, JetEvaluationEqualsDoubleAndAnalyticJacobians) {
  using Jet = ceres::Jet<double, 15>;  // D_w 9, b_g 3, input 3
  const GyroIntrinsics g = RandomGyro(GetParam(), rng_);
  const Vector3d in = RandomVector(rng_, 3.0), b = RandomVector(rng_, 0.05);
  Jet Dw[9];
  for (int k = 0; k < g.DwSize(); ++k)
    Dw[k] = Jet(g.Dw()[k], k);
  Vec3T<Jet> in_j, b_j;
  for (int k = 0; k < 3; ++k) {
    b_j(k) = Jet(b(k), 9 + k);
    in_j(k) = Jet(in(k), 12 + k);
  }
  for (bool raw_from_true : {true, false}) {
    const Jet* dw = g.DwSize() ? Dw : nullptr;
    const Vec3T<Jet> out = raw_from_true ? GyroRawFromTrue<Jet>(g.model(), dw, in_j, b_j)
                                         : GyroTrueFromRaw<Jet>(g.model(), dw, in_j, b_j);
    GyroMatrixJacobian J_Dw;
    Matrix3d J_bg, J_in;
    const GyroJacobians J{&J_Dw, &J_bg, &J_in};
    const Vector3d y = raw_from_true ? g.RawFromTrue(in, b, J) : g.TrueFromRaw(in, b, J);
    for (int r = 0; r < 3; ++r) {
      EXPECT_NEAR(out(r).a, y(r), 1e-14);
      if (g.DwSize() > 0) {
        EXPECT_LT((out(r).v.head(g.DwSize()).transpose() - J_Dw.row(r)).cwiseAbs().maxCoeff(),
                  1e-13);
      }
      EXPECT_LT((out(r).v.segment<3>(9).transpose() - J_bg.row(r)).cwiseAbs().maxCoeff(), 1e-13);
      EXPECT_LT((out(r).v.segment<3>(12).transpose() - J_in.row(r)).cwiseAbs().maxCoeff(), 1e-13);
    }
  }
}

TEST_P(GyroModelTest, CorrectionInvertsMeasurement) {
  for (int trial = 0; trial < 20; ++trial) {
    const GyroIntrinsics g = RandomGyro(GetParam(), rng_);
    const Vector3d w_G = RandomVector(rng_, 3.0), b_g = RandomVector(rng_, 0.05);
    const Vector3d w_m = g.RawFromTrue(w_G, b_g);
    EXPECT_LT((g.TrueFromRaw(w_m, b_g) - w_G).cwiseAbs().maxCoeff(), 1e-12);
    // SPEC: w_m = D_w^-1 w_G + b_g.
    EXPECT_LT((w_m - (g.D_w().inverse() * w_G + b_g)).cwiseAbs().maxCoeff(), 1e-12);
  }
}

TEST_P(GyroModelTest, StoredFormRoundTripsExactly) {
  const GyroIntrinsics g = RandomGyro(GetParam(), rng_);
  const std::vector<double> s = g.ToStored();
  EXPECT_EQ(static_cast<int>(s.size()), StoredSize(GyroDwForm(GetParam())));
  const GyroIntrinsics h = GyroIntrinsics::FromStored(GetParam(), s);
  EXPECT_EQ(h.ToStored(), s);
  EXPECT_EQ(h.D_w(), g.D_w());
  EXPECT_TRUE(GyroIntrinsics::FromStored(GetParam(), {}).D_w().isIdentity(0.0));
}

std::string GyroCaseName(const ::testing::TestParamInfo<GyroModel>& p) {
  return ToString(p.param);
}

INSTANTIATE_TEST_SUITE_P(AllModels, GyroModelTest,
                         ::testing::Values(GyroModel::kNone, GyroModel::kUpper, GyroModel::kFull),
                         GyroCaseName);

std::string ErrorOf(GyroModel m, const std::vector<double>& Dw) {
  try {
    GyroIntrinsics::FromStored(m, Dw);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(GyroStoredForm, RejectsBadDw) {
  EXPECT_THAT(ErrorOf(GyroModel::kNone, {1, 0, 1, 0, 0, 1}),
              HasSubstr("Dw: gyroscope model none has no Dw"));
  EXPECT_THAT(ErrorOf(GyroModel::kUpper, {1, 0, 1}), HasSubstr("Dw: expected 6 numbers"));
  EXPECT_THAT(ErrorOf(GyroModel::kFull, {1, 0, 0, 0, 1, 0, 0, 0}),
              HasSubstr("Dw: expected 9 numbers"));
  EXPECT_THAT(ErrorOf(GyroModel::kUpper, {1, 0, 1, 0, 0, std::numeric_limits<double>::infinity()}),
              HasSubstr("Dw[5] (d33) is not finite: inf"));
  EXPECT_THAT(ErrorOf(GyroModel::kUpper, {0, 0, 1, 0, 0, 1}), HasSubstr("Dw: is singular"));
  EXPECT_THAT(ErrorOf(GyroModel::kFull, {-1, 0, 0, 0, 1, 0, 0, 0, 1}),
              HasSubstr("Dw: determinant -1 must be positive"));
  EXPECT_EQ(ErrorOf(GyroModel::kFull, {0, -1, 0, 1, 0, 0, 0, 0, 1}), "(accepted)");  // a rotation
}

}  // namespace
}  // namespace ctcal
