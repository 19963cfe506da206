// The samples of one inertial sensor over a run of K consecutive spline segments as one residual
// block, compressed into a square-root information factor over the block's columns (the camera
// frames' compression of frame_corners_residual.h, applied to IMU and gyroscope samples).
//
// Model. Sample i of the run has the whitened residual e_i (6 rows for an IMU, 3 for a gyro) and
// Jacobian J_i of its own residual class (base_imu_residual.h, aux_imu_residual.h,
// aux_gyro_residual.h, evaluated through their analytic EvaluateSample). Every sample of the run
// touches N of the run's N + K - 1 knots and the sensor's other blocks (gravity, the bias knots of
// one bias segment, intrinsics, extrinsics, time offset), so the stacked J = [J_1; ...; J_M] has
// n = 7 (N + K - 1) + n_common ambient columns and 6 M rows; at 1 kHz and 0.029 s knots a run of
// K = 9 segments holds ~260 samples (1570 rows) over ~124 columns.
//
// Compression. The samples' rows are stacked in the blocks' tangent coordinates: the residuals
// hand Ceres J_ambient = J_tangent MinusJacobian (residual_support.h), so J_t = J_ambient P with
// P = diag(PlusJacobian) (MinusJacobian PlusJacobian = I; gravity's plain ambient Jacobian and the
// Euclidean blocks keep P = I). The augmented [J_t | e] is Householder-factored,
// [J_t | e] = Q [R z; 0 rho; 0 0], and the block returns r = [z; last] with
//   last^2 = rho^2 (+ the Huber remainder below)
// and the Jacobian [R MinusJacobian; 0] of each block, which Ceres' PlusJacobian turns back into
// [R; 0] in the tangent. As for the frame blocks (frame_corners_residual.h):
//   ||r||^2 = ||e||^2 (exact cost), [R; 0]^T r = R^T z = J_t^T e (exact gradient),
//   R^T R = J_t^T J_t (exact Gauss-Newton Hessian).
// The factor has the blocks' tangent dimension n rows (the quaternions 3 of 4, the joint SE(3)
// knots 6 of 7) plus the remainder row; the columns of blocks Ceres holds constant are zero. The
// QR, not the normal equations: within one run the intrinsic, bias and knot columns are nearly
// collinear (scaled pivots of J^T J down to ~1e-14 over 20 ms), which the normal equations'
// squared condition number turns into gradient errors of 1e-7.
//
// Robust loss (Huber, threshold a, on s_i = ||e_i||^2), the frame blocks' scheme (their file
// comment derives it): the rows of sample i are scaled by w_i = sqrt(rho'(s_i)) (fixed per
// evaluation, as Ceres' per-block HuberLoss does with its corrector when rho'' <= 0), and
// sum_i rho(s_i) - rho'(s_i) s_i >= 0 is added to last^2, so ||r||^2 = sum rho(s_i).
//
// Stacked form (`stacked`, plain L2 only): where the factor would have more rows than the samples
// (the demo's 200-300 Hz sensors: 7 base-IMU samples per 0.029 s segment are 44 rows, the factor
// ~58), the block returns the samples' own whitened residuals and ambient Jacobians one under the
// other, r = [e_1; ...; e_M]: the per-sample blocks' rows exactly, in one block. What it saves is
// Ceres' per-block work, not flops: its J^T J makes one product term per pair of a block's
// parameter blocks (~120 per base-IMU sample, sorted once per solve), and evaluates, checks and
// scales every block on its own (docs/performance.md step 7b).
//
// Samples held by the caller (`HeldInertialSamples`): a 1 kHz IMU's 600 k samples per 10 min would
// otherwise be held twice, once as the calibrator's selected samples and once as the blocks'
// functors (~144 bytes each: the raw sample, its two segment clocks, the model and whitening). A
// block can instead keep one functor of the sensor (model, whitening) and read its samples where
// the caller keeps them, placing each on its segments when it is evaluated (PlaceSample, the same
// arithmetic as the caller's, so the functor is equal to the bit): 1 byte per sample instead of
// ~144 (docs/performance.md step 7e).
//
// Residual-only evaluations (jacobians == nullptr, Ceres' candidate steps) skip the factorisation
// and return r = [0; sqrt(c)]: the same cost, but a residual vector is only meaningful together
// with its Jacobian. Per-sample whitened residuals (statistics) come from the samples' own
// classes, not from this block.
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "ctcal/calibrator/residuals/aux_gyro_residual.h"
#include "ctcal/calibrator/residuals/inertial_support.h"
#include "ctcal/calibrator/residuals/residual_support.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/spline/so3_manifold.h"

namespace ctcal {

// A raw sample placed on its trajectory and bias segments: the per-sample part of a sample's
// setup (the sensor's model and whitening are the rest).
inline void PlaceSample(const ImuSample& z, const SegmentClock& clock,
                        const SegmentClock& bias_clock, ImuSampleSetup* s) {
  s->z.w_m = z.w_m;
  s->z.a_m = z.a_m;
  s->clock = clock;
  s->bias_clock = bias_clock;
}
inline void PlaceSample(const GyroSample& z, const SegmentClock& clock,
                        const SegmentClock& bias_clock, GyroSampleSetup* s) {
  s->w_m = z.w_m;
  s->clock = clock;
  s->bias_clock = bias_clock;
}

// The raw sample type of a residual's setup.
template <class Setup>
struct RawSampleOf;
template <>
struct RawSampleOf<ImuSampleSetup> {
  using type = ImuSample;
};
template <>
struct RawSampleOf<GyroSampleSetup> {
  using type = GyroSample;
};

// The raw samples of one block where the caller holds them (file comment): sample i is
// samples[i], on trajectory segment first_segment + offsets[i] of `trajectory` and on bias segment
// bias_segment of `bias`, its stamp on the sensor's clock (the clocks are computed from the stamp
// as SegmentClock::At does for every sample residual).
template <class Raw>
struct HeldInertialSamples {
  const Raw* samples = nullptr;
  KnotTiming trajectory;
  int first_segment = 0;
  KnotTiming bias;
  int bias_segment = 0;
};

// The run length K of a sensor's compressed blocks for the Jacobian's size, or 0 where per-sample
// blocks are better. samples_per_segment: the sensor's rate times the knot spacing; sample_rows:
// 6 (IMU) or 3 (gyro); order N; common_cols / common_rank: ambient columns / tangent rank of the
// sensor's blocks besides the knots. A run of K segments stores rows(K) x cols(K) Jacobian values
// for K samples_per_segment samples, against sample_rows x (7 N + common_cols) each on their own;
// Ceres' J^T J costs ~rows x cols^2 per block. K minimises the storage per sample, and the blocks
// are used only where they also at least halve Ceres' J^T J flops (1 kHz IMU: 4x less; 250 Hz:
// none, so the demo keeps per-sample blocks; docs/performance.md step 6).
inline int InertialBlockSegments(double samples_per_segment, int sample_rows, int order,
                                 int common_cols, int common_rank) {
  const double raw_cols = 7.0 * order + common_cols;
  const double raw_storage = sample_rows * raw_cols;
  const double raw_flops = sample_rows * raw_cols * raw_cols;
  int best = 0;
  double best_storage = raw_storage;
  double best_flops = raw_flops;
  for (int K = 1; K <= 64; ++K) {
    const double rows = 6.0 * (order + K - 1) + common_rank + 1;
    const double cols = 7.0 * (order + K - 1) + common_cols;
    const double samples = samples_per_segment * K;
    const double storage = rows * cols / samples;
    if (storage < best_storage) {
      best = K;
      best_storage = storage;
      best_flops = rows * cols * cols / samples;
    }
  }
  return best > 0 && best_flops <= 0.5 * raw_flops ? best : 0;
}

// Sample: BaseImuResidual<N, Rep, Nb>, AuxImuResidual<N, Rep, Nb> or AuxGyroResidual<N, Rep, Nb>.
template <class Sample>
class InertialBlockResidual final : public ceres::CostFunction {
 public:
  using Spline = typename Sample::Spline;
  using Functor = typename Sample::Functor;
  using Raw = typename RawSampleOf<typename Sample::Setup>::type;  // ImuSample or GyroSample
  static constexpr int N = Spline::kTangentSize / 6;
  static constexpr int kGroups = Spline::kNumBlocks / N;  // split: rotations, positions; joint: 1
  static constexpr int kSampleRows = Sample::kNumResiduals;
  static constexpr int kNumTrajBlocks = Spline::kNumBlocks;

  // The trajectory blocks of a run of `num_segments` segments from knot `first_knot`, in the
  // block's order: per group (split: rotations, then positions) the N + K - 1 knots.
  static std::vector<double*> TrajectoryBlocks(Spline& spline, int first_knot, int num_segments) {
    std::vector<double*> blocks;
    const int knots = N + num_segments - 1;
    for (int g = 0; g < kGroups; ++g) {
      for (int k = 0; k < knots; ++k) {
        const int seg = first_knot + std::min(k, num_segments - 1);
        blocks.push_back(spline.SegmentBlocks(seg)[g * N + (first_knot + k - seg)]);
      }
    }
    return blocks;
  }

  // samples: each sample's functor; offsets: each sample's segment relative to the run's first
  // (0 .. num_segments - 1, non-decreasing); sample_sizes: Sample::BlockSizes of the sensor (the
  // blocks after the trajectory's are shared by every sample); common_manifolds: the manifold of
  // each of those shared blocks whose residual Jacobian is lifted from its tangent with
  // MinusJacobian (the left rotations), nullptr for the others (Euclidean blocks, and gravity,
  // whose Jacobian is the plain ambient one); huber_threshold 0: plain L2; stacked: the samples'
  // rows uncompressed (file comment; L2 only).
  InertialBlockResidual(std::vector<Functor> samples, std::vector<std::uint8_t> offsets,
                        int num_segments, const std::vector<int>& sample_sizes,
                        const std::vector<const ceres::Manifold*>& common_manifolds,
                        double huber_threshold, bool stacked = false)
      : samples_(std::move(samples)),
        offsets_(std::move(offsets)),
        num_segments_(num_segments),
        sample_sizes_(sample_sizes),
        huber_(huber_threshold),
        stacked_(stacked) {
    if (samples_.size() != offsets_.size())
      throw std::invalid_argument("InertialBlockResidual: inconsistent samples/offsets/blocks");
    Init(common_manifolds);
  }

  // The same over samples the caller holds (file comment): `sensor` is any functor of the sensor
  // (its per-sample fields are replaced), held.samples[0 .. offsets.size()) the raw samples, which
  // must outlive the block.
  InertialBlockResidual(const Functor& sensor, const HeldInertialSamples<Raw>& held,
                        std::vector<std::uint8_t> offsets, int num_segments,
                        const std::vector<int>& sample_sizes,
                        const std::vector<const ceres::Manifold*>& common_manifolds,
                        double huber_threshold, bool stacked = false)
      : sensor_(sensor),
        held_(held),
        offsets_(std::move(offsets)),
        num_segments_(num_segments),
        sample_sizes_(sample_sizes),
        huber_(huber_threshold),
        stacked_(stacked) {
    if (held.samples == nullptr)
      throw std::invalid_argument("InertialBlockResidual: no held samples");
    Init(common_manifolds);
  }

  int NumSamples() const { return static_cast<int>(offsets_.size()); }
  // The tangent column (= the factor's row) where each of the block's parameter blocks starts.
  const std::vector<int>& TangentColumns() const { return tan_col_; }

  // The knot blocks' manifolds, as the residuals lift their Jacobians (residual_support.h).
  static const ceres::Manifold* TrajectoryManifold(int group) {
    static const So3RightManifold so3;
    static const Se3RightManifold se3;
    if constexpr (Spline::kRepresentation == Se3Representation::kJoint)
      return &se3;
    return group == 0 ? static_cast<const ceres::Manifold*>(&so3) : nullptr;
  }

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    if (stacked_)
      return EvaluateStacked(p, residuals, jacobians);
    return EvaluateCompressed(p, residuals, jacobians);
  }

 private:
  // The checks and the block layout shared by both constructors.
  void Init(const std::vector<const ceres::Manifold*>& common_manifolds) {
    const int num_segments = num_segments_;
    const int num_common = static_cast<int>(sample_sizes_.size()) - kNumTrajBlocks;
    if (offsets_.empty() || num_segments < 1 || num_common < 0 ||
        static_cast<int>(common_manifolds.size()) != num_common)
      throw std::invalid_argument("InertialBlockResidual: inconsistent samples/offsets/blocks");
    if (stacked_ && huber_ > 0.0)
      throw std::invalid_argument("InertialBlockResidual: the stacked form is plain L2 only");
    for (std::size_t i = 0; i < offsets_.size(); ++i) {
      if (offsets_[i] >= num_segments || (i > 0 && offsets_[i] < offsets_[i - 1]))
        throw std::invalid_argument("InertialBlockResidual: sample " + std::to_string(i) +
                                    " has segment offset " + std::to_string(offsets_[i]) +
                                    " out of order or beyond " + std::to_string(num_segments));
    }
    const int knots = N + num_segments - 1;
    std::vector<int> sizes;
    for (int g = 0; g < kGroups; ++g) {
      sizes.insert(sizes.end(), knots, Spline::AmbientSize(g * N));
      manifolds_.insert(manifolds_.end(), knots, TrajectoryManifold(g));
    }
    sizes.insert(sizes.end(), sample_sizes_.begin() + kNumTrajBlocks, sample_sizes_.end());
    manifolds_.insert(manifolds_.end(), common_manifolds.begin(), common_manifolds.end());
    int col = 0, tan = 0;
    for (std::size_t u = 0; u < sizes.size(); ++u) {
      block_col_.push_back(col);
      tan_col_.push_back(tan);
      col += sizes[u];
      tan += manifolds_[u] != nullptr ? manifolds_[u]->TangentSize() : sizes[u];
    }
    num_cols_ = col;
    num_factor_rows_ = tan;
    set_num_residuals(stacked_ ? kSampleRows * NumSamples() : num_factor_rows_ + 1);
    *mutable_parameter_block_sizes() = sizes;
  }

  // Sample i's functor: the owned one, or the sensor's with held sample i placed on its segments
  // (into `placed`).
  const Functor& SampleAt(std::size_t i, std::optional<Functor>* placed) const {
    if (!sensor_)
      return samples_[i];
    placed->emplace(*sensor_);
    const Raw& z = held_.samples[i];
    PlaceSample(z, SegmentClock::At(z.t_ns, held_.trajectory, held_.first_segment + offsets_[i]),
                SegmentClock::At(z.t_ns, held_.bias, held_.bias_segment), &(*placed)->s);
    return **placed;
  }

  // The compressed form (file comment).
  bool EvaluateCompressed(double const* const* p, double* residuals, double** jacobians) const {
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    const int num_sample_blocks = static_cast<int>(sample_sizes_.size());
    const int num_blocks = static_cast<int>(block_col_.size());
    const int n = num_factor_rows_;  // tangent columns
    std::vector<const double*> ps(static_cast<std::size_t>(num_sample_blocks));
    std::vector<double*> js(static_cast<std::size_t>(num_sample_blocks));
    std::vector<RowMajor> J_b(static_cast<std::size_t>(num_sample_blocks));
    const auto union_block = [this](int b, int off) { return UnionBlock(b, off); };
    const bool want = jacobians != nullptr;
    // PlusJacobian of every manifold block (file comment: the stacking is in the tangent).
    std::vector<RowMajor> plus(static_cast<std::size_t>(num_blocks));
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic> A;  // [w J_t | w e], the samples' rows
    if (want) {
      for (int u = 0; u < num_blocks; ++u) {
        const ceres::Manifold* m = manifolds_[static_cast<std::size_t>(u)];
        if (m == nullptr)
          continue;
        RowMajor& P = plus[static_cast<std::size_t>(u)];
        P.resize(m->AmbientSize(), m->TangentSize());
        m->PlusJacobian(p[u], P.data());
      }
      for (int b = 0; b < num_sample_blocks; ++b) {
        J_b[static_cast<std::size_t>(b)].resize(kSampleRows, sample_sizes_[b]);
      }
      A.setZero(kSampleRows * static_cast<Eigen::Index>(NumSamples()), n + 1);
    }

    double cost = 0.0;      // sum rho(s_i)
    double weighted = 0.0;  // sum w_i^2 s_i: the rows' part of it
    double r[kSampleRows];
    std::optional<Functor> placed;
    for (std::size_t i = 0; i < offsets_.size(); ++i) {
      const int off = offsets_[i];
      for (int b = 0; b < num_sample_blocks; ++b) {
        const int u = union_block(b, off);
        ps[static_cast<std::size_t>(b)] = p[u];
        // Ceres asks for the Jacobian of the blocks it estimates; the others' columns stay zero.
        js[static_cast<std::size_t>(b)] =
            want && jacobians[u] != nullptr ? J_b[static_cast<std::size_t>(b)].data() : nullptr;
      }
      if (!Sample::Analytic::EvaluateSample(SampleAt(i, &placed), ps.data(), r,
                                            want ? js.data() : nullptr))
        return false;
      const Eigen::Map<const Eigen::Matrix<double, kSampleRows, 1>> ri(r);
      const double sq = ri.squaredNorm();
      const HuberValue h = Huber(sq, huber_);
      const double w = std::sqrt(h.rho1);
      cost += h.rho;
      weighted += w * w * sq;
      if (!want)
        continue;
      auto rows = A.middleRows(kSampleRows * static_cast<Eigen::Index>(i), kSampleRows);
      for (int b = 0; b < num_sample_blocks; ++b) {
        if (js[static_cast<std::size_t>(b)] == nullptr)
          continue;
        const int u = union_block(b, off);
        const RowMajor& Jb = J_b[static_cast<std::size_t>(b)];
        if (manifolds_[static_cast<std::size_t>(u)] == nullptr) {
          rows.middleCols(tan_col_[u], Jb.cols()) = w * Jb;
        } else {
          const RowMajor& P = plus[static_cast<std::size_t>(u)];
          rows.middleCols(tan_col_[u], P.cols()) = w * (Jb * P);
        }
      }
      rows.col(n) = w * ri;
    }
    Eigen::Map<Eigen::VectorXd> out(residuals, n + 1);
    out.setZero();
    if (!std::isfinite(cost))
      return false;
    if (!want) {
      out(n) = std::sqrt(cost);
      return true;
    }

    // [A_t | e] = Q [R z; 0 rho; 0 0] (file comment).
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(A);
    const Eigen::MatrixXd& QR = qr.matrixQR();
    const int rows = static_cast<int>(std::min<Eigen::Index>(A.rows(), n + 1));
    Eigen::MatrixXd R = Eigen::MatrixXd::Zero(n, n);
    for (int k = 0; k < std::min(rows, n); ++k) {
      R.row(k).tail(n - k) = QR.row(k).segment(k, n - k);
      out(k) = QR(k, n);
    }
    const double rho = rows == n + 1 ? QR(n, n) : 0.0;
    out(n) = std::sqrt(rho * rho + std::max(cost - weighted, 0.0));
    if (!out.allFinite())
      return false;

    for (int u = 0; u < num_blocks; ++u) {
      if (jacobians[u] == nullptr)
        continue;
      const ceres::Manifold* m = manifolds_[static_cast<std::size_t>(u)];
      const int size = parameter_block_sizes()[static_cast<std::size_t>(u)];
      Eigen::Map<RowMajor> J(jacobians[u], n + 1, size);
      J.bottomRows(1).setZero();
      if (m == nullptr) {
        J.topRows(n) = R.middleCols(tan_col_[u], size);
        continue;
      }
      RowMajor minus(m->TangentSize(), size);
      m->MinusJacobian(p[u], minus.data());
      J.topRows(n) = R.middleCols(tan_col_[u], m->TangentSize()) * minus;
    }
    return true;
  }

  // The block's block of sample block b for a sample on segment offset `off`.
  int UnionBlock(int b, int off) const {
    const int knots = N + num_segments_ - 1;
    return b < kNumTrajBlocks ? (b / N) * knots + off + b % N
                              : kGroups * knots + (b - kNumTrajBlocks);
  }

  // The stacked form (file comment): every sample writes its residual and ambient Jacobian rows
  // straight into the block's (a sample's rows of block u are contiguous in the row-major
  // Jacobian, whose width is that block's size); the knots a sample does not touch stay zero.
  bool EvaluateStacked(double const* const* p, double* residuals, double** jacobians) const {
    const int num_sample_blocks = static_cast<int>(sample_sizes_.size());
    if (jacobians != nullptr && num_segments_ > 1) {
      for (std::size_t u = 0; u < block_col_.size(); ++u) {
        if (jacobians[u] != nullptr)
          std::fill_n(jacobians[u],
                      static_cast<std::size_t>(num_residuals()) *
                          static_cast<std::size_t>(parameter_block_sizes()[u]),
                      0.0);
      }
    }
    std::vector<const double*> ps(static_cast<std::size_t>(num_sample_blocks));
    std::vector<double*> js(static_cast<std::size_t>(num_sample_blocks));
    std::optional<Functor> placed;
    for (std::size_t i = 0; i < offsets_.size(); ++i) {
      const int off = offsets_[i];
      const std::ptrdiff_t row = kSampleRows * static_cast<std::ptrdiff_t>(i);
      for (int b = 0; b < num_sample_blocks; ++b) {
        const int u = UnionBlock(b, off);
        ps[static_cast<std::size_t>(b)] = p[u];
        js[static_cast<std::size_t>(b)] = jacobians != nullptr && jacobians[u] != nullptr
                                              ? jacobians[u] + row * sample_sizes_[b]
                                              : nullptr;
      }
      if (!Sample::Analytic::EvaluateSample(SampleAt(i, &placed), ps.data(), residuals + row,
                                            jacobians != nullptr ? js.data() : nullptr))
        return false;
    }
    return true;
  }

  std::vector<Functor> samples_;   // owned samples, or
  std::optional<Functor> sensor_;  // the sensor's functor and
  HeldInertialSamples<Raw> held_;  // the samples the caller holds
  std::vector<std::uint8_t> offsets_;
  int num_segments_;
  std::vector<int> sample_sizes_;
  std::vector<int> block_col_;  // the block's block u starts at column block_col_[u]
  std::vector<int> tan_col_;    // and at tangent column tan_col_[u]
  std::vector<const ceres::Manifold*> manifolds_;  // nullptr: Euclidean (file comment)
  int num_cols_ = 0;
  int num_factor_rows_ = 0;
  double huber_;
  bool stacked_;
};

}  // namespace ctcal
