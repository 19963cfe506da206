#include "ctcal/calibrator/discrete/discrete_residuals.h"

#include <Eigen/Cholesky>

namespace ctcal::discrete {

// Rotation covariance of the gyroscope's preintegration, step by step with the step's mean
// corrected reading w (Simpson weights of the RK4 nodes) over h: dphi' = Exp(w h)^T dphi +
// Jr(w h) h dw, dw the raw white noise (covariance sigma_c^2 / h over the step) mapped through
// GyroTrueFromRaw's input Jacobian (D_w).
GyroPreintegration::GyroPreintegration(const std::vector<RawImuSample>& samples, double t_i,
                                       double t_j, const GyroIntrinsics& intrinsics,
                                       const InertialNoise& noise, const Eigen::Vector3d& b_g)
    : readings_(detail::ClippedReadings(samples, t_i, t_j)), t_i_(t_i), t_j_(t_j) {
  Eigen::Matrix3d J_w_raw;
  GyroJacobians jac;
  jac.J_out_in = &J_w_raw;
  std::vector<Eigen::Vector3d> w(readings_.size());
  for (std::size_t k = 0; k < readings_.size(); ++k)
    w[k] = intrinsics.TrueFromRaw(readings_[k].w_m, b_g, k == 0 ? jac : GyroJacobians{});
  const double var = noise.gyroscope_noise_density * noise.gyroscope_noise_density;
  for (std::size_t k = 0; k + 2 < readings_.size(); k += 2) {
    const double h = readings_[k + 2].t - readings_[k].t;
    const Eigen::Vector3d full = (w[k] + 4.0 * w[k + 1] + w[k + 2]) / 6.0 * h;
    const Eigen::Matrix3d A = ExpSO3<double>(full).toRotationMatrix().transpose();
    const Eigen::Matrix3d B = RightJacobianSO3<double>(full) * h * J_w_raw;
    covariance_ = A * covariance_ * A.transpose() + B * (var / h) * B.transpose();
  }
  dR_ = IntegrateGyroRotation<double>(readings_, intrinsics.model(), intrinsics.Dw(), b_g);
  covariance_ = 0.5 * (covariance_ + covariance_.transpose());
  const Eigen::LLT<Eigen::Matrix3d> llt(covariance_);
  if (llt.info() != Eigen::Success)
    throw std::invalid_argument("gyro preintegration: covariance not positive definite over [" +
                                std::to_string(t_i) + ", " + std::to_string(t_j) +
                                "] s (noise density zero?)");
  sqrt_information_ = llt.matrixL().solve(Eigen::Matrix3d::Identity());
}

// Defined here, not inline in the header: each camera model's Jet instantiation compiled once.
ceres::CostFunction* MakeDiscreteCorner(CameraModelType type, const CornerMeasurement& m,
                                        double stamp, const BaseSource& src, const CornerIndex& c,
                                        const BlockList& list) {
  return VisitCameraModel(type, [&](auto model) -> ceres::CostFunction* {
    using Model = decltype(model);
    return MakeDynamicAutoDiff(new DiscreteCornerFunctor<Model>{m, stamp, src, c}, list.sizes(), 2);
  });
}

}  // namespace ctcal::discrete
