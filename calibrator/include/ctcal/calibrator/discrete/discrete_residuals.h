// The residuals of the discrete MVIS problem that read the base pose between keyframes (report
// eq. 38-39, 44, appendices A and B): camera corners, auxiliary IMU and auxiliary gyroscope
// preintegration. The base IMU's own factor is preintegration_residual.h.
//
// All three are Jet automatic differentiation (ceres::DynamicAutoDiffCostFunction): the pose
// interpolation, the re-integration of the auxiliary samples with the current intrinsics and the
// camera projections are templated on the scalar, so the Jacobians are exact, including those
// with respect to the time offsets (through the query time). tests/calibrator/
// test_discrete_residuals.cpp checks every block against central differences on its manifold.
//
// Base pose at base-clock time t (BaseMotionAt):
//  - A.1 kinematic, from keyframe k with s = t - t_k, midpoint rule (PropagateMidpoint): the
//    corrected base IMU reading at t_k + s/2 (the raw reading's cubic at t_k continued linearly,
//    raw_k + (s/2) d raw/dt, then ImuTrueFromRaw with the current base intrinsics and the
//    keyframe's biases):
//      R = R_k Exp(w_mid s),  R_mid = R_k Exp(w_mid s/2),
//      p = p_k + v_k s + (R_mid a_mid + g) s^2 / 2,  v = v_k + (R_mid a_mid + g) s,
//    w_B the corrected reading at t (raw_k + s d raw/dt). The rotation error is O(s^3): with the
//    keyframes at the frame times of the initial time offsets, every corner of a camera sits at
//    the offset's change s from its keyframe (5-7 ms with table4 guesses), where the O(s^2) of
//    the constant reading (2e-4 rad at 5 ms) biased the cameras' extrinsics by up to 5 sigma.
//  - A.2 pose-based between keyframes k, k+1 (u = (t - t_k) / (t_k1 - t_k)):
//      R = R_k Exp(u Log(R_k^T R_k1)),  p = p_k + u (p_k1 - p_k),
//      w_B = Log(R_k^T R_k1) / dt,  v = (p_k1 - p_k) / dt.
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "ctcal/calibrator/discrete/pose_interpolation.h"
#include "ctcal/calibrator/discrete/preintegration.h"
#include "ctcal/calibrator/discrete/preintegration_residual.h"
#include "ctcal/calibrator/discrete/split_integration.h"
#include "ctcal/calibrator/residuals/corner_residual.h"
#include "ctcal/calibrator/residuals/residual_support.h"
#include "ctcal/sensors/camera_model.h"
#include "ctcal/sensors/gyro_intrinsics.h"
#include "ctcal/sensors/imu_intrinsics.h"

namespace ctcal::discrete {

// The parameter blocks of one cost function, each once (Ceres rejects a block listed twice, e.g.
// keyframe k+1 of an A.2 corner that is also the end of an auxiliary interval).
class BlockList {
 public:
  // The index of `block` in the list, appended when new.
  int Add(double* block, int size) {
    for (std::size_t i = 0; i < blocks_.size(); ++i) {
      if (blocks_[i] == block)
        return static_cast<int>(i);
    }
    blocks_.push_back(block);
    sizes_.push_back(size);
    return static_cast<int>(blocks_.size()) - 1;
  }
  const std::vector<double*>& blocks() const { return blocks_; }
  const std::vector<int>& sizes() const { return sizes_; }

 private:
  std::vector<double*> blocks_;
  std::vector<int> sizes_;
};

// Indices of an IMU's intrinsics blocks (-1: the model has none).
struct ImuBlockIndex {
  ImuModelLayout layout;
  int Dw = -1, Da = -1, Tg = -1, rotation = -1;

  static ImuBlockIndex Add(BlockList* list, ImuIntrinsics* intr) {
    ImuBlockIndex ix;
    ix.layout = intr->layout();
    if (intr->Dw() != nullptr)
      ix.Dw = list->Add(intr->Dw(), intr->DwSize());
    if (intr->Da() != nullptr)
      ix.Da = list->Add(intr->Da(), intr->DaSize());
    if (intr->Tg() != nullptr)
      ix.Tg = list->Add(intr->Tg(), intr->TgSize());
    if (intr->q_rotation() != nullptr)
      ix.rotation = list->Add(intr->q_rotation(), 4);
    return ix;
  }
  template <typename T>
  ImuBlocks<T> Of(T const* const* x) const {
    ImuBlocks<T> b;
    b.Dw = Dw >= 0 ? x[Dw] : nullptr;
    b.Da = Da >= 0 ? x[Da] : nullptr;
    b.Tg = Tg >= 0 ? x[Tg] : nullptr;
    b.q_rotation = rotation >= 0 ? x[rotation] : nullptr;
    return b;
  }
};

// The state of the base IMU at one keyframe (blocks Ceres optimises in place).
struct Keyframe {
  double t = 0.0;                                   // base clock, s (relative to the problem's t0)
  std::array<double, 4> q_W_B{0.0, 0.0, 0.0, 1.0};  // x, y, z, w (So3LeftManifold)
  std::array<double, 3> p_W_B{0.0, 0.0, 0.0};
  std::array<double, 3> v_W{0.0, 0.0, 0.0};
  std::array<double, 3> b_g{0.0, 0.0, 0.0};
  std::array<double, 3> b_a{0.0, 0.0, 0.0};
  RawImuSample raw;       // the base IMU's raw reading at t (A.1)
  RawImuSample raw_rate;  // its time derivative (w_m, a_m: d/dt of the readings; t unused)
};

struct KeyframeIndex {
  int q = -1, p = -1, v = -1, bg = -1, ba = -1;
  static KeyframeIndex Add(BlockList* list, Keyframe* k) {
    KeyframeIndex ix;
    ix.q = list->Add(k->q_W_B.data(), 4);
    ix.p = list->Add(k->p_W_B.data(), 3);
    ix.v = list->Add(k->v_W.data(), 3);
    ix.bg = list->Add(k->b_g.data(), 3);
    ix.ba = list->Add(k->b_a.data(), 3);
    return ix;
  }
};

// Where the base motion at a query time comes from (A.1 from keyframe k, or A.2 between k, k1),
// and the blocks it reads.
struct BaseSource {
  bool kinematic = true;
  KeyframeIndex k, k1;  // k1 only for A.2
  double t_k = 0.0, t_k1 = 0.0;
  RawImuSample raw_k, raw_rate_k;
  ImuBlockIndex base;  // base intrinsics (A.1)
  int g_W = -1;

  // A.1 from keyframe `kf`, or A.2 between `kf` and `kf1` when kf1 != nullptr.
  static BaseSource Add(BlockList* list, Keyframe* kf, Keyframe* kf1, ImuIntrinsics* base_intr,
                        double* g_W) {
    BaseSource s;
    s.kinematic = kf1 == nullptr;
    s.k = KeyframeIndex::Add(list, kf);
    s.t_k = kf->t;
    s.raw_k = kf->raw;
    s.raw_rate_k = kf->raw_rate;
    s.g_W = list->Add(g_W, 3);
    if (s.kinematic) {
      s.base = ImuBlockIndex::Add(list, base_intr);
    } else {
      s.k1 = KeyframeIndex::Add(list, kf1);
      s.t_k1 = kf1->t;
    }
    return s;
  }
};

template <typename T>
struct BaseMotion {
  QuatT<T> q_W_B = QuatT<T>::Identity();
  Vec3T<T> p_W_B = Vec3T<T>::Zero();
  Vec3T<T> v_W = Vec3T<T>::Zero();
  Vec3T<T> w_B = Vec3T<T>::Zero();
};

// The base motion at base-clock time t (header comment).
template <typename T>
BaseMotion<T> BaseMotionAt(const BaseSource& s, T const* const* x, const T& t) {
  using CV = Eigen::Map<const Vec3T<T>>;
  const Eigen::Map<const QuatT<T>> q_k(x[s.k.q]);
  const CV p_k(x[s.k.p]);
  BaseMotion<T> m;
  if (s.kinematic) {
    const T ds = t - T(s.t_k);
    const auto corrected = [&](const T& tau, Vec3T<T>* w_B, Vec3T<T>* a_B) {
      ImuTrueFromRaw<T>(s.base.layout, s.base.Of<T>(x),
                        Vec3T<T>(s.raw_k.w_m.cast<T>() + s.raw_rate_k.w_m.cast<T>() * tau),
                        Vec3T<T>(s.raw_k.a_m.cast<T>() + s.raw_rate_k.a_m.cast<T>() * tau),
                        CV(x[s.k.bg]), CV(x[s.k.ba]), w_B, a_B);
    };
    Vec3T<T> w_mid, a_mid, a_t;
    corrected(T(0.5) * ds, &w_mid, &a_mid);
    corrected(ds, &m.w_B, &a_t);
    const InterpolatedPose<T> pose =
        PropagateMidpoint<T>(QuatT<T>(q_k), Vec3T<T>(p_k), Vec3T<T>(CV(x[s.k.v])), w_mid, a_mid,
                             Vec3T<T>(CV(x[s.g_W])), s.t_k, t, &m.v_W);
    m.q_W_B = pose.q_W_B;
    m.p_W_B = pose.p_W_B;
  } else {
    const Eigen::Map<const QuatT<T>> q_k1(x[s.k1.q]);
    const CV p_k1(x[s.k1.p]);
    const InterpolatedPose<T> pose = InterpolateGeodesic<T>(
        QuatT<T>(q_k), Vec3T<T>(p_k), QuatT<T>(q_k1), Vec3T<T>(p_k1), s.t_k, s.t_k1, t);
    const T dt(s.t_k1 - s.t_k);
    m.q_W_B = pose.q_W_B;
    m.p_W_B = pose.p_W_B;
    m.v_W = (p_k1 - p_k) / dt;
    m.w_B = LogSO3<T>(QuatT<T>(q_k.conjugate() * q_k1)) / dt;
  }
  return m;
}

// --- camera corner ----------------------------------------------------------------------------
// Reprojection of a board corner (corner_residual.h's model) with the base pose from BaseSource
// at base time t = stamp + time_offset + v_meas line_delay:
//   p_C = R_B_C^T (R_W_B(t)^T (p_W - p_W_B(t)) - t_B_C),  r = (uv_meas - project(p_C)) / sigma.
struct CornerIndex {
  int q_B_C = -1, t_B_C = -1, time_offset = -1, line_delay = -1, params = -1;
};

template <class Model>
struct DiscreteCornerFunctor {
  CornerMeasurement m;
  double stamp = 0.0;  // camera clock, s (relative to the problem's t0)
  BaseSource src;
  CornerIndex c;

  template <typename T>
  bool operator()(T const* const* x, T* residuals) const {
    const T t = T(stamp) + x[c.time_offset][0] + T(m.uv.y()) * x[c.line_delay][0];
    const BaseMotion<T> b = BaseMotionAt<T>(src, x, t);
    const Mat3T<T> R_B_C = Eigen::Map<const QuatT<T>>(x[c.q_B_C]).toRotationMatrix();
    const Eigen::Map<const Vec3T<T>> t_B_C(x[c.t_B_C]);
    const Vec3T<T> p_B = b.q_W_B.conjugate() * Vec3T<T>(m.p_W.cast<T>() - b.p_W_B);
    const Vec3T<T> p_C = R_B_C.transpose() * (p_B - t_B_C);
    Eigen::Matrix<T, 2, 1> uv;
    if (!Model::template Project<T>(x[c.params], p_C, &uv))
      return false;
    const T inv_sigma = T(1.0 / m.sigma_px);
    residuals[0] = (T(m.uv.x()) - uv.x()) * inv_sigma;
    residuals[1] = (T(m.uv.y()) - uv.y()) * inv_sigma;
    return true;
  }
};

// Builds the corner's cost function and its block list (`list` must start empty).
ceres::CostFunction* MakeDiscreteCorner(CameraModelType type, const CornerMeasurement& m,
                                        double stamp, const BaseSource& src, const CornerIndex& c,
                                        const BlockList& list);

// --- auxiliary IMU (eq. 38-39, appendix B) -----------------------------------------------------
// The auxiliary IMU A's samples, integrated on its own clock over [tau_i, tau_j] (the keyframe
// times minus its time offset at build time) with its current intrinsics and its biases of
// keyframe i, give the deltas of A's motion between base times tau + time_offset. A's pose there
// is the base pose (BaseSource) composed with T_B_A:
//   R_W_A = R_W_B R_B_A,   p_W_A = p_W_B + R_W_B t_B_A,
// and A's velocity is either its own state per keyframe (--aux-velocity state) or the rigid-body
// velocity of B's motion (appendix B, --aux-velocity rigid):
//   v_W_A = v_W + R_W_B (w_B x t_B_A)     (w_B the base gyro's corrected reading at the keyframe).
// The residual is the base factor's (PreintegrationError) on A's states, whitened by A's
// preintegration covariance.
struct AuxImuIndex {
  ImuBlockIndex intr;
  int q_B_A = -1, t_B_A = -1, time_offset = -1;
  int v_i = -1, v_j = -1;  // -1: rigid-body velocity
  int bg = -1, ba = -1;
};

struct AuxImuFunctor {
  std::shared_ptr<const Preintegration> pre;  // on A's clock, for the readings and whitening
  BaseSource src_i, src_j;
  AuxImuIndex a;

  template <typename T>
  struct AuxState {
    QuatT<T> q;
    Vec3T<T> p, v;
  };

  template <typename T>
  AuxState<T> StateAt(const BaseSource& src, int v_index, double tau, T const* const* x) const {
    const T t = T(tau) + x[a.time_offset][0];
    const BaseMotion<T> b = BaseMotionAt<T>(src, x, t);
    const Eigen::Map<const QuatT<T>> q_B_A(x[a.q_B_A]);
    const Eigen::Map<const Vec3T<T>> t_B_A(x[a.t_B_A]);
    AuxState<T> s;
    s.q = b.q_W_B * q_B_A;
    s.p = b.p_W_B + b.q_W_B * t_B_A;
    if (v_index >= 0)
      s.v = Eigen::Map<const Vec3T<T>>(x[v_index]);
    else
      s.v = b.v_W + b.q_W_B * Vec3T<T>(b.w_B.cross(t_B_A));
    return s;
  }

  // A's deltas with its current intrinsics and biases (reads those blocks only).
  template <typename T>
  PreintegratedDeltas<T> Deltas(T const* const* x) const {
    return IntegrateDeltas<T>(pre->readings(), a.intr.layout, a.intr.Of<T>(x),
                              Eigen::Map<const Vec3T<T>>(x[a.bg]),
                              Eigen::Map<const Vec3T<T>>(x[a.ba]));
  }

  // Whether block b is read by Deltas only (split_integration.h).
  std::vector<bool> IntegrationBlocks(std::size_t num_blocks) const {
    std::vector<bool> out(num_blocks, false);
    for (const int b : {a.intr.Dw, a.intr.Da, a.intr.Tg, a.intr.rotation, a.bg, a.ba}) {
      if (b >= 0)
        out[static_cast<std::size_t>(b)] = true;
    }
    return out;
  }

  template <typename T>
  bool operator()(T const* const* x, T* residuals) const {
    return Error<T>(x, Deltas<T>(x), residuals);
  }

  template <typename T>
  bool Error(T const* const* x, const PreintegratedDeltas<T>& d, T* residuals) const {
    const AuxState<T> si = StateAt<T>(src_i, a.v_i, pre->t_i(), x);
    const AuxState<T> sj = StateAt<T>(src_j, a.v_j, pre->t_j(), x);
    const Eigen::Matrix<T, 9, 1> r = PreintegrationError<T>(
        d, pre->dt(), Eigen::Map<const Vec3T<T>>(x[src_i.g_W]), si.q, si.p, si.v, sj.q, sj.p, sj.v);
    Eigen::Map<Eigen::Matrix<T, 9, 1>> out(residuals);
    out = pre->sqrt_information().cast<T>() * r;
    return true;
  }
};

// --- auxiliary gyroscope (eq. 44) -------------------------------------------------------------
// Rotation-only preintegration of gyroscope G over [tau_i, tau_j] on its clock (same nodes and
// RK4 as the base, GyroTrueFromRaw with its current D_w and bias at keyframe i):
//   r = Log(dR_G^T R_B_G^T R_W_B(tau_i + t_off)^T R_W_B(tau_j + t_off) R_B_G),
// whitened by the propagated rotation covariance (dphi' = Exp(w h)^T dphi + Jr(w h) h dw).
class GyroPreintegration {
 public:
  // Throws std::invalid_argument naming the times for an empty or uncovered interval.
  GyroPreintegration(const std::vector<RawImuSample>& samples, double t_i, double t_j,
                     const GyroIntrinsics& intrinsics, const InertialNoise& noise,
                     const Eigen::Vector3d& b_g);
  double t_i() const { return t_i_; }
  double t_j() const { return t_j_; }
  const std::vector<RawImuSample>& readings() const { return readings_; }
  const QuatT<double>& dR() const { return dR_; }
  const Eigen::Matrix3d& covariance() const { return covariance_; }
  const Eigen::Matrix3d& sqrt_information() const { return sqrt_information_; }

 private:
  std::vector<RawImuSample> readings_;
  double t_i_ = 0.0, t_j_ = 0.0;
  QuatT<double> dR_ = QuatT<double>::Identity();
  Eigen::Matrix3d covariance_ = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d sqrt_information_ = Eigen::Matrix3d::Identity();
};

// dR_G from the readings with the gyro's current intrinsics and bias (any scalar).
template <typename T>
QuatT<T> IntegrateGyroRotation(const std::vector<RawImuSample>& readings, GyroModel model,
                               const T* Dw, const Vec3T<T>& b_g) {
  PreintegratedDeltas<T> d;
  std::vector<Vec3T<T>> w(readings.size());
  for (std::size_t k = 0; k < readings.size(); ++k)
    w[k] = GyroTrueFromRaw<T>(model, Dw, readings[k].w_m.cast<T>(), b_g);
  const Vec3T<T> zero = Vec3T<T>::Zero();
  for (std::size_t k = 0; k + 2 < readings.size(); k += 2)
    detail::Rk4Step<T>(w[k], zero, w[k + 1], zero, w[k + 2], zero,
                       readings[k + 2].t - readings[k].t, &d);
  return d.dR;
}

struct AuxGyroIndex {
  GyroModel model = GyroModel::kNone;
  int Dw = -1, q_B_G = -1, time_offset = -1, bg = -1;
};

struct AuxGyroFunctor {
  std::shared_ptr<const GyroPreintegration> pre;
  BaseSource src_i, src_j;
  AuxGyroIndex a;

  // dR_G with the gyro's current intrinsics and bias (dv, dp unused: zero).
  template <typename T>
  PreintegratedDeltas<T> Deltas(T const* const* x) const {
    PreintegratedDeltas<T> d;
    d.dR = IntegrateGyroRotation<T>(pre->readings(), a.model, a.Dw >= 0 ? x[a.Dw] : nullptr,
                                    Eigen::Map<const Vec3T<T>>(x[a.bg]));
    return d;
  }

  std::vector<bool> IntegrationBlocks(std::size_t num_blocks) const {
    std::vector<bool> out(num_blocks, false);
    for (const int b : {a.Dw, a.bg}) {
      if (b >= 0)
        out[static_cast<std::size_t>(b)] = true;
    }
    return out;
  }

  template <typename T>
  bool operator()(T const* const* x, T* residuals) const {
    return Error<T>(x, Deltas<T>(x), residuals);
  }

  template <typename T>
  bool Error(T const* const* x, const PreintegratedDeltas<T>& d, T* residuals) const {
    const QuatT<T>& dR = d.dR;
    const BaseMotion<T> bi = BaseMotionAt<T>(src_i, x, T(pre->t_i()) + x[a.time_offset][0]);
    const BaseMotion<T> bj = BaseMotionAt<T>(src_j, x, T(pre->t_j()) + x[a.time_offset][0]);
    const Eigen::Map<const QuatT<T>> q_B_G(x[a.q_B_G]);
    const QuatT<T> rel = q_B_G.conjugate() * bi.q_W_B.conjugate() * bj.q_W_B * q_B_G;
    const Vec3T<T> r = LogSO3<T>(QuatT<T>(dR.conjugate() * rel));
    Eigen::Map<Vec3T<T>> out(residuals);
    out = pre->sqrt_information().cast<T>() * r;
    return true;
  }
};

// The auxiliary factors as SplitIntegrationCost (the integration differentiated only with respect
// to the sensor's intrinsics and biases); `list` holds the functor's blocks.
template <class Functor>
ceres::CostFunction* MakeSplitIntegration(Functor functor, const BlockList& list,
                                          int num_residuals) {
  const std::vector<bool> integration = functor.IntegrationBlocks(list.sizes().size());
  return new SplitIntegrationCost<Functor>(std::make_shared<const Functor>(std::move(functor)),
                                           list.sizes(), integration, num_residuals);
}

}  // namespace ctcal::discrete
