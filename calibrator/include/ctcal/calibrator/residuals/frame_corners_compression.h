// The square-root information factor of every corner of one global-shutter frame over the
// frame-local variables x = (dtheta, dt, dparams): the compression step of
// frame_corners_residual.h (its file comment derives it, the robust stage's Huber weights and
// remainder row included), for any pose source. The spline's FrameCornersResidual and the
// discrete method's DiscreteFrameCorners (discrete/frame_corners.h) chain R to their own blocks.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <vector>

#include "ctcal/calibrator/residuals/corner_residual.h"
#include "ctcal/calibrator/residuals/residual_support.h"

namespace ctcal {

namespace frame_corners_internal {

// A = [J | e] (2M x kNx + 1) factored as [R z; 0 rho] with R^T R = J^T J, R^T z = J^T e and
// rho^2 = ||e||^2 - ||z||^2, written as CompressFrameCornersOf's r = [z; sqrt(rho^2 + remainder)]
// and R. Through the Gram matrix A^T A (one matrix product, m n^2 flops at the speed of a blocked
// kernel) and its Cholesky factor, instead of Householder's QR (2 m n^2 flops, one reflection at a
// time: 7 % of EuRoC's whole calibration). Forming J^T J loses what the normal equations the
// solvers form from R lose anyway (R^T R = J^T J to the same rounding), so the step and the
// covariance do not change; but the Cholesky factor of a nearly singular J^T J is not accurate:
// false (use FactorQr) when a column of J keeps less than kMinPivot of its squared norm after
// the columns before it (J^T J's pivot against its diagonal), including when the factor fails.
// rho^2 is taken as a difference and clamped at 0: ||r||^2 = max(||e||^2, ||z||^2), the cost to
// the rounding of ||e||^2 even when the frame's variables explain nearly all of it.
inline constexpr double kMinPivot = 1e-10;

template <int kNx, class MatA>
bool FactorGram(const MatA& A, double remainder, double* residuals,
                Eigen::Matrix<double, kNx, kNx>* R) {
  const Eigen::Matrix<double, kNx + 1, kNx + 1> G = A.transpose() * A;
  const Eigen::LLT<Eigen::Matrix<double, kNx, kNx>, Eigen::Upper> llt(
      G.template topLeftCorner<kNx, kNx>());
  if (llt.info() != Eigen::Success)
    return false;
  *R = llt.matrixU();
  for (int k = 0; k < kNx; ++k) {
    const double pivot = (*R)(k, k) * (*R)(k, k);
    if (!(pivot >= kMinPivot * G(k, k)) || !(G(k, k) > 0.0))
      return false;
  }
  Eigen::Map<Eigen::Matrix<double, kNx + 1, 1>> r(residuals);
  r.template head<kNx>() = G.template topRightCorner<kNx, 1>();
  llt.matrixL().solveInPlace(r.template head<kNx>());
  const double rho2 = std::max(G(kNx, kNx) - r.template head<kNx>().squaredNorm(), 0.0);
  r(kNx) = std::sqrt(rho2 + remainder);
  return r.allFinite() && R->allFinite();
}

// The same factors by Householder's QR of A: any A, also fewer rows than columns (the rows of R
// beyond 2M zero) or nearly dependent columns.
template <int kNx, class MatA>
void FactorQr(const MatA& A, double remainder, double* residuals,
              Eigen::Matrix<double, kNx, kNx>* R) {
  const Eigen::HouseholderQR<Eigen::Matrix<double, Eigen::Dynamic, kNx + 1>> qr(A);
  const auto& QR = qr.matrixQR();
  const int rows = std::min(static_cast<int>(A.rows()), kNx + 1);
  R->setZero();
  Eigen::Map<Eigen::Matrix<double, kNx + 1, 1>> r(residuals);
  r.setZero();
  for (int k = 0; k < rows; ++k) {
    for (int j = k; j < kNx; ++j)
      (*R)(k, j) = QR(k, j);
    if (k < kNx)
      r(k) = QR(k, kNx);
  }
  const double rho = rows == kNx + 1 ? QR(kNx, kNx) : 0.0;
  r(kNx) = std::sqrt(rho * rho + remainder);
}

}  // namespace frame_corners_internal

// Camera pose T_C_W = (R_C_W, t_C_W) of the frame, intrinsics `params`, huber_threshold 0 for plain
// L2. Writes r = [z; last] (kNx + 1 values) and R (kNx x kNx, upper triangular, rows beyond 2M
// zero), where x perturbs the pose on the left (p_C -> Exp(dtheta) p_C + dt) and the intrinsics.
// Returns false when a corner does not project validly.
// `corner_at(i)` gives the frame's corner i < M as a CornerMeasurement (owned or held corners).
template <class Model, class CornerAt>
bool CompressFrameCornersOf(
    int M, const CornerAt& corner_at, const double* params, const Eigen::Matrix3d& R_C_W,
    const Eigen::Vector3d& t_C_W, double huber_threshold, double* residuals,
    Eigen::Matrix<double, 6 + Model::kNumParams, 6 + Model::kNumParams>* R) {
  constexpr int kNx = 6 + Model::kNumParams;
  const double huber = huber_threshold;
  Eigen::Matrix<double, Eigen::Dynamic, kNx + 1> A(2 * M, kNx + 1);
  double remainder = 0.0;  // sum rho(s_i) - rho'(s_i) s_i
  Eigen::Matrix<double, 2, 3> J_uv_p;
  Eigen::Matrix<double, 2, Model::kNumParams> J_uv_params;
  for (int i = 0; i < M; ++i) {
    const CornerMeasurement m = corner_at(i);
    const Eigen::Vector3d p_C = R_C_W * m.p_W + t_C_W;
    Eigen::Vector2d uv;
    if (!Model::template Project<double>(params, p_C, &uv, &J_uv_p, &J_uv_params))
      return false;
    const Eigen::Vector2d e = (m.uv - uv) / m.sigma_px;
    double w = 1.0 / m.sigma_px;
    if (huber > 0.0) {  // within the threshold rho(s) = s, rho' = 1: both lines change nothing
      const double s = e.squaredNorm();
      const HuberValue h = Huber(s, huber);
      remainder += h.rho - h.rho1 * s;
      w *= std::sqrt(h.rho1);
    }
    auto rows = A.template middleRows<2>(2 * i);
    rows.template leftCols<3>() = w * (J_uv_p * Hat<double>(p_C));
    rows.template middleCols<3>(3) = -w * J_uv_p;
    rows.template middleCols<Model::kNumParams>(6) = -w * J_uv_params;
    rows.col(kNx) = (w * m.sigma_px) * e;
  }
  const double remainder_row = std::max(remainder, 0.0);
  if (2 * M > kNx && frame_corners_internal::FactorGram<kNx>(A, remainder_row, residuals, R))
    return true;
  frame_corners_internal::FactorQr<kNx>(A, remainder_row, residuals, R);
  return true;
}

// The frame's cost sum_i rho(s_i) = ||r||^2 of CompressFrameCornersOf's r (its remainder row
// makes the two equal; frame_corners_residual.h derives it), without the Jacobians and the
// factorisation: what a residual-only evaluation (a candidate step's cost) needs. False when a
// corner does not project validly.
template <class Model, class CornerAt>
bool FrameCornersCostOf(int M, const CornerAt& corner_at, const double* params,
                        const Eigen::Matrix3d& R_C_W, const Eigen::Vector3d& t_C_W,
                        double huber_threshold, double* cost) {
  const double huber = huber_threshold;
  double sum = 0.0;
  for (int i = 0; i < M; ++i) {
    const CornerMeasurement m = corner_at(i);
    Eigen::Vector2d uv;
    if (!Model::template Project<double>(params, R_C_W * m.p_W + t_C_W, &uv))
      return false;
    sum += Huber(((m.uv - uv) / m.sigma_px).squaredNorm(), huber).rho;
  }
  *cost = sum;
  return true;
}

// The corner sources of CompressFrameCornersOf: corners owned as CornerMeasurements, or held
// compactly with their board points in a table (HeldCorner). Named types, not lambdas, so that
// the factorisation is compiled once per camera model and source, not once per residual class.
struct OwnedCornerAt {
  const CornerMeasurement* corners;
  const CornerMeasurement& operator()(int i) const { return corners[i]; }
};
struct HeldCornerAt {
  const HeldCorner* corners;
  const Eigen::Vector3d* board_W;
  CornerMeasurement operator()(int i) const { return MeasurementOf(corners[i], board_W); }
};

// The M corners at `corners` (owned by the caller).
template <class Model>
bool CompressFrameCorners(const CornerMeasurement* corners, int M, const double* params,
                          const Eigen::Matrix3d& R_C_W, const Eigen::Vector3d& t_C_W,
                          double huber_threshold, double* residuals,
                          Eigen::Matrix<double, 6 + Model::kNumParams, 6 + Model::kNumParams>* R) {
  return CompressFrameCornersOf<Model>(M, OwnedCornerAt{corners}, params, R_C_W, t_C_W,
                                       huber_threshold, residuals, R);
}

template <class Model>
bool CompressFrameCorners(const std::vector<CornerMeasurement>& corners, const double* params,
                          const Eigen::Matrix3d& R_C_W, const Eigen::Vector3d& t_C_W,
                          double huber_threshold, double* residuals,
                          Eigen::Matrix<double, 6 + Model::kNumParams, 6 + Model::kNumParams>* R) {
  return CompressFrameCorners<Model>(corners.data(), static_cast<int>(corners.size()), params,
                                     R_C_W, t_C_W, huber_threshold, residuals, R);
}

}  // namespace ctcal
