#include <Eigen/Cholesky>
#include <algorithm>
#include <sstream>

#include "ctcal/calibrator/discrete/preintegration.h"

namespace ctcal::discrete {
namespace {

std::string Interval(double t_i, double t_j) {
  std::ostringstream os;
  os.precision(9);
  os << "[" << t_i << ", " << t_j << "] s";
  return os.str();
}

}  // namespace

namespace detail {

std::vector<RawImuSample> ClippedReadings(const std::vector<RawImuSample>& samples, double t_i,
                                          double t_j) {
  if (!(t_i < t_j))
    throw std::invalid_argument("preintegration: empty interval " + Interval(t_i, t_j));
  if (samples.size() < 2 || samples.front().t > t_i || samples.back().t < t_j)
    throw std::invalid_argument("preintegration: base IMU samples do not cover the interval " +
                                Interval(t_i, t_j));
  const auto by_time = [](const RawImuSample& s, double t) { return s.t < t; };
  // first sample at or after t_i / t_j
  auto it_i = std::lower_bound(samples.begin(), samples.end(), t_i, by_time);
  auto it_j = std::lower_bound(samples.begin(), samples.end(), t_j, by_time);
  std::vector<RawImuSample> out;
  out.reserve(static_cast<std::size_t>(it_j - it_i) + 2);
  const auto at = [&](std::vector<RawImuSample>::const_iterator it, double t) {
    if (it->t == t)
      return *it;
    return InterpolateRaw(*(it - 1), *it, t);
  };
  out.push_back(at(it_i, t_i));
  for (auto it = it_i; it != it_j; ++it) {
    if (it->t <= t_i)
      continue;
    if (!(it->t > out.back().t))
      throw std::invalid_argument(
          "preintegration: base IMU samples not in increasing time order "
          "in " +
          Interval(t_i, t_j));
    out.push_back(*it);
  }
  out.push_back(at(it_j, t_j));
  if (!(out.back().t > out[out.size() - 2].t))
    throw std::invalid_argument(
        "preintegration: base IMU samples not in increasing time order in " + Interval(t_i, t_j));
  return out;
}

}  // namespace detail

Preintegration::Preintegration(const std::vector<RawImuSample>& samples, double t_i, double t_j,
                               const ImuIntrinsics& intrinsics, const InertialNoise& noise,
                               const Eigen::Vector3d& b_g, const Eigen::Vector3d& b_a)
    : readings_(detail::ClippedReadings(samples, t_i, t_j)), t_i_(t_i), t_j_(t_j), noise_(noise) {
  noise_.Validate(true);
  Reintegrate(intrinsics, b_g, b_a);
}

// Linearisation of one midpoint step (see detail::MidpointStep) about the current estimate, with
// the mean corrected reading (w, a) over the step of length h, E = Exp(w h / 2), R_m = dR E:
//   dphi' = Exp(w h)^T dphi + Jr(w h) h dw
//   the midpoint orientation's error  theta = E^T dphi + Jr(w h / 2) (h / 2) dw, so
//   R_m (a + da) perturbed = R_m a + R_m da - R_m [a]x theta, and
//   dv' = dv + h (R_m da - R_m [a]x theta),   dp' = dp + h dv + h^2 / 2 (R_m da - R_m [a]x theta).
// x' = A x + B du with du = [dw; da]. A bias change enters du through the (constant, since the
// correction is affine) Jacobian of ImuTrueFromRaw, raw noise through its input Jacobian.
void Preintegration::Reintegrate(const ImuIntrinsics& intrinsics, const Eigen::Vector3d& b_g,
                                 const Eigen::Vector3d& b_a) {
  b_g_bar_ = b_g;
  b_a_bar_ = b_a;
  deltas_ = PreintegratedDeltas<double>();
  covariance_.setZero();
  J_delta_bias_.setZero();

  Eigen::Matrix<double, 6, 3> J_u_bg, J_u_ba;
  Eigen::Matrix<double, 6, 6> J_u_raw;
  ImuJacobians jac;
  jac.J_out_bg = &J_u_bg;
  jac.J_out_ba = &J_u_ba;
  jac.J_out_in = &J_u_raw;
  std::vector<Eigen::Vector3d> w(readings_.size()), a(readings_.size());
  for (std::size_t k = 0; k < readings_.size(); ++k)
    intrinsics.TrueFromRaw(readings_[k].w_m, readings_[k].a_m, b_g, b_a, &w[k], &a[k],
                           k == 0 ? jac : ImuJacobians{});
  Eigen::Matrix<double, 6, 6> J_u_b;
  J_u_b << J_u_bg, J_u_ba;
  const double var_g = noise_.gyroscope_noise_density * noise_.gyroscope_noise_density;
  const double var_a = noise_.accelerometer_noise_density * noise_.accelerometer_noise_density;

  const Eigen::Matrix3d I3 = Eigen::Matrix3d::Identity();
  for (std::size_t k = 1; k < readings_.size(); ++k) {
    const double h = readings_[k].t - readings_[k - 1].t;
    const Eigen::Vector3d w_mid = 0.5 * (w[k - 1] + w[k]);
    const Eigen::Vector3d a_mid = 0.5 * (a[k - 1] + a[k]);
    const Eigen::Vector3d half = w_mid * (0.5 * h);
    const Eigen::Vector3d full = w_mid * h;
    const Eigen::Matrix3d E = ExpSO3<double>(half).toRotationMatrix();
    const Eigen::Matrix3d R_m = deltas_.dR.toRotationMatrix() * E;
    const Eigen::Matrix3d Ra_hat = R_m * Hat<double>(a_mid);

    Eigen::Matrix<double, 9, 9> A = Eigen::Matrix<double, 9, 9>::Identity();
    A.block<3, 3>(0, 0) = ExpSO3<double>(full).toRotationMatrix().transpose();
    A.block<3, 3>(3, 0) = -h * Ra_hat * E.transpose();
    A.block<3, 3>(6, 0) = -0.5 * h * h * Ra_hat * E.transpose();
    A.block<3, 3>(6, 3) = h * I3;
    Eigen::Matrix<double, 9, 6> B = Eigen::Matrix<double, 9, 6>::Zero();
    const Eigen::Matrix3d theta_w = RightJacobianSO3<double>(half) * (0.5 * h);
    B.block<3, 3>(0, 0) = RightJacobianSO3<double>(full) * h;
    B.block<3, 3>(3, 0) = -h * Ra_hat * theta_w;
    B.block<3, 3>(6, 0) = -0.5 * h * h * Ra_hat * theta_w;
    B.block<3, 3>(3, 3) = h * R_m;
    B.block<3, 3>(6, 3) = 0.5 * h * h * R_m;

    Eigen::Matrix<double, 6, 6> Q = Eigen::Matrix<double, 6, 6>::Zero();
    Q.diagonal() << Eigen::Vector3d::Constant(var_g / h), Eigen::Vector3d::Constant(var_a / h);
    const Eigen::Matrix<double, 9, 6> BJ = B * J_u_raw;
    covariance_ = A * covariance_ * A.transpose() + BJ * Q * BJ.transpose();
    J_delta_bias_ = A * J_delta_bias_ + B * J_u_b;
    detail::MidpointStep<double>(w[k - 1], a[k - 1], w[k], a[k], h, &deltas_);
  }
  covariance_ = 0.5 * (covariance_ + covariance_.transpose());
  const Eigen::LLT<Eigen::Matrix<double, 9, 9>> llt(covariance_);
  if (llt.info() != Eigen::Success)
    throw std::invalid_argument("preintegration: covariance not positive definite over " +
                                Interval(t_i_, t_j_) + " (noise densities zero?)");
  sqrt_information_ = llt.matrixL().solve(Eigen::Matrix<double, 9, 9>::Identity());
}

}  // namespace ctcal::discrete
