#include <ceres/jet.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
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

RawImuSample InterpolateRaw(const std::vector<RawImuSample>& samples, std::size_t k, double t) {
  const std::size_t n = samples.size();
  const std::size_t lo = k > 0 ? k - 1 : 0;
  const std::size_t hi = std::min(n - 1, k + 2);
  RawImuSample out;
  out.t = t;
  out.w_m.setZero();
  out.a_m.setZero();
  for (std::size_t i = lo; i <= hi; ++i) {
    double L = 1.0;
    for (std::size_t m = lo; m <= hi; ++m) {
      if (m != i)
        L *= (t - samples[m].t) / (samples[i].t - samples[m].t);
    }
    out.w_m += L * samples[i].w_m;
    out.a_m += L * samples[i].a_m;
  }
  return out;
}

std::vector<RawImuSample> ClippedReadings(const std::vector<RawImuSample>& samples, double t_i,
                                          double t_j) {
  if (!(t_i < t_j))
    throw std::invalid_argument("preintegration: empty interval " + Interval(t_i, t_j));
  if (samples.size() < 2 || samples.front().t > t_i || samples.back().t < t_j)
    throw std::invalid_argument("preintegration: IMU samples do not cover the interval " +
                                Interval(t_i, t_j));
  const auto by_time = [](const RawImuSample& s, double t) { return s.t < t; };
  // first sample at or after t_i / t_j
  const auto it_i = std::lower_bound(samples.begin(), samples.end(), t_i, by_time);
  const auto it_j = std::lower_bound(samples.begin(), samples.end(), t_j, by_time);
  // The sample interval [k, k+1] holding t, k = index of the last sample before (or at) t.
  const auto segment_of = [&](double t) {
    const auto it = std::upper_bound(samples.begin(), samples.end(), t,
                                     [](double x, const RawImuSample& s) { return x < s.t; });
    const std::size_t k = static_cast<std::size_t>(std::max<std::ptrdiff_t>(
        0, std::min<std::ptrdiff_t>(it - samples.begin() - 1,
                                    static_cast<std::ptrdiff_t>(samples.size()) - 2)));
    return k;
  };
  std::vector<double> bounds{t_i};
  for (auto it = it_i; it != it_j; ++it) {
    if (it->t <= t_i)
      continue;
    if (!(it->t > bounds.back()))
      throw std::invalid_argument("preintegration: IMU samples not in increasing time order in " +
                                  Interval(t_i, t_j));
    bounds.push_back(it->t);
  }
  if (!(t_j > bounds.back()))
    throw std::invalid_argument("preintegration: IMU samples not in increasing time order in " +
                                Interval(t_i, t_j));
  bounds.push_back(t_j);
  std::vector<RawImuSample> out;
  out.reserve(2 * bounds.size() - 1);
  for (std::size_t b = 0; b < bounds.size(); ++b) {
    if (b > 0) {
      const double tm = 0.5 * (bounds[b - 1] + bounds[b]);
      out.push_back(InterpolateRaw(samples, segment_of(tm), tm));
    }
    const double t = bounds[b];
    const std::size_t k = segment_of(t);
    if (samples[k].t == t)
      out.push_back(samples[k]);
    else if (samples[k + 1].t == t)
      out.push_back(samples[k + 1]);
    else
      out.push_back(InterpolateRaw(samples, k, t));
  }
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

// Covariance: linearisation of one step of length h about the current estimate with the step's
// mean corrected reading (w, a) (Simpson weights of the RK4 nodes), E = Exp(w h / 2),
// R_m = dR E (the error propagation only needs first order in h; the deltas themselves come from
// the RK4 step):
//   dphi' = Exp(w h)^T dphi + Jr(w h) h dw
//   the mid orientation's error  theta = E^T dphi + Jr(w h / 2) (h / 2) dw, so
//   R_m (a + da) perturbed = R_m a + R_m da - R_m [a]x theta, and
//   dv' = dv + h (R_m da - R_m [a]x theta),   dp' = dp + h dv + h^2 / 2 (R_m da - R_m [a]x theta).
// x' = A x + B du with du = [dw; da], raw noise mapped through ImuTrueFromRaw's input Jacobian.
// Bias Jacobians: exact derivatives of the RK4 deltas (Jets over [b_g, b_a]), so that the
// first-order correction (eq. 36) is the tangent of re-integration (eq. 37).
void Preintegration::Reintegrate(const ImuIntrinsics& intrinsics, const Eigen::Vector3d& b_g,
                                 const Eigen::Vector3d& b_a) {
  b_g_bar_ = b_g;
  b_a_bar_ = b_a;
  deltas_ = PreintegratedDeltas<double>();
  covariance_.setZero();
  J_delta_bias_.setZero();

  Eigen::Matrix<double, 6, 6> J_u_raw;
  ImuJacobians jac;
  jac.J_out_in = &J_u_raw;
  std::vector<Eigen::Vector3d> w(readings_.size()), a(readings_.size());
  for (std::size_t k = 0; k < readings_.size(); ++k)
    intrinsics.TrueFromRaw(readings_[k].w_m, readings_[k].a_m, b_g, b_a, &w[k], &a[k],
                           k == 0 ? jac : ImuJacobians{});
  const double var_g = noise_.gyroscope_noise_density * noise_.gyroscope_noise_density;
  const double var_a = noise_.accelerometer_noise_density * noise_.accelerometer_noise_density;

  const Eigen::Matrix3d I3 = Eigen::Matrix3d::Identity();
  PreintegratedDeltas<double> d;
  for (std::size_t k = 0; k + 2 < readings_.size(); k += 2) {
    const double h = readings_[k + 2].t - readings_[k].t;
    const Eigen::Vector3d w_mid = (w[k] + 4.0 * w[k + 1] + w[k + 2]) / 6.0;
    const Eigen::Vector3d a_mid = (a[k] + 4.0 * a[k + 1] + a[k + 2]) / 6.0;
    const Eigen::Vector3d half = w_mid * (0.5 * h);
    const Eigen::Vector3d full = w_mid * h;
    const Eigen::Matrix3d E = ExpSO3<double>(half).toRotationMatrix();
    const Eigen::Matrix3d R_m = d.dR.toRotationMatrix() * E;
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
    detail::Rk4Step<double>(w[k], a[k], w[k + 1], a[k + 1], w[k + 2], a[k + 2], h, &d);
  }
  deltas_ = d;
  {
    using J6 = ceres::Jet<double, 6>;
    Vec3T<J6> bg, ba;
    for (int i = 0; i < 3; ++i) {
      bg(i) = J6(b_g(i), i);
      ba(i) = J6(b_a(i), 3 + i);
    }
    // The intrinsics as constant Jets (the derivatives are with respect to the biases only).
    std::array<std::array<J6, 9>, 4> storage;
    const ImuBlocks<double> b = intrinsics.blocks();
    const auto lift = [&](const double* src, int size, int slot) -> const J6* {
      if (src == nullptr)
        return nullptr;
      for (int i = 0; i < size; ++i)
        storage[static_cast<std::size_t>(slot)][static_cast<std::size_t>(i)] = J6(src[i]);
      return storage[static_cast<std::size_t>(slot)].data();
    };
    ImuBlocks<J6> blocks_jet;
    blocks_jet.Dw = lift(b.Dw, 9, 0);
    blocks_jet.Da = lift(b.Da, 9, 1);
    blocks_jet.Tg = lift(b.Tg, 9, 2);
    blocks_jet.q_rotation = lift(b.q_rotation, 4, 3);
    const PreintegratedDeltas<J6> dj =
        IntegrateDeltas<J6>(readings_, intrinsics.layout(), blocks_jet, bg, ba);
    const Vec3T<J6> e = LogSO3<J6>(QuatT<J6>(deltas_.dR.cast<J6>().conjugate() * dj.dR));
    for (int i = 0; i < 3; ++i) {
      J_delta_bias_.row(i) = e(i).v.transpose();
      J_delta_bias_.row(3 + i) = dj.dv(i).v.transpose();
      J_delta_bias_.row(6 + i) = dj.dp(i).v.transpose();
    }
  }
  covariance_ = 0.5 * (covariance_ + covariance_.transpose());
  const Eigen::LLT<Eigen::Matrix<double, 9, 9>> llt(covariance_);
  if (llt.info() != Eigen::Success)
    throw std::invalid_argument("preintegration: covariance not positive definite over " +
                                Interval(t_i_, t_j_) + " (noise densities zero?)");
  sqrt_information_ = llt.matrixL().solve(Eigen::Matrix<double, 9, 9>::Identity());
}

}  // namespace ctcal::discrete
