// The square-root information factor of every corner of one global-shutter frame over the
// frame-local variables x = (dtheta, dt, dparams): the compression step of
// frame_corners_residual.h (its file comment derives it, the robust stage's Huber weights and
// remainder row included), for any pose source. The spline's FrameCornersResidual and the
// discrete method's DiscreteFrameCorners (discrete/frame_corners.h) chain R to their own blocks.
#pragma once

#include <Eigen/Core>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <vector>

#include "ctcal/calibrator/residuals/corner_residual.h"
#include "ctcal/calibrator/residuals/residual_support.h"

namespace ctcal {

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
    if (huber > 0.0) {
      const double s = e.squaredNorm();
      if (s > huber * huber) {
        const double root = std::sqrt(s);
        const double rho1 = huber / root;  // rho'(s)
        remainder += (2.0 * huber * root - huber * huber) - rho1 * s;
        w *= std::sqrt(rho1);
      }
    }
    auto rows = A.template middleRows<2>(2 * i);
    rows.template leftCols<3>() = w * (J_uv_p * Hat<double>(p_C));
    rows.template middleCols<3>(3) = -w * J_uv_p;
    rows.template middleCols<Model::kNumParams>(6) = -w * J_uv_params;
    rows.col(kNx) = (w * m.sigma_px) * e;
  }
  const Eigen::HouseholderQR<Eigen::Matrix<double, Eigen::Dynamic, kNx + 1>> qr(A);
  const auto& QR = qr.matrixQR();
  const int rows = std::min(2 * M, kNx + 1);
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
  r(kNx) = std::sqrt(rho * rho + std::max(remainder, 0.0));
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
