// Kalibr's scale-misalignment IMU model and its map to ours: Kalibr's own equations reproduced
// through our model for every target model, round trips both ways, hand-made cases, and the
// cases where no exact map exists.
#include "ctcal/sensors/kalibr_imu_model.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <ostream>
#include <random>
#include <string>

#include "imu_test_util.h"

namespace ctcal {

inline void PrintTo(ImuModel m, std::ostream* os) {
  *os << ToString(m);
}

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using test::RandomImuIntrinsics;
using test::RandomMatrix;
using test::RandomRotation;
using test::RandomVector;
using ::testing::HasSubstr;

// A Kalibr result as Kalibr produces it: lower-triangular M's near the identity, a full A, a
// rotation C_gyro_i.
KalibrScaleMisalignment RandomKalibr(std::mt19937& rng) {
  KalibrScaleMisalignment k;
  k.M_gyro =
      Matrix3d((Matrix3d::Identity() + RandomMatrix(rng, 0.05)).triangularView<Eigen::Lower>());
  k.M_accel =
      Matrix3d((Matrix3d::Identity() + RandomMatrix(rng, 0.05)).triangularView<Eigen::Lower>());
  k.A_gyro = RandomMatrix(rng, 0.01);
  k.C_gyro_i = RandomRotation(rng);
  return k;
}

// Kalibr's prediction (IccSensors.py, IccScaledMisalignedImu) in its frame i.
void KalibrRaw(const KalibrScaleMisalignment& k, const Vector3d& w_i, const Vector3d& a_i,
               const Vector3d& b_g, const Vector3d& b_a, Vector3d* w_m, Vector3d* a_m) {
  *w_m = k.M_gyro * (k.C_gyro_i * w_i) + k.A_gyro * (k.C_gyro_i * a_i) + b_g;
  *a_m = k.M_accel * a_i + b_a;
}

double MaxAbs(const Matrix3d& M) {
  return M.cwiseAbs().maxCoeff();
}

class KalibrMapTest : public ::testing::TestWithParam<ImuModel> {
 protected:
  std::mt19937 rng_{99};
};

// Import, then our measurement model of the rotated true signals equals Kalibr's raw readings.
TEST_P(KalibrMapTest, ImportReproducesKalibrsEquations) {
  for (int trial = 0; trial < 10; ++trial) {
    const KalibrScaleMisalignment k = RandomKalibr(rng_);
    const KalibrImuImport imported = FromKalibrScaleMisalignment(k, GetParam());
    EXPECT_LT(MaxAbs(imported.R_I_i.transpose() * imported.R_I_i - Matrix3d::Identity()), 1e-14);
    EXPECT_NEAR(imported.R_I_i.determinant(), 1.0, 1e-14);
    for (int s = 0; s < 5; ++s) {
      const Vector3d w_i = RandomVector(rng_, 3.0), a_i = RandomVector(rng_, 12.0);
      const Vector3d b_g = RandomVector(rng_, 0.05), b_a = RandomVector(rng_, 0.3);
      Vector3d w_k, a_k, w_m, a_m;
      KalibrRaw(k, w_i, a_i, b_g, b_a, &w_k, &a_k);
      imported.intrinsics.RawFromTrue(imported.R_I_i * w_i, imported.R_I_i * a_i, b_g, b_a, &w_m,
                                      &a_m);
      EXPECT_LT((w_m - w_k).cwiseAbs().maxCoeff(), 1e-12);
      EXPECT_LT((a_m - a_k).cwiseAbs().maxCoeff(), 1e-12);
    }
  }
}

// Ours -> Kalibr (canonical lower-triangular form) -> ours gives back the same parameters and
// a consistent frame rotation; Kalibr's equations reproduce our raw readings.
TEST_P(KalibrMapTest, OursToKalibrAndBackIsExact) {
  for (int trial = 0; trial < 10; ++trial) {
    const ImuIntrinsics x = RandomImuIntrinsics(GetParam(), GSensitivity::kFull, rng_);
    Matrix3d R_i_I;
    const KalibrScaleMisalignment k = ToKalibrScaleMisalignment(x, &R_i_I);
    for (const Matrix3d* M : {&k.M_gyro, &k.M_accel}) {
      EXPECT_EQ((*M)(0, 1), 0.0);
      EXPECT_EQ((*M)(0, 2), 0.0);
      EXPECT_EQ((*M)(1, 2), 0.0);
      EXPECT_GT(M->diagonal().minCoeff(), 0.0);
    }
    EXPECT_LT(MaxAbs(k.C_gyro_i.transpose() * k.C_gyro_i - Matrix3d::Identity()), 1e-14);

    const Vector3d w_I = RandomVector(rng_, 3.0), a_I = RandomVector(rng_, 12.0);
    const Vector3d b_g = RandomVector(rng_, 0.05), b_a = RandomVector(rng_, 0.3);
    Vector3d w_k, a_k, w_m, a_m;
    x.RawFromTrue(w_I, a_I, b_g, b_a, &w_m, &a_m);
    KalibrRaw(k, R_i_I * w_I, R_i_I * a_I, b_g, b_a, &w_k, &a_k);
    EXPECT_LT((w_m - w_k).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((a_m - a_k).cwiseAbs().maxCoeff(), 1e-12);

    const KalibrImuImport back = FromKalibrScaleMisalignment(k, GetParam(), GSensitivity::kFull);
    EXPECT_LT(MaxAbs(back.R_I_i - R_i_I.transpose()), 1e-13);
    EXPECT_LT(MaxAbs(back.intrinsics.D_w() - x.D_w()), 1e-13);
    EXPECT_LT(MaxAbs(back.intrinsics.D_a() - x.D_a()), 1e-13);
    EXPECT_LT(MaxAbs(back.intrinsics.T_g() - x.T_g()), 1e-13);
    EXPECT_LT(MaxAbs(back.intrinsics.R_I_w() - x.R_I_w()), 1e-13);
    EXPECT_LT(MaxAbs(back.intrinsics.R_I_a() - x.R_I_a()), 1e-13);
  }
}

// Kalibr (lower-triangular, as Kalibr writes it) -> ours -> Kalibr gives back Kalibr's numbers.
TEST_P(KalibrMapTest, KalibrToOursAndBackIsExact) {
  for (int trial = 0; trial < 10; ++trial) {
    const KalibrScaleMisalignment k = RandomKalibr(rng_);
    const KalibrImuImport imported = FromKalibrScaleMisalignment(k, GetParam());
    Matrix3d R_i_I;
    const KalibrScaleMisalignment back = ToKalibrScaleMisalignment(imported.intrinsics, &R_i_I);
    EXPECT_LT(MaxAbs(R_i_I - imported.R_I_i.transpose()), 1e-13);
    EXPECT_LT(MaxAbs(back.M_gyro - k.M_gyro), 1e-13);
    EXPECT_LT(MaxAbs(back.M_accel - k.M_accel), 1e-13);
    EXPECT_LT(MaxAbs(back.A_gyro - k.A_gyro), 1e-13);
    EXPECT_LT(MaxAbs(back.C_gyro_i - k.C_gyro_i), 1e-13);
  }
}

INSTANTIATE_TEST_SUITE_P(ImuModels, KalibrMapTest,
                         ::testing::Values(ImuModel::kImu1, ImuModel::kImu2, ImuModel::kImu3,
                                           ImuModel::kImu4),
                         [](const ::testing::TestParamInfo<ImuModel>& p) {
                           return ToString(p.param);
                         });

// Hand-made: pure scale factors and no misalignment. Kalibr's M's are diagonal, so every frame
// is the same and D = M^-1 entry by entry.
TEST(KalibrHandMade, DiagonalScalesMapToInverseScales) {
  KalibrScaleMisalignment k;
  k.M_gyro = Vector3d(1.01, 0.98, 1.002).asDiagonal();
  k.M_accel = Vector3d(0.99, 1.03, 1.0).asDiagonal();
  const KalibrImuImport x = FromKalibrScaleMisalignment(k, ImuModel::kImu2, GSensitivity::kNone);
  EXPECT_TRUE(x.R_I_i.isIdentity(1e-15));
  EXPECT_TRUE(x.intrinsics.R_I_a().isIdentity(1e-15));
  const std::vector<double> Dw = x.intrinsics.ToStored().Dw;
  const std::vector<double> Da = x.intrinsics.ToStored().Da;
  const std::vector<double> Dw_expected = {1 / 1.01, 0, 1 / 0.98, 0, 0, 1 / 1.002};
  const std::vector<double> Da_expected = {1 / 0.99, 0, 1 / 1.03, 0, 0, 1.0};
  for (int i = 0; i < 6; ++i) {
    EXPECT_NEAR(Dw[i], Dw_expected[i], 1e-15) << "Dw[" << i << "]";
    EXPECT_NEAR(Da[i], Da_expected[i], 1e-15) << "Da[" << i << "]";
  }
}

// Hand-made: perfect triads, the gyroscope turned 90 degrees about z against the accelerometer.
// imu2's frame is the gyroscope's, so R_I_i = C_gyro_i and R_I_a = R_gyro_accel = C_gyro_i;
// imu1's frame is the accelerometer's (= Kalibr's i), so R_I_i = I and R_I_w = C_gyro_i^T.
TEST(KalibrHandMade, RotatedGyroscope) {
  KalibrScaleMisalignment k;
  k.C_gyro_i << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  const KalibrImuImport imu2 = FromKalibrScaleMisalignment(k, ImuModel::kImu2, GSensitivity::kNone);
  EXPECT_LT(MaxAbs(imu2.R_I_i - k.C_gyro_i), 1e-15);
  EXPECT_LT(MaxAbs(imu2.intrinsics.R_I_a() - k.C_gyro_i), 1e-15);
  EXPECT_LT(MaxAbs(imu2.intrinsics.D_w() - Matrix3d::Identity()), 1e-15);
  EXPECT_LT(MaxAbs(imu2.intrinsics.D_a() - Matrix3d::Identity()), 1e-15);
  const KalibrImuImport imu1 = FromKalibrScaleMisalignment(k, ImuModel::kImu1, GSensitivity::kNone);
  EXPECT_LT(MaxAbs(imu1.R_I_i - Matrix3d::Identity()), 1e-15);
  EXPECT_LT(MaxAbs(imu1.intrinsics.R_I_w() - k.C_gyro_i.transpose()), 1e-15);
  // A g-sensitivity along Kalibr's gyro z axis stays on z: T_g = A C_gyro_i R_i_I.
  k.A_gyro = Matrix3d::Zero();
  k.A_gyro(2, 2) = 1e-3;
  const KalibrImuImport upper =
      FromKalibrScaleMisalignment(k, ImuModel::kImu2, GSensitivity::kUpper);
  EXPECT_NEAR(upper.intrinsics.T_g()(2, 2), 1e-3, 1e-18);
  EXPECT_LT(MaxAbs(upper.intrinsics.T_g() - k.A_gyro), 1e-18);
}

std::string ImportError(const KalibrScaleMisalignment& k, ImuModel m, GSensitivity g) {
  try {
    FromKalibrScaleMisalignment(k, m, g);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(KalibrLimits, InexactTargetsAreRejected) {
  std::mt19937 rng(5);
  const KalibrScaleMisalignment k = RandomKalibr(rng);
  EXPECT_THAT(ImportError(k, ImuModel::kImu2, GSensitivity::kNone),
              HasSubstr("gyroscopes.A: is not zero"));
  EXPECT_THAT(ImportError(k, ImuModel::kImu2, GSensitivity::kUpper),
              HasSubstr("gyroscopes.A: in our frame I the g-sensitivity"));
  EXPECT_THAT(ImportError(k, ImuModel::kNone, GSensitivity::kFull),
              HasSubstr("model none: Kalibr's gyroscopes.M"));
  // The identity Kalibr model fits model none.
  EXPECT_EQ(ImportError(KalibrScaleMisalignment{}, ImuModel::kNone, GSensitivity::kNone),
            "(accepted)");
}

TEST(KalibrLimits, BadKalibrMatricesAreRejected) {
  KalibrScaleMisalignment k;
  k.C_gyro_i = 1.1 * Matrix3d::Identity();
  EXPECT_THAT(ImportError(k, ImuModel::kImu2, GSensitivity::kFull),
              HasSubstr("gyroscopes.C_gyro_i: is not a rotation"));
  k = {};
  k.M_accel(1, 1) = 0.0;
  EXPECT_THAT(ImportError(k, ImuModel::kImu2, GSensitivity::kFull),
              HasSubstr("accelerometers.M: is singular"));
  k = {};
  k.M_gyro(0, 0) = -1.0;
  EXPECT_THAT(ImportError(k, ImuModel::kImu2, GSensitivity::kFull),
              HasSubstr("gyroscopes.M: determinant -1 must be positive"));
  k = {};
  k.A_gyro(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT(ImportError(k, ImuModel::kImu2, GSensitivity::kFull),
              HasSubstr("gyroscopes.A: has a non-finite entry"));
}

// The factorisations the map rests on: unique, a rotation times a triangle with positive diagonal.
TEST(KalibrFactorisations, RotationTimesTriangle) {
  std::mt19937 rng(6);
  for (int trial = 0; trial < 50; ++trial) {
    Matrix3d X = RandomRotation(rng) * (Matrix3d::Identity() + RandomMatrix(rng, 0.3));
    if (X.determinant() < 0)
      X.col(0) *= -1.0;
    Matrix3d Q, U, L;
    RotationUpperFactor(X, &Q, &U);
    EXPECT_LT(MaxAbs(Q * U - X), 1e-14);
    EXPECT_LT(MaxAbs(Q.transpose() * Q - Matrix3d::Identity()), 1e-14);
    EXPECT_NEAR(Q.determinant(), 1.0, 1e-14);
    EXPECT_TRUE(Matrix3d(U.triangularView<Eigen::StrictlyLower>()).isZero(0.0));
    EXPECT_GT(U.diagonal().minCoeff(), 0.0);
    RotationLowerFactor(X, &Q, &L);
    EXPECT_LT(MaxAbs(Q * L - X), 1e-14);
    EXPECT_NEAR(Q.determinant(), 1.0, 1e-14);
    EXPECT_TRUE(Matrix3d(L.triangularView<Eigen::StrictlyUpper>()).isZero(0.0));
    EXPECT_GT(L.diagonal().minCoeff(), 0.0);
  }
}

}  // namespace
}  // namespace ctcal
