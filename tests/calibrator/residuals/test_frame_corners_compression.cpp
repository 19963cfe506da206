// The frame's compression (frame_corners_compression.h) by the Gram matrix's Cholesky factor
// against Householder's QR of the same [J | e]: the same Gauss-Newton Hessian R^T R, gradient
// R^T z and cost ||r||^2 on a real frame's shape, with and without Huber; the QR taken where the
// Cholesky factor would not be accurate (nearly dependent columns) or cannot exist (fewer rows
// than columns); and the residual-only cost FrameCornersCostOf equal to the compressed ||r||^2.
#include "ctcal/calibrator/residuals/frame_corners_compression.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "ctcal/sensors/camera_pinhole.h"

namespace ctcal {
namespace {

using Model = PinholeModel<RadTanDistortion>;
constexpr int kNx = 6 + Model::kNumParams;
using MatR = Eigen::Matrix<double, kNx, kNx>;
using VecR = Eigen::Matrix<double, kNx + 1, 1>;
using MatA = Eigen::Matrix<double, Eigen::Dynamic, kNx + 1>;

// The Gauss-Newton quantities a factor stands for: R^T R, R^T z and ||r||^2.
struct Normal {
  MatR H;
  Eigen::Matrix<double, kNx, 1> g;
  double cost;
};

Normal NormalOf(const MatR& R, const VecR& r) {
  return {R.transpose() * R, R.transpose() * r.head<kNx>(), r.squaredNorm()};
}

double MaxAbs(const Eigen::MatrixXd& m) {
  return m.cwiseAbs().maxCoeff();
}

void ExpectSameNormal(const Normal& a, const Normal& b, double tol) {
  EXPECT_LT(MaxAbs(a.H - b.H), tol * MaxAbs(b.H));
  EXPECT_LT(MaxAbs(a.g - b.g), tol * MaxAbs(b.g));
  EXPECT_NEAR(a.cost, b.cost, tol * b.cost);
}

// A frame of M corners of a 7 x 6 board 0.6-1.2 m in front of a 752 x 480 pinhole-radtan
// camera, at a slightly wrong pose (residuals of a few pixels) plus 0.3 px noise.
struct Frame {
  std::vector<CornerMeasurement> corners;
  double params[Model::kNumParams] = {458.0, 457.0, 367.0, 248.0, -0.28, 0.07, 2e-4, 2e-5};
  Eigen::Matrix3d R_C_W;
  Eigen::Vector3d t_C_W;
};

Frame MakeFrame(int M, double tilt, std::uint32_t seed) {
  Frame f;
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.3);
  f.R_C_W = Eigen::AngleAxisd(tilt, Eigen::Vector3d(0.3, 1.0, 0.1).normalized()).toRotationMatrix();
  f.t_C_W = Eigen::Vector3d(-0.2, -0.15, 0.9);
  const Eigen::Matrix3d R_true = Eigen::AngleAxisd(0.004, Eigen::Vector3d::UnitX()) * f.R_C_W;
  const Eigen::Vector3d t_true = f.t_C_W + Eigen::Vector3d(0.002, -0.001, 0.003);
  for (int i = 0; i < M; ++i) {
    CornerMeasurement c;
    c.p_W = Eigen::Vector3d(0.06 * (i % 7), 0.06 * ((i / 7) % 6), 0.0);
    Eigen::Vector2d uv;
    EXPECT_TRUE(Model::Project<double>(f.params, R_true * c.p_W + t_true, &uv));
    c.uv = uv + Eigen::Vector2d(noise(rng), noise(rng));
    c.sigma_px = i % 5 == 0 ? 0.5 : 1.0;
    f.corners.push_back(c);
  }
  return f;
}

// CompressFrameCornersOf's [J | e] (its loop, unweighted: plain L2), for the factors alone.
MatA Augmented(const Frame& f) {
  const int M = static_cast<int>(f.corners.size());
  MatA A(2 * M, kNx + 1);
  for (int i = 0; i < M; ++i) {
    const CornerMeasurement& m = f.corners[static_cast<std::size_t>(i)];
    const Eigen::Vector3d p_C = f.R_C_W * m.p_W + f.t_C_W;
    Eigen::Vector2d uv;
    Eigen::Matrix<double, 2, 3> J_p;
    Eigen::Matrix<double, 2, Model::kNumParams> J_k;
    EXPECT_TRUE(Model::Project<double>(f.params, p_C, &uv, &J_p, &J_k));
    const double w = 1.0 / m.sigma_px;
    A.middleRows<2>(2 * i) << w * (J_p * Hat<double>(p_C)), -w * J_p, -w * J_k, w * (m.uv - uv);
  }
  return A;
}

TEST(FrameCornersCompression, GramFactorGivesTheQrFactorsNormalEquations) {
  for (const double tilt : {0.0, 0.3, 0.7}) {
    const MatA A = Augmented(MakeFrame(42, tilt, 7));
    MatR R_gram, R_qr;
    VecR r_gram, r_qr;
    ASSERT_TRUE(frame_corners_internal::FactorGram<kNx>(A, 0.25, r_gram.data(), &R_gram));
    frame_corners_internal::FactorQr<kNx>(A, 0.25, r_qr.data(), &R_qr);
    ExpectSameNormal(NormalOf(R_gram, r_gram), NormalOf(R_qr, r_qr), 1e-9);
    // The leading rows (the pose's, well conditioned) are the same rows up to their signs; the
    // last ones are not compared: one frame barely separates the distortion's columns, and the
    // Cholesky factor has those rows only to the accuracy the normal equations need.
    for (int k = 0; k < 6; ++k) {
      const double sign = R_qr(k, k) < 0.0 ? -1.0 : 1.0;
      EXPECT_LT(MaxAbs(R_gram.row(k) - sign * R_qr.row(k)), 1e-9 * MaxAbs(R_qr)) << "row " << k;
    }
  }
}

TEST(FrameCornersCompression, NearlyDependentColumnsAreLeftToTheQr) {
  MatA A = Augmented(MakeFrame(42, 0.3, 11));
  // The last intrinsic column a copy of the one before it up to 1e-7 of its size: a pivot of
  // ~1e-14 of its diagonal, below kMinPivot.
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1e-7 * A.col(kNx - 2).cwiseAbs().maxCoeff());
  for (int i = 0; i < A.rows(); ++i)
    A(i, kNx - 1) = A(i, kNx - 2) + n(rng);
  MatR R;
  VecR r;
  EXPECT_FALSE(frame_corners_internal::FactorGram<kNx>(A, 0.0, r.data(), &R));
  // The same columns 1e-3 apart are well within the Gram factor's accuracy.
  std::normal_distribution<double> wide(0.0, 1e-3 * A.col(kNx - 2).cwiseAbs().maxCoeff());
  for (int i = 0; i < A.rows(); ++i)
    A(i, kNx - 1) = A(i, kNx - 2) + wide(rng);
  EXPECT_TRUE(frame_corners_internal::FactorGram<kNx>(A, 0.0, r.data(), &R));
}

TEST(FrameCornersCompression, CostOnlyEqualsTheCompressedCostAndFewCornersUseTheQr) {
  // 42 corners take the Gram factor, 6 (12 rows, fewer than R's 14) the QR; Huber off and on (a
  // threshold that some corners of the few-pixel residuals exceed).
  for (const int M : {42, 6}) {
    const Frame f = MakeFrame(M, 0.4, 5);
    for (const double huber : {0.0, 1.5}) {
      MatR R;
      VecR r;
      ASSERT_TRUE(
          CompressFrameCorners<Model>(f.corners, f.params, f.R_C_W, f.t_C_W, huber, r.data(), &R));
      double cost = 0.0;
      ASSERT_TRUE(FrameCornersCostOf<Model>(M, OwnedCornerAt{f.corners.data()}, f.params, f.R_C_W,
                                            f.t_C_W, huber, &cost));
      EXPECT_NEAR(r.squaredNorm(), cost, 1e-10 * cost) << M << " corners, huber " << huber;
      if (M == 6) {
        // The QR of 12 rows: R's rows 14 .. kNx - 1 are zero, as FactorQr writes them.
        MatR R_qr;
        VecR r_qr;
        frame_corners_internal::FactorQr<kNx>(Augmented(f), 0.0, r_qr.data(), &R_qr);
        EXPECT_EQ(R.bottomRows(kNx - 2 * M).cwiseAbs().maxCoeff(), 0.0);
        if (huber == 0.0)
          ExpectSameNormal(NormalOf(R, r), NormalOf(R_qr, r_qr), 1e-12);
      }
    }
  }
}

TEST(FrameCornersCompression, ExactFitLeavesOnlyTheRemainder) {
  // e in the span of J (rho = 0 exactly): the Gram factor's rho^2 is a difference of nearly equal
  // numbers, clamped at 0, so the last row is sqrt(remainder) to the rounding of ||e||^2.
  MatA A = Augmented(MakeFrame(42, 0.2, 9));
  Eigen::Matrix<double, kNx, 1> x;
  for (int k = 0; k < kNx; ++k)
    x(k) = 1e-3 * (k + 1);
  A.col(kNx) = A.leftCols<kNx>() * x;
  MatR R;
  VecR r;
  ASSERT_TRUE(frame_corners_internal::FactorGram<kNx>(A, 4.0, r.data(), &R));
  EXPECT_NEAR(r(kNx), 2.0, 1e-6);
  EXPECT_NEAR(r.head<kNx>().squaredNorm(), A.col(kNx).squaredNorm(),
              1e-10 * A.col(kNx).squaredNorm());
}

}  // namespace
}  // namespace ctcal
