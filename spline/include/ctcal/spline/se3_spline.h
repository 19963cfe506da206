// The body trajectory T_W_B(t) as a uniform B-spline of order N, in two representations behind one
// interface, Se3Spline<N, Rep>:
//   kSplit (default): a cumulative SO(3) spline for R_W_B and an R^3 spline for p_W_B,
//   kJoint: a cumulative SE(3) spline (the pose knots interpolated on the group).
// Both answer the pose, body angular velocity w_B and acceleration alpha_B, world velocity v_W and
// acceleration a_W, their time derivatives (for time offsets), and the accelerometer's specific
// force a_B = R_W_B^T (a_W - g_W) (SPEC section 1).
//
// Knot storage, the same 7 doubles per knot for both: quaternion x, y, z, w of R_W_Bk, then p_W_Bk.
// Ceres parameter blocks of one segment (first knot k), in this order:
//   kSplit: blocks 0..N-1 = rotations of knots k..k+N-1 (4 doubles, So3RightManifold, tangent 3),
//           blocks N..2N-1 = positions of knots k..k+N-1 (3 doubles, Euclidean, tangent 3);
//   kJoint: blocks 0..N-1 = poses of knots k..k+N-1 (7 doubles, Se3RightManifold, tangent 6:
//           [rho; phi], T = T_hat Exp([rho; phi])).
// Every Jacobian with respect to the knots is 3 x 6N: block b occupies the columns
// [TangentOffset(b), TangentOffset(b) + TangentSize(b)) and is with respect to exactly that block's
// manifold tangent. Rotation outputs use the right perturbation R_W_B = R_hat * Exp(dtheta).
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <vector>

#include "ctcal/spline/cumulative_lie_segment.h"
#include "ctcal/spline/rd_spline.h"
#include "ctcal/spline/uniform_spline.h"

namespace ctcal {

enum class Se3Representation { kSplit, kJoint };

// Evaluation of a trajectory at one time. Fields beyond max_derivative are left zero:
//   0: R_W_B, q_W_B, p_W_B;  1: + w_B, v_W;  2: + alpha_B, a_W;  3: + dalpha_B, jerk_W.
// Time derivatives: d R_W_B/dt = R_W_B [w_B]x, d p/dt = v_W, d w_B/dt = alpha_B, d v_W/dt = a_W,
// d alpha_B/dt = dalpha_B, d a_W/dt = jerk_W, d a_B/dt = SpecificForceRate.
template <typename T>
struct Se3Kinematics {
  Mat3T<T> R_W_B = Mat3T<T>::Identity();
  Vec3T<T> p_W_B = Vec3T<T>::Zero();
  Vec3T<T> w_B = Vec3T<T>::Zero();
  Vec3T<T> v_W = Vec3T<T>::Zero();
  Vec3T<T> alpha_B = Vec3T<T>::Zero();
  Vec3T<T> a_W = Vec3T<T>::Zero();
  Vec3T<T> dalpha_B = Vec3T<T>::Zero();
  Vec3T<T> jerk_W = Vec3T<T>::Zero();

  QuatT<T> q_W_B() const { return QuatT<T>(R_W_B); }
  // a_B = R_W_B^T (a_W - g_W): what an ideal accelerometer in B measures (needs max_derivative 2).
  Vec3T<T> SpecificForce(const Vec3T<T>& g_W) const { return R_W_B.transpose() * (a_W - g_W); }
  // d a_B/dt = -w_B x a_B + R_W_B^T jerk_W (needs max_derivative 3).
  Vec3T<T> SpecificForceRate(const Vec3T<T>& g_W) const {
    return -w_B.cross(SpecificForce(g_W)) + R_W_B.transpose() * jerk_W;
  }
};

// Optional Jacobians of the kinematics with respect to the 6N tangent coordinates of the local
// support (layout above); nullptr = not computed. J_f_knots is the specific force's and needs g_W.
// The specific force's Jacobian with respect to g_W is -R_W_B^T.
template <typename T, int N>
struct Se3Jacobians {
  using Block = Eigen::Matrix<T, 3, 6 * N>;
  Block* J_R_knots = nullptr;
  Block* J_p_knots = nullptr;
  Block* J_w_knots = nullptr;
  Block* J_alpha_knots = nullptr;
  Block* J_v_knots = nullptr;
  Block* J_a_knots = nullptr;
  Block* J_f_knots = nullptr;
};

namespace internal {

template <int N, Se3Representation Rep>
struct Se3SegmentImpl;

template <int N>
struct Se3SegmentImpl<N, Se3Representation::kSplit> {
  static constexpr int kNumBlocks = 2 * N;
  static constexpr int AmbientSize(int b) { return b < N ? 4 : 3; }
  static constexpr int TangentOffset(int b) { return 3 * b; }
  static constexpr int TangentSize(int) { return 3; }
  static const double* BlockPointer(const double* knot_data, int b) {
    return b < N ? knot_data + 7 * b : knot_data + 7 * (b - N) + 4;
  }

  template <typename T>
  static void Evaluate(const T* const* blocks, const T& u, const T& inv_dt, int max_derivative,
                       const Vec3T<T>* g_W, Se3Kinematics<T>* out, const Se3Jacobians<T, N>* J) {
    using Rot = CumulativeLieSegment<So3Group, N>;
    using Block = typename Se3Jacobians<T, N>::Block;
    const bool jac = J != nullptr;
    const bool jac_f = jac && J->J_f_knots != nullptr;
    const bool jac_R = jac && (J->J_R_knots != nullptr || jac_f);
    const bool jac_a = jac && (J->J_a_knots != nullptr || jac_f);

    typename Rot::template KnotJacobians<T> J_R, J_w, J_alpha;
    typename Rot::template Jacobians<T> rot_jac;
    if (jac_R)
      rot_jac.J_value_knots = &J_R;
    if (jac && J->J_w_knots != nullptr)
      rot_jac.J_velocity_knots = &J_w;
    if (jac && J->J_alpha_knots != nullptr)
      rot_jac.J_acceleration_knots = &J_alpha;
    typename Rot::template Output<T> rot;
    Rot::Evaluate(blocks, u, inv_dt, max_derivative, true, &rot, jac ? &rot_jac : nullptr);
    out->R_W_B = rot.value;
    out->w_B = rot.velocity;
    out->alpha_B = rot.acceleration;
    out->dalpha_B = rot.jerk;

    // Position: a Euclidean spline, linear in the knots with scalar weights per derivative.
    const T* const* pos = blocks + N;
    std::array<std::array<T, N>, kMaxDerivative + 1> weights;
    const int pos_order = jac_a && max_derivative < 2 ? 2 : max_derivative;
    Vec3T<T>* const pos_out[kMaxDerivative + 1] = {&out->p_W_B, &out->v_W, &out->a_W, &out->jerk_W};
    for (int k = 0; k <= pos_order; ++k) {
      *pos_out[k] = RdSpline<3, N>::EvaluateSegment(pos, u, inv_dt, k, &weights[k]);
    }
    if (!jac)
      return;

    const auto rotation_block = [](const typename Rot::template KnotJacobians<T>& src, Block* dst) {
      dst->setZero();
      for (int i = 0; i < N; ++i)
        dst->template block<3, 3>(0, 3 * i) = src[i];
    };
    const auto position_block = [&weights](int k, const Mat3T<T>& M, Block* dst) {
      dst->setZero();
      for (int i = 0; i < N; ++i)
        dst->template block<3, 3>(0, 3 * (N + i)) = weights[k][i] * M;
    };
    const Mat3T<T> I = Mat3T<T>::Identity();
    if (J->J_R_knots != nullptr)
      rotation_block(J_R, J->J_R_knots);
    if (J->J_w_knots != nullptr)
      rotation_block(J_w, J->J_w_knots);
    if (J->J_alpha_knots != nullptr)
      rotation_block(J_alpha, J->J_alpha_knots);
    if (J->J_p_knots != nullptr)
      position_block(0, I, J->J_p_knots);
    if (J->J_v_knots != nullptr)
      position_block(1, I, J->J_v_knots);
    if (J->J_a_knots != nullptr)
      position_block(2, I, J->J_a_knots);
    if (jac_f) {
      // a_B = R^T (a_W - g_W); R -> R Exp(d) gives Exp(-d) a_B ~= a_B + [a_B]x d.
      const Vec3T<T> f = out->SpecificForce(*g_W);
      position_block(2, out->R_W_B.transpose(), J->J_f_knots);
      const Mat3T<T> F = Hat<T>(f);
      for (int i = 0; i < N; ++i)
        J->J_f_knots->template block<3, 3>(0, 3 * i) = F * J_R[i];
    }
  }
};

template <int N>
struct Se3SegmentImpl<N, Se3Representation::kJoint> {
  static constexpr int kNumBlocks = N;
  static constexpr int AmbientSize(int) { return 7; }
  static constexpr int TangentOffset(int b) { return 6 * b; }
  static constexpr int TangentSize(int) { return 6; }
  static const double* BlockPointer(const double* knot_data, int b) { return knot_data + 7 * b; }

  // The SE(3) spline gives the body twist xi = [v_B; w_B] = (T^-1 dT/dt)^vee and its derivatives;
  // with R' = R [w]x:
  //   v_W = R v_B,  a_W = R y,  y = v_B' + w x v_B,  jerk_W = R (y' + w x y),
  //   y' = v_B'' + alpha x v_B + w x v_B'.
  // Knot Jacobians: from J_T (rows [rho; phi]), J_xi, J_xi': R -> R Exp(phi), p -> p + R rho, so
  //   J_R = J_T.phi,  J_p = R J_T.rho,  J_v = R (J_vB - [v_B]x J_R),  J_a = R (J_y - [y]x J_R),
  //   J_y = J_vB' + [w]x J_vB - [v_B]x J_w.
  template <typename T>
  static void Evaluate(const T* const* blocks, const T& u, const T& inv_dt, int max_derivative,
                       const Vec3T<T>* g_W, Se3Kinematics<T>* out, const Se3Jacobians<T, N>* J) {
    using Pose = CumulativeLieSegment<Se3Group, N>;
    using Block = typename Se3Jacobians<T, N>::Block;
    const bool jac = J != nullptr;
    const bool jac_f = jac && J->J_f_knots != nullptr;
    const bool jac_a = jac && (J->J_a_knots != nullptr || jac_f);
    const bool jac_R = jac && (J->J_R_knots != nullptr || J->J_p_knots != nullptr ||
                               J->J_v_knots != nullptr || jac_a);
    const bool jac_xi = jac && (J->J_w_knots != nullptr || J->J_v_knots != nullptr || jac_a);
    const bool jac_xid = jac && (J->J_alpha_knots != nullptr || jac_a);

    typename Pose::template KnotJacobians<T> J_T, J_xi, J_xid;
    typename Pose::template Jacobians<T> pose_jac;
    if (jac_R)
      pose_jac.J_value_knots = &J_T;
    if (jac_xi)
      pose_jac.J_velocity_knots = &J_xi;
    if (jac_xid)
      pose_jac.J_acceleration_knots = &J_xid;
    typename Pose::template Output<T> pose;
    Pose::Evaluate(blocks, u, inv_dt, max_derivative, true, &pose, jac ? &pose_jac : nullptr);

    const Mat3T<T>& R = pose.value.R;
    out->R_W_B = R;
    out->p_W_B = pose.value.t;
    const Vec3T<T> v_B = pose.velocity.template head<3>();
    const Vec3T<T> w = pose.velocity.template tail<3>();
    const Vec3T<T> dv_B = pose.acceleration.template head<3>();
    const Vec3T<T> y = dv_B + w.cross(v_B);
    out->w_B = w;
    out->alpha_B = pose.acceleration.template tail<3>();
    out->dalpha_B = pose.jerk.template tail<3>();
    if (max_derivative >= 1)
      out->v_W = R * v_B;
    if (max_derivative >= 2)
      out->a_W = R * y;
    if (max_derivative >= 3) {
      const Vec3T<T> dy = pose.jerk.template head<3>() + out->alpha_B.cross(v_B) + w.cross(dv_B);
      out->jerk_W = R * (dy + w.cross(y));
    }
    if (!jac)
      return;

    // Rows of the 6-dof Jacobians, laid out as 3 x 6N.
    const auto rows = [](const typename Pose::template KnotJacobians<T>& src, int row) {
      Block dst;
      for (int i = 0; i < N; ++i)
        dst.template block<3, 6>(0, 6 * i) = src[i].template block<3, 6>(row, 0);
      return dst;
    };
    Block J_R;
    if (jac_R)
      J_R = rows(J_T, 3);
    if (J->J_R_knots != nullptr)
      *J->J_R_knots = J_R;
    if (J->J_p_knots != nullptr)
      *J->J_p_knots = R * rows(J_T, 0);
    if (J->J_w_knots != nullptr)
      *J->J_w_knots = rows(J_xi, 3);
    if (J->J_alpha_knots != nullptr)
      *J->J_alpha_knots = rows(J_xid, 3);
    if (J->J_v_knots != nullptr)
      *J->J_v_knots = R * (rows(J_xi, 0) - Hat<T>(v_B) * J_R);
    if (jac_a) {
      const Block J_y = rows(J_xid, 0) + Hat<T>(w) * rows(J_xi, 0) - Hat<T>(v_B) * rows(J_xi, 3);
      if (J->J_a_knots != nullptr)
        *J->J_a_knots = R * (J_y - Hat<T>(y) * J_R);
      if (jac_f) {
        // a_B = y - R^T g_W;  R -> R Exp(d) changes R^T g_W by -[R^T g_W]x d.
        *J->J_f_knots = J_y - Hat<T>(R.transpose() * *g_W) * J_R;
      }
    }
  }
};

}  // namespace internal

template <int N, Se3Representation Rep = Se3Representation::kSplit>
class Se3Spline : public UniformSpline<N> {
  using Impl = internal::Se3SegmentImpl<N, Rep>;

 public:
  static constexpr Se3Representation kRepresentation = Rep;
  static constexpr int kKnotSize = 7;
  static constexpr int kTangentSize = 6 * N;
  // Parameter blocks of one segment (layout in the file comment).
  static constexpr int kNumBlocks = Impl::kNumBlocks;
  static constexpr int AmbientSize(int b) { return Impl::AmbientSize(b); }
  static constexpr int TangentSize(int b) { return Impl::TangentSize(b); }
  static constexpr int TangentOffset(int b) { return Impl::TangentOffset(b); }
  template <typename T>
  using Jacobians = Se3Jacobians<T, N>;

  // Segment level: blocks[b] -> the parameter block b of the local support (Ceres order), u in
  // [0, 1], inv_dt = 1/dt in 1/s. g_W is needed only for J_f_knots. T = double or ceres::Jet.
  template <typename T>
  static void EvaluateSegment(const T* const* blocks, const T& u, const T& inv_dt,
                              int max_derivative, const Vec3T<T>* g_W, Se3Kinematics<T>* out,
                              const Se3Jacobians<T, N>* J = nullptr) {
    Impl::Evaluate(blocks, u, inv_dt, max_derivative, g_W, out, J);
  }

  // knots: kKnotSize doubles each (quaternion x, y, z, w of R_W_Bk, then p_W_Bk).
  Se3Spline(KnotTiming timing, int num_knots)
      : UniformSpline<N>(timing, num_knots), knots_(kKnotSize * num_knots, 0.0) {
    for (int k = 0; k < num_knots; ++k)
      knots_[kKnotSize * k + 3] = 1.0;
  }

  int NumKnots() const { return UniformSpline<N>::NumKnots(); }
  Eigen::Map<Eigen::Quaterniond> KnotRotation(int k) {
    return Eigen::Map<Eigen::Quaterniond>(KnotData(k));
  }
  Eigen::Map<Eigen::Vector3d> KnotPosition(int k) {
    return Eigen::Map<Eigen::Vector3d>(KnotData(k) + 4);
  }
  Eigen::Quaterniond KnotRotation(int k) const {
    return Eigen::Map<const Eigen::Quaterniond>(KnotData(k));
  }
  Eigen::Vector3d KnotPosition(int k) const {
    return Eigen::Map<const Eigen::Vector3d>(KnotData(k) + 4);
  }
  double* KnotData(int k) { return knots_.data() + kKnotSize * CheckedKnot(k); }
  const double* KnotData(int k) const { return knots_.data() + kKnotSize * CheckedKnot(k); }

  // The kNumBlocks parameter blocks of the segment starting at knot first_index, in Ceres order.
  std::array<double*, Impl::kNumBlocks> SegmentBlocks(int first_index) {
    std::array<double*, Impl::kNumBlocks> blocks;
    const double* base = KnotData(first_index);
    CheckedKnot(first_index + N - 1);
    for (int b = 0; b < Impl::kNumBlocks; ++b)
      blocks[b] = const_cast<double*>(Impl::BlockPointer(base, b));
    return blocks;
  }

  // Class level: evaluate at t_ns + offset_s (throws std::out_of_range outside the spline).
  void Evaluate(std::int64_t t_ns, double offset_s, int max_derivative, const Eigen::Vector3d* g_W,
                Se3Kinematics<double>* out, const Se3Jacobians<double, N>* J = nullptr,
                int* first_index = nullptr) const {
    const SegmentLocation<double> loc = this->ComputeIndexOrThrow(t_ns, offset_s);
    if (first_index != nullptr)
      *first_index = loc.first_index;
    std::array<const double*, Impl::kNumBlocks> blocks;
    for (int b = 0; b < Impl::kNumBlocks; ++b) {
      blocks[b] = Impl::BlockPointer(KnotData(loc.first_index), b);
    }
    Impl::Evaluate(blocks.data(), loc.u, loc.inv_dt, max_derivative, g_W, out, J);
  }

  Se3Kinematics<double> Evaluate(std::int64_t t_ns, int max_derivative = 2) const {
    Se3Kinematics<double> out;
    Evaluate(t_ns, 0.0, max_derivative, nullptr, &out);
    return out;
  }

 private:
  int CheckedKnot(int k) const {
    if (k < 0 || k >= NumKnots()) {
      throw std::out_of_range("knot " + std::to_string(k) + " of a spline with " +
                              std::to_string(NumKnots()) + " knots");
    }
    return k;
  }

  std::vector<double> knots_;
};

}  // namespace ctcal
