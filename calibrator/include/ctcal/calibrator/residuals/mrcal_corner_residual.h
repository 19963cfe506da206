// The corner residual of corner_residual.h for a camera with an mrcal lens (camera_model mrcal),
// whose parameter count is a run-time number, and the factory that picks it.
//
// Same residual, r = (uv_meas - pi(theta, p_C)) / sigma with p_C = CornerResidual::PointInCamera
// (trajectory, extrinsics, time offset, line delay). Its Jacobians by the chain rule:
//   d r / d (every block but theta) = -(d pi / d p_C) (d p_C / d block) / sigma,
//   d r / d theta = -(d pi / d theta) / sigma,
// with mrcal's own gradients of pi (mrcal_project) and d p_C / d block by autodiff of
// PointInCamera alone (3 outputs over the geometric blocks), so theta's hundreds of parameters (a
// splined lens) never enter the Jets.
#pragma once

#include <ceres/ceres.h>

#include <memory>
#include <vector>

#include "ctcal/calibrator/residuals/corner_residual.h"
#include "ctcal/sensors/mrcal_lens.h"

namespace ctcal {

template <int N, Se3Representation Rep>
class MrcalCornerResidual final : public ceres::CostFunction {
 public:
  using R = CornerResidual<N, Rep>;

  MrcalCornerResidual(std::shared_ptr<const MrcalLens> lens, const CornerMeasurement& m,
                      const SegmentClock& clock)
      : lens_(std::move(lens)), m_(m) {
    set_num_residuals(2);
    *mutable_parameter_block_sizes() = R::BlockSizes(lens_->NumParams());
    std::vector<int> geometric = R::BlockSizes(0);
    geometric.pop_back();
    point_.reset(MakeDynamicAutoDiff(new PointFunctor{m, clock}, geometric, 3));
  }

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    const std::vector<int>& sizes = parameter_block_sizes();
    double p_C[3];
    std::vector<std::vector<double>> J_geo;
    std::vector<double*> J_geo_ptr(static_cast<std::size_t>(R::kParams), nullptr);
    if (jacobians) {
      J_geo.resize(static_cast<std::size_t>(R::kParams));
      for (int b = 0; b < R::kParams; ++b) {
        if (!jacobians[b])
          continue;
        J_geo[static_cast<std::size_t>(b)].resize(3 * static_cast<std::size_t>(sizes[b]));
        J_geo_ptr[static_cast<std::size_t>(b)] = J_geo[static_cast<std::size_t>(b)].data();
      }
    }
    if (!point_->Evaluate(p, p_C, jacobians ? J_geo_ptr.data() : nullptr))
      return false;
    Eigen::Vector2d uv;
    Eigen::Matrix<double, 2, 3> J_uv_p;
    Eigen::Matrix<double, 2, Eigen::Dynamic> J_uv_theta;
    const bool want_theta = jacobians && jacobians[R::kParams];
    if (!lens_->Project(p[R::kParams], Eigen::Vector3d(p_C[0], p_C[1], p_C[2]), &uv,
                        jacobians ? &J_uv_p : nullptr, want_theta ? &J_uv_theta : nullptr))
      return false;
    const double inv_sigma = 1.0 / m_.sigma_px;
    residuals[0] = (m_.uv.x() - uv.x()) * inv_sigma;
    residuals[1] = (m_.uv.y() - uv.y()) * inv_sigma;
    if (!jacobians)
      return true;
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    for (int b = 0; b < R::kParams; ++b) {
      if (!jacobians[b])
        continue;
      const Eigen::Map<const RowMajor> J_p_b(J_geo_ptr[static_cast<std::size_t>(b)], 3, sizes[b]);
      Eigen::Map<RowMajor>(jacobians[b], 2, sizes[b]) = -inv_sigma * J_uv_p * J_p_b;
    }
    if (want_theta)
      Eigen::Map<RowMajor>(jacobians[R::kParams], 2, lens_->NumParams()) = -inv_sigma * J_uv_theta;
    return true;
  }

 private:
  struct PointFunctor {
    CornerMeasurement m;
    SegmentClock clock;
    template <typename T>
    bool operator()(T const* const* p, T* out) const {
      const Vec3T<T> p_C = R::template PointInCamera<T>(p, m, clock);
      for (int i = 0; i < 3; ++i)
        out[i] = p_C(i);
      return true;
    }
  };

  std::shared_ptr<const MrcalLens> lens_;
  CornerMeasurement m_;
  std::unique_ptr<ceres::CostFunction> point_;
};

// The corner cost of a camera of any model: mrcal lenses above, SPEC section 4's models through
// MakeCornerResidual (analytic or autodiff).
template <int N, Se3Representation Rep>
ceres::CostFunction* MakeCameraCornerResidual(bool analytic, const CameraModel& camera,
                                              const CornerMeasurement& m,
                                              const SegmentClock& clock) {
  if (camera.mrcal_lens())
    return new MrcalCornerResidual<N, Rep>(camera.shared_mrcal_lens(), m, clock);
  return MakeCornerResidual<N, Rep>(analytic, camera.type(), m, clock);
}

}  // namespace ctcal
