// The stored forms of SPEC section 3: column-wise upper-triangular 6, row-major full 9.
#include "ctcal/sensors/stored_matrix.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <vector>

namespace ctcal {
namespace {

using Eigen::Matrix3d;
using ::testing::HasSubstr;

TEST(StoredMatrix, UpperIsColumnWise) {
  // [d11, d12, d22, d13, d23, d33] = [1, 2, 3, 4, 5, 6].
  const std::vector<double> s = {1, 2, 3, 4, 5, 6};
  Matrix3d expected;
  expected << 1, 2, 4, 0, 3, 5, 0, 0, 6;
  EXPECT_EQ(MatrixFromStored<double>(MatrixForm::kUpper, s.data(), Matrix3d::Zero()), expected);
  EXPECT_EQ(StoredFromMatrix(MatrixForm::kUpper, expected), s);
}

TEST(StoredMatrix, FullIsRowMajor) {
  const std::vector<double> s = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  Matrix3d expected;
  expected << 1, 2, 3, 4, 5, 6, 7, 8, 9;
  EXPECT_EQ(MatrixFromStored<double>(MatrixForm::kFull, s.data(), Matrix3d::Zero()), expected);
  EXPECT_EQ(StoredFromMatrix(MatrixForm::kFull, expected), s);
}

TEST(StoredMatrix, AbsentIsTheGivenDefault) {
  EXPECT_EQ(MatrixFromStored<double>(MatrixForm::kAbsent, nullptr, Matrix3d::Identity()),
            Matrix3d::Identity());
  EXPECT_TRUE(StoredFromMatrix(MatrixForm::kAbsent, Matrix3d::Identity()).empty());
}

TEST(StoredMatrix, IndexMapsCoverEachStoredEntryOnce) {
  for (MatrixForm f : {MatrixForm::kUpper, MatrixForm::kFull}) {
    Matrix3d seen = Matrix3d::Zero();
    for (int k = 0; k < StoredSize(f); ++k) {
      ASSERT_LE(StoredRow(f, k), StoredCol(f, k) + (f == MatrixForm::kFull ? 2 : 0));
      seen(StoredRow(f, k), StoredCol(f, k)) += 1.0;
    }
    EXPECT_EQ(seen.sum(), StoredSize(f));
    EXPECT_EQ(seen.maxCoeff(), 1.0);
  }
}

TEST(StoredMatrix, Representability) {
  Matrix3d M = Matrix3d::Identity();
  M(0, 2) = 0.1;
  EXPECT_TRUE(IsRepresentable(MatrixForm::kUpper, M, Matrix3d::Identity()));
  M(2, 0) = 1e-300;  // any non-zero strictly lower entry, however small
  EXPECT_FALSE(IsRepresentable(MatrixForm::kUpper, M, Matrix3d::Identity()));
  EXPECT_TRUE(IsRepresentable(MatrixForm::kFull, M, Matrix3d::Identity()));
  EXPECT_FALSE(IsRepresentable(MatrixForm::kAbsent, M, Matrix3d::Identity()));
}

TEST(StoredMatrix, CheckedRotationReturnsTheSameRotation) {
  const Eigen::Quaterniond q0 = Eigen::Quaterniond(0.3, -0.5, 0.7, 0.1).normalized();
  const Eigen::Quaterniond q = CheckedRotation(q0.toRotationMatrix(), "R_I_a");
  EXPECT_LT((q.toRotationMatrix() - q0.toRotationMatrix()).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_THAT(
      [] {
        try {
          CheckedRotation(Matrix3d::Zero(), "R_I_w");
        } catch (const std::invalid_argument& e) {
          return std::string(e.what());
        }
        return std::string();
      }(),
      HasSubstr("R_I_w: is not a rotation"));
}

}  // namespace
}  // namespace ctcal

namespace ctcal {
namespace {

TEST(StoredMatrix, ScaleMatrixInverseIsTheInverse) {
  Eigen::Matrix3d D;
  D << 1.02, -0.03, 0.05, 0.0, 0.97, 0.011, 0.0, 0.0, 1.004;
  const Eigen::Matrix3d T = ScaleMatrixInverse(MatrixForm::kUpper, D);
  EXPECT_LT((T * D - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_TRUE(Eigen::Matrix3d(T.triangularView<Eigen::StrictlyLower>()).isZero(0.0));
  D(2, 0) = 0.02;
  EXPECT_LT((ScaleMatrixInverse(MatrixForm::kFull, D) * D - Eigen::Matrix3d::Identity())
                .cwiseAbs()
                .maxCoeff(),
            1e-15);
  EXPECT_EQ(ScaleMatrixInverse(MatrixForm::kAbsent, D), Eigen::Matrix3d::Identity());
}

}  // namespace
}  // namespace ctcal
