// The discrete formulation's base motion and biases for the report (report_data_builder.h):
// KeyframeTrajectory and KeyframeBiases.
#include <algorithm>
#include <cmath>
#include <memory>

#include "ctcal/calibrator/discrete/discrete_residuals.h"
#include "ctcal/calibrator/report_data_builder.h"

namespace ctcal {
namespace {

using discrete::BaseMotion;
using discrete::BaseSource;
using discrete::BlockList;
using discrete::Keyframe;

class KeyframeMotion {
 public:
  KeyframeMotion(const std::vector<Keyframe>& keyframes, ImuIntrinsics* base,
                 const Eigen::Vector3d& g_W, std::int64_t t0_ns,
                 std::function<KeyframeSlot(double)> slot)
      : kf_(keyframes), base_(base), t0_ns_(t0_ns), slot_(std::move(slot)) {
    g_W_[0] = g_W.x();
    g_W_[1] = g_W.y();
    g_W_[2] = g_W.z();
    if (kf_.empty())
      throw std::invalid_argument("report data: no keyframes");
    // A.1 at the keyframe itself: the corrected base reading; a_W = d/dt of A.1's velocity at
    // the keyframe (central difference: the midpoint A.1's velocity is not linear in the time).
    for (std::size_t k = 0; k < kf_.size(); ++k) {
      const double h = 1e-4;
      const BaseMotion<double> m0 = Motion(static_cast<int>(k), true, kf_[k].t);
      const BaseMotion<double> m1 = Motion(static_cast<int>(k), true, kf_[k].t + h);
      const BaseMotion<double> m2 = Motion(static_cast<int>(k), true, kf_[k].t - h);
      w_k_.push_back(m0.w_B);
      a_k_.push_back((m1.v_W - m2.v_W) / (2.0 * h));
    }
  }

  Se3Kinematics<double> operator()(std::int64_t t_ns, int derivatives) {
    const double t = 1e-9 * static_cast<double>(t_ns - t0_ns_);
    const int n = static_cast<int>(kf_.size());
    const bool before = t <= kf_.front().t, after = t >= kf_.back().t;
    if (derivatives == 0 || before || after || n < 2) {
      KeyframeSlot s = slot_ ? slot_(t) : KeyframeSlot{};
      if (s.k < 0 || s.k >= n || (!s.kinematic && s.k + 1 >= n))
        s = KeyframeSlot{before || n < 2 ? 0 : n - 1, true};
      if (derivatives > 0)  // outside the keyframes: A.1 from the end keyframe
        s = KeyframeSlot{before || n < 2 ? 0 : n - 1, true};
      const BaseMotion<double> m = Motion(s.k, s.kinematic, t);
      Se3Kinematics<double> kin;
      kin.R_W_B = m.q_W_B.normalized().toRotationMatrix();
      kin.p_W_B = m.p_W_B;
      kin.v_W = m.v_W;
      kin.w_B = m.w_B;
      if (s.kinematic)
        kin.a_W = a_k_[static_cast<std::size_t>(s.k)];
      return kin;
    }
    const auto it = std::upper_bound(kf_.begin(), kf_.end(), t,
                                     [](double x, const Keyframe& k) { return x < k.t; });
    const int k = static_cast<int>(it - kf_.begin()) - 1;
    Se3Kinematics<double> kin = Hermite(k, t);
    // Angular acceleration: central differences of the interpolated rate (a polynomial's).
    const double h = 1e-4;
    kin.alpha_B = (Hermite(k, t + h).w_B - Hermite(k, t - h).w_B) / (2.0 * h);
    return kin;
  }

 private:
  BaseMotion<double> Motion(int k, bool kinematic, double t) {
    BlockList list;
    Keyframe* a = &kf_[static_cast<std::size_t>(k)];
    Keyframe* b = kinematic ? nullptr : &kf_[static_cast<std::size_t>(k) + 1];
    const BaseSource src = BaseSource::Add(&list, a, b, base_, g_W_);
    return discrete::BaseMotionAt<double>(src, list.blocks().data(), t);
  }

  // On [t_k, t_k1] with tau = t - t_k: p(tau) quintic through (p, v, a_W) at both ends;
  // R = R_k Exp(phi(tau)), phi cubic with phi(0) = 0, phi'(0) = w_k, phi(h) = Log(R_k^T R_k1),
  // phi'(h) = Jr(phi(h))^-1 w_k1 (so that w_B = Jr(phi) phi' matches both keyframes).
  Se3Kinematics<double> Hermite(int k, double t) const {
    const Keyframe& A = kf_[static_cast<std::size_t>(k)];
    const Keyframe& B = kf_[static_cast<std::size_t>(k) + 1];
    const auto K = static_cast<std::size_t>(k);
    const double h = B.t - A.t, tau = t - A.t;
    const Eigen::Vector3d p0(A.p_W_B.data()), v0(A.v_W.data()), p1(B.p_W_B.data()),
        v1(B.v_W.data());
    const Eigen::Vector3d& a0 = a_k_[K];
    const Eigen::Vector3d& a1 = a_k_[K + 1];
    Eigen::Matrix3d M;
    M << h * h * h, h * h * h * h, h * h * h * h * h, 3 * h * h, 4 * h * h * h, 5 * h * h * h * h,
        6 * h, 12 * h * h, 20 * h * h * h;
    Eigen::Matrix3d rhs;  // rows: position, velocity, acceleration conditions; columns: axes
    rhs.row(0) = (p1 - p0 - v0 * h - 0.5 * a0 * h * h).transpose();
    rhs.row(1) = (v1 - v0 - a0 * h).transpose();
    rhs.row(2) = (a1 - a0).transpose();
    const Eigen::Matrix3d c = M.partialPivLu().solve(rhs);  // rows c3, c4, c5
    Se3Kinematics<double> kin;
    const double t2 = tau * tau, t3 = t2 * tau, t4 = t3 * tau, t5 = t4 * tau;
    kin.p_W_B =
        p0 + v0 * tau + 0.5 * a0 * t2 + (c.row(0) * t3 + c.row(1) * t4 + c.row(2) * t5).transpose();
    kin.v_W =
        v0 + a0 * tau + (3 * c.row(0) * t2 + 4 * c.row(1) * t3 + 5 * c.row(2) * t4).transpose();
    kin.a_W = a0 + (6 * c.row(0) * tau + 12 * c.row(1) * t2 + 20 * c.row(2) * t3).transpose();

    const Eigen::Quaterniond q0(A.q_W_B[3], A.q_W_B[0], A.q_W_B[1], A.q_W_B[2]);
    const Eigen::Quaterniond q1(B.q_W_B[3], B.q_W_B[0], B.q_W_B[1], B.q_W_B[2]);
    const Eigen::Vector3d Phi = LogSO3<double>(Eigen::Quaterniond(q0.conjugate() * q1));
    const Eigen::Vector3d& w0 = w_k_[K];
    const Eigen::Vector3d d1 = RightJacobianInvSO3<double>(Phi) * w_k_[K + 1];
    Eigen::Matrix2d R;
    R << h * h, h * h * h, 2 * h, 3 * h * h;
    Eigen::Matrix<double, 2, 3> r;
    r.row(0) = (Phi - w0 * h).transpose();
    r.row(1) = (d1 - w0).transpose();
    const Eigen::Matrix<double, 2, 3> b = R.partialPivLu().solve(r);  // rows b2, b3
    const Eigen::Vector3d phi = w0 * tau + (b.row(0) * t2 + b.row(1) * t3).transpose();
    const Eigen::Vector3d dphi = w0 + (2 * b.row(0) * tau + 3 * b.row(1) * t2).transpose();
    kin.R_W_B = (q0 * ExpSO3<double>(phi)).normalized().toRotationMatrix();
    kin.w_B = RightJacobianSO3<double>(phi) * dphi;
    return kin;
  }

  std::vector<Keyframe> kf_;
  ImuIntrinsics* base_;
  double g_W_[3];
  std::int64_t t0_ns_;
  std::function<KeyframeSlot(double)> slot_;
  std::vector<Eigen::Vector3d> w_k_, a_k_;
};

}  // namespace

TrajectoryEvaluator KeyframeTrajectory(const std::vector<Keyframe>& keyframes, ImuIntrinsics* base,
                                       const Eigen::Vector3d& g_W, std::int64_t t0_ns,
                                       std::function<KeyframeSlot(double t)> slot) {
  auto motion = std::make_shared<KeyframeMotion>(keyframes, base, g_W, t0_ns, std::move(slot));
  return [motion](std::int64_t t_ns, int derivatives) { return (*motion)(t_ns, derivatives); };
}

BiasEvaluator KeyframeBiases(std::vector<double> t_k, std::vector<Eigen::Vector3d> b_g,
                             std::vector<Eigen::Vector3d> b_a, std::int64_t t0_ns,
                             double time_offset) {
  if (t_k.empty() || b_g.size() != t_k.size() || (!b_a.empty() && b_a.size() != t_k.size()))
    throw std::invalid_argument("report data: keyframe biases do not match the keyframes");
  return [t_k = std::move(t_k), b_g = std::move(b_g), b_a = std::move(b_a), t0_ns, time_offset](
             std::int64_t t_ns, Eigen::Vector3d* bg, Eigen::Vector3d* ba) {
    const double t = 1e-9 * static_cast<double>(t_ns - t0_ns) + time_offset;
    const auto it = std::upper_bound(t_k.begin(), t_k.end(), t);
    const std::size_t k = it == t_k.begin() ? 0 : static_cast<std::size_t>(it - t_k.begin()) - 1;
    *bg = b_g[k];
    if (!b_a.empty())
      *ba = b_a[k];
  };
}

}  // namespace ctcal
