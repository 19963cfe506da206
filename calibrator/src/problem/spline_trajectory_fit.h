// The initial fit of the trajectory spline T_W_B(t) (and of gravity) to the base poses from the
// camera views and to the base IMU's samples, by Gauss-Newton on normal equations the fit
// assembles itself: no Ceres residual block per sample, so memory is O(knots) (a band of 6x6
// blocks) however long the recording (docs/performance.md, step 5). Private to the calibrator.
//
// Unknowns: the knots' tangent perturbations (6 per knot, the spline's own right manifolds) and
// gravity g_W (3, free; the calibration puts it on its sphere afterwards). Whitened residuals,
// each a model of the calibrator's own residual with the sensor's intrinsics and biases fixed at
// their guesses:
//   pose (camera view mapped to B):  Log(R_meas^T R_W_B(t)) / sigma_R,  (p_W_B(t) - p_meas) /
//   sigma_p; base gyroscope:                  (w_B(t) - w_I) / sigma_w; base accelerometer:
//   (R_W_B(t)^T (a_W(t) - g_W) - a_I) / sigma_a,
// with w_I, a_I the sample corrected by the guessed intrinsics and seeded biases (the base IMU
// defines B, so w_B = w_I and the specific force f_B = a_I). Jacobians: the spline's analytic
// tangent Jacobians J_R, J_p, J_w, J_f (se3_spline.h); the rotation error's J_r^-1(e) J_R; the
// specific force's -R_W_B^T with respect to g_W.
//
// Structure: a residual of segment s touches knots s .. s+N-1, so H is block-banded (N 6x6 blocks
// per block row) plus 3 gravity columns; it is assembled band-wise and factored block-band-wise
// (SolveStep: no fill beyond the band and the border). Each step is damped
// Levenberg-Marquardt style (lambda scales diag(H), grows on a rejected step), which also keeps
// knots without data determined.
//
// Threads: Assemble, ~90 % of the fit on the demo rig (~60 % on EuRoC, whose 7 ms knots carry
// fewer samples each: the sequential SolveStep is ~20 % there), runs on `threads` threads, one
// chunk of consecutive segments each (Chunk). A chunk accumulates in place the block rows only its
// residuals reach and aside the N - 1 rows after them, which the next chunk's reach too; those
// rows, gravity's block and the cost are then summed in chunk order. The partition depends only on
// the samples' times and the thread count, so a run gives the same bits for the same data and
// threads (docs/calibrator.md, "Reproducibility"); one thread sums exactly as the serial loop did.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "ctcal/calibrator/residuals/residual_support.h"
#include "ctcal/calibrator/spline_init.h"
#include "ctcal/sensors/parallel_for.h"
#include "ctcal/spline/se3_spline.h"
#include "ctcal/spline/so3.h"
#include "ctcal/spline/so3_manifold.h"

namespace ctcal {
namespace spline_internal {

// One base-IMU sample corrected by the guessed intrinsics and biases (base clock = its clock).
struct BaseRateSample {
  std::int64_t t_ns = 0;
  Eigen::Vector3d w_I = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_I = Eigen::Vector3d::Zero();
};

struct TrajectoryFitOptions {
  double sigma_rotation = 0.01;  // rad: camera-view orientation (extrinsic and offset guesses)
  double sigma_position = 0.01;  // m
  double sigma_gyro = 0.05;      // rad/s: guessed gyro intrinsics and bias
  double sigma_accel = 0.2;      // m/s^2: guessed accelerometer intrinsics and bias
  bool use_accel = true;         // false: gravity is not estimated (no accelerometer residuals)
  int max_iterations = 20;
  // Stop once a step lowers the cost by less than this share of it. The fit only seeds the
  // robust solve, whose first step lowers the calibration's cost by orders of magnitude (EuRoC's
  // 36 s: 1.5e5 -> 2.5e4). On the cross-validation's subsets (every other 4 s block of camera
  // views left out, the IMU alone across the gaps) it converges linearly, ~0.6 a step, and spent
  // its last 8 of 20 steps (its limit) on 0.1 % of its cost under the 1e-6 it had.
  double relative_tolerance = 1e-3;
  int threads = 1;  // Assemble's; <= 1: serially
};

struct TrajectoryFitReport {
  int iterations = 0;
  double initial_cost = 0.0;  // 1/2 sum of squared whitened residuals
  double final_cost = 0.0;
};

template <int N, Se3Representation Rep>
class TrajectoryFit {
 public:
  using Spline = Se3Spline<N, Rep>;
  static constexpr int kGravity = 3;

  TrajectoryFit(const std::vector<TimedPose>& poses, const std::vector<BaseRateSample>& imu,
                const TrajectoryFitOptions& options)
      : poses_(poses), imu_(imu), o_(options) {}

  // The start: every knot at the pose nearest to its centre time (poses sorted by time).
  static void SeedKnots(const std::vector<TimedPose>& poses, Spline* spline) {
    std::size_t j = 0;
    for (int k = 0; k < spline->NumKnots() && !poses.empty(); ++k) {
      const std::int64_t tc = spline->KnotCentreTimeNs(k);
      while (j + 1 < poses.size() &&
             std::llabs(poses[j + 1].t_ns - tc) <= std::llabs(poses[j].t_ns - tc))
        ++j;
      spline->KnotRotation(k) = poses[j].q_W_B.normalized();
      spline->KnotPosition(k) = poses[j].p_W_B;
    }
  }

  // Refines `spline` (its knots are the start) and `g_W` in place.
  TrajectoryFitReport Run(Spline* spline, Eigen::Vector3d* g_W) {
    spline_ = spline;
    g_ = *g_W;
    K_ = spline->NumKnots();
    n_ = 6 * K_ + (o_.use_accel ? kGravity : 0);
    band_.resize(static_cast<std::size_t>(N * K_));  // zeroed by the chunks (Assemble)
    border_.resize(6 * K_, 3);
    b_.resize(n_);
    Partition();
    TrajectoryFitReport report;
    double cost = Assemble(true);
    report.initial_cost = cost;
    double lambda = 1e-6;
    std::vector<double> saved(static_cast<std::size_t>(7 * K_));
    for (int it = 0; it < o_.max_iterations; ++it) {
      Eigen::VectorXd dx;
      if (!SolveStep(lambda, &dx))
        break;
      std::copy(spline->KnotData(0), spline->KnotData(0) + 7 * K_, saved.begin());
      const Eigen::Vector3d g_saved = g_;
      ApplyStep(dx);
      // The candidate's cost with its H and b, the next step's when it is taken (nearly every step
      // is): one pass per accepted step instead of a cost-only pass and then this one. A rejected
      // candidate's H and b are assembled again at the point kept.
      const double new_cost = Assemble(true);
      if (!(new_cost < cost)) {  // rejected (also NaN): undo, damp more
        std::copy(saved.begin(), saved.end(), spline->KnotData(0));
        g_ = g_saved;
        lambda *= 10.0;
        if (lambda > 1e6)
          break;
        Assemble(true);
        continue;
      }
      ++report.iterations;
      const double change = (cost - new_cost) / std::max(cost, 1e-300);
      cost = new_cost;
      lambda = std::max(lambda / 10.0, 1e-9);
      if (change < o_.relative_tolerance)
        break;
    }
    report.final_cost = cost;
    *g_W = g_;
    return report;
  }

 private:
  using Mat6 = Eigen::Matrix<double, 6, 6>;
  using Block = typename Spline::template Jacobians<double>::Block;

  // A run of consecutive segments and the samples in them. Its residuals reach block rows (knots)
  // row_begin .. (its last segment) + N - 1: those before row_end no other chunk reaches, so they
  // are accumulated in place in band_, border_ and b_; the N - 1 rows from row_end on, which the
  // next chunk's residuals reach too, go to the spill, added after every chunk has run, in chunk
  // order, like gravity's block and the cost. alignas: each chunk's accumulators on cache lines
  // of their own.
  struct alignas(64) Chunk {
    int row_begin = 0;                    // its first segment (= block row)
    int row_end = 0;                      // its segments' end (the last chunk: K)
    std::vector<std::size_t> poses, imu;  // its samples' indices, in input order
    std::vector<Mat6, Eigen::aligned_allocator<Mat6>> spill_band;  // N - 1 block rows of N blocks
    Eigen::Matrix<double, Eigen::Dynamic, 3> spill_border;
    Eigen::VectorXd spill_b;
    Eigen::Matrix3d Hgg = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b_g = Eigen::Vector3d::Zero();
    double cost = 0.0;
  };

  int SegmentOf(std::int64_t t_ns) const {
    const KnotTiming& tm = spline_->timing();
    const std::int64_t k = (t_ns - tm.t0_ns) / tm.dt_ns;
    return static_cast<int>(
        std::min<std::int64_t>(std::max<std::int64_t>(k, 0), spline_->NumSegments() - 1));
  }

  // Knot i's 6 tangent columns of a segment Jacobian (layout of se3_spline.h: split = rotations
  // of the N knots, then their positions; joint = 6 per knot).
  template <int Rows>
  static Eigen::Matrix<double, Rows, 6> KnotColumns(const Eigen::Matrix<double, Rows, 6 * N>& J,
                                                    int i) {
    Eigen::Matrix<double, Rows, 6> out;
    if constexpr (Rep == Se3Representation::kJoint) {
      out = J.template middleCols<6>(6 * i);
    } else {
      out.template leftCols<3>() = J.template middleCols<3>(3 * i);
      out.template rightCols<3>() = J.template middleCols<3>(3 * (N + i));
    }
    return out;
  }

  // Adds one whitened residual r (Rows) of segment `seg` with Jacobian J over the segment's knots
  // and J_g over gravity (nullptr: none) to chunk c's share of H and b; returns 1/2 |r|^2.
  template <int Rows>
  double Add(Chunk* c, int seg, const Eigen::Matrix<double, Rows, 1>& r,
             const Eigen::Matrix<double, Rows, 6 * N>& J, const Eigen::Matrix<double, Rows, 3>* J_g,
             bool jacobians) {
    if (jacobians) {
      std::array<Eigen::Matrix<double, Rows, 6>, N> Jk;
      for (int i = 0; i < N; ++i)
        Jk[static_cast<std::size_t>(i)] = KnotColumns<Rows>(J, i);
      for (int i = 0; i < N; ++i) {
        const auto& Ji = Jk[static_cast<std::size_t>(i)];
        const bool own = seg + i < c->row_end;
        const int row = own ? seg + i : seg + i - c->row_end;
        Mat6* band = own ? &Band(row, 0) : &c->spill_band[static_cast<std::size_t>(N * row)];
        Eigen::VectorXd& b = own ? b_ : c->spill_b;
        Eigen::Matrix<double, Eigen::Dynamic, 3>& border = own ? border_ : c->spill_border;
        b.template segment<6>(6 * row) -= Ji.transpose() * r;
        for (int j = i; j < N; ++j)
          band[j - i].noalias() += Ji.transpose() * Jk[static_cast<std::size_t>(j)];
        if (J_g != nullptr)
          border.template middleRows<6>(6 * row).noalias() += Ji.transpose() * *J_g;
      }
      if (J_g != nullptr) {
        c->Hgg.noalias() += J_g->transpose() * *J_g;
        c->b_g -= J_g->transpose() * r;
      }
    }
    return 0.5 * r.squaredNorm();
  }

  Mat6& Band(int k, int j) { return band_[static_cast<std::size_t>(N * k + j)]; }

  // Splits the segments into `threads` chunks of about equal numbers of samples (poses and IMU
  // samples counted alike: the two kinds mix about evenly along a recording) and lists each
  // chunk's samples; samples outside the spline's time span are left out. Once per Run: the
  // times do not change.
  void Partition() {
    const int num_segments = spline_->NumSegments();
    const auto in_span = [this](std::int64_t t_ns) {
      return t_ns >= spline_->MinTimeNs() && t_ns <= spline_->MaxTimeNs();
    };
    std::vector<int> chunk_of(static_cast<std::size_t>(num_segments), 0);  // samples, then chunk
    for (const TimedPose& pose : poses_)
      if (in_span(pose.t_ns))
        ++chunk_of[static_cast<std::size_t>(SegmentOf(pose.t_ns))];
    for (const BaseRateSample& z : imu_)
      if (in_span(z.t_ns))
        ++chunk_of[static_cast<std::size_t>(SegmentOf(z.t_ns))];
    std::int64_t total = 0;
    for (const int n : chunk_of)
      total += n;
    const int num_chunks = std::max(1, o_.threads);
    chunks_.assign(static_cast<std::size_t>(num_chunks), Chunk{});
    int seg = 0;
    std::int64_t taken = 0;
    for (int k = 0; k < num_chunks; ++k) {
      Chunk& c = chunks_[static_cast<std::size_t>(k)];
      c.row_begin = seg;
      // Segments while the samples taken stay within the first k + 1 of num_chunks parts.
      while (seg < num_segments &&
             (k + 1 == num_chunks ||
              (taken + chunk_of[static_cast<std::size_t>(seg)]) * num_chunks <= (k + 1) * total)) {
        taken += chunk_of[static_cast<std::size_t>(seg)];
        chunk_of[static_cast<std::size_t>(seg++)] = k;
      }
      c.row_end = k + 1 == num_chunks ? K_ : seg;
      c.spill_band.resize(static_cast<std::size_t>(N * (N - 1)));
      c.spill_border.resize(6 * (N - 1), 3);
      c.spill_b.resize(6 * (N - 1));
    }
    const auto chunk_at = [&](std::int64_t t_ns) -> Chunk& {
      return chunks_[static_cast<std::size_t>(chunk_of[static_cast<std::size_t>(SegmentOf(t_ns))])];
    };
    for (std::size_t i = 0; i < poses_.size(); ++i)
      if (in_span(poses_[i].t_ns))
        chunk_at(poses_[i].t_ns).poses.push_back(i);
    for (std::size_t i = 0; i < imu_.size(); ++i)
      if (in_span(imu_[i].t_ns))
        chunk_at(imu_[i].t_ns).imu.push_back(i);
  }

  // The cost at the current values; with `jacobians`, also H and b (-gradient).
  double Assemble(bool jacobians) {
    ParallelFor(o_.threads, chunks_.size(),
                [&](std::size_t k) { AssembleChunk(&chunks_[k], jacobians); });
    double cost = 0.0;
    if (jacobians) {
      Hgg_.setZero();
      if (o_.use_accel)
        b_.template tail<3>().setZero();
    }
    for (const Chunk& c : chunks_) {
      cost += c.cost;
      if (!jacobians)
        continue;
      for (int q = 0; q < N - 1 && c.row_end + q < K_; ++q) {
        const int row = c.row_end + q;
        for (int j = 0; j < N; ++j)
          Band(row, j) += c.spill_band[static_cast<std::size_t>(N * q + j)];
        border_.template middleRows<6>(6 * row) += c.spill_border.template middleRows<6>(6 * q);
        b_.template segment<6>(6 * row) += c.spill_b.template segment<6>(6 * q);
      }
      Hgg_ += c.Hgg;
      if (o_.use_accel)
        b_.template tail<3>() += c.b_g;
    }
    return cost;
  }

  // Chunk c's cost, with `jacobians` also its share of H and b (Chunk); runs beside the others.
  void AssembleChunk(Chunk* c, bool jacobians) {
    if (jacobians) {
      const int rows = c->row_end - c->row_begin;
      std::fill(band_.begin() + N * c->row_begin, band_.begin() + N * c->row_end, Mat6::Zero());
      border_.middleRows(6 * c->row_begin, 6 * rows).setZero();
      b_.segment(6 * c->row_begin, 6 * rows).setZero();
      std::fill(c->spill_band.begin(), c->spill_band.end(), Mat6::Zero());
      c->spill_border.setZero();
      c->spill_b.setZero();
      c->Hgg.setZero();
      c->b_g.setZero();
    }
    double cost = 0.0;
    const double wR = 1.0 / o_.sigma_rotation, wp = 1.0 / o_.sigma_position;
    for (const std::size_t i : c->poses) {
      const TimedPose& pose = poses_[i];
      Se3Kinematics<double> kin;
      Block J_R, J_p;
      typename Spline::template Jacobians<double> Jk;
      Jk.J_R_knots = &J_R;
      Jk.J_p_knots = &J_p;
      const int seg = SegmentOf(pose.t_ns);
      Evaluate(seg, pose.t_ns, 0, nullptr, &kin, jacobians ? &Jk : nullptr);
      const Eigen::Vector3d e = LogSO3<double>(
          Eigen::Quaterniond(pose.q_W_B.conjugate() * Eigen::Quaterniond(kin.R_W_B)));
      Eigen::Matrix<double, 6, 1> r;
      r << wR * e, wp * (kin.p_W_B - pose.p_W_B);
      Eigen::Matrix<double, 6, 6 * N> J;
      if (jacobians) {
        J.template topRows<3>() = wR * RightJacobianInvSO3<double>(e) * J_R;
        J.template bottomRows<3>() = wp * J_p;
      }
      cost += Add<6>(c, seg, r, J, nullptr, jacobians);
    }
    const double ww = 1.0 / o_.sigma_gyro, wa = 1.0 / o_.sigma_accel;
    for (const std::size_t i : c->imu) {
      const BaseRateSample& z = imu_[i];
      Se3Kinematics<double> kin;
      Block J_w, J_f;
      typename Spline::template Jacobians<double> Jk;
      Jk.J_w_knots = &J_w;
      if (o_.use_accel)
        Jk.J_f_knots = &J_f;
      const int seg = SegmentOf(z.t_ns);
      Evaluate(seg, z.t_ns, o_.use_accel ? 2 : 1, &g_, &kin, jacobians ? &Jk : nullptr);
      if (!o_.use_accel) {
        const Eigen::Vector3d r = ww * (kin.w_B - z.w_I);
        cost += Add<3>(c, seg, r, Eigen::Matrix<double, 3, 6 * N>(ww * J_w), nullptr, jacobians);
        continue;
      }
      Eigen::Matrix<double, 6, 1> r;
      r << ww * (kin.w_B - z.w_I), wa * (kin.SpecificForce(g_) - z.a_I);
      Eigen::Matrix<double, 6, 6 * N> J;
      Eigen::Matrix<double, 6, 3> J_g = Eigen::Matrix<double, 6, 3>::Zero();
      if (jacobians) {
        J.template topRows<3>() = ww * J_w;
        J.template bottomRows<3>() = wa * J_f;
        J_g.template bottomRows<3>() = -wa * kin.R_W_B.transpose();
      }
      cost += Add<6>(c, seg, r, J, &J_g, jacobians);
    }
    c->cost = cost;
  }

  void Evaluate(int seg, std::int64_t t_ns, int derivatives, const Eigen::Vector3d* g_W,
                Se3Kinematics<double>* kin,
                const typename Spline::template Jacobians<double>* J) const {
    const SegmentClock clock = SegmentClock::At(t_ns, spline_->timing(), seg);
    Spline::template EvaluateSegment<double>(spline_->SegmentBlocks(seg).data(), clock.U(),
                                             clock.inv_dt, derivatives, g_W, kin, J);
  }

  // Solves (H + lambda diag(H) + eps I) dx = b by a block Cholesky factorisation H = R^T R, R
  // upper block-banded like H's upper half (block row k: R_kk = L_k^T with L_k the Cholesky factor
  // of the updated diagonal block, R_k,k+j = L_k^-1 H'_k,k+j for j < N) plus the gravity border's
  // 3 dense columns: no fill beyond the band. Forward substitution R^T y = b rides along with the
  // factorisation, then R dx = y backwards. O(K N^2 6^3) with fixed-size blocks: the general
  // sparse LDL^T it replaces, fed ~36 N triplets per knot every step, took ~0.45 s of the fit on
  // EuRoC's 36 s (5115 knots).
  bool SolveStep(double lambda, Eigen::VectorXd* dx) {
    using Vec6 = Eigen::Matrix<double, 6, 1>;
    using Mat63 = Eigen::Matrix<double, 6, 3>;
    double max_diag = 0.0;
    for (int k = 0; k < K_; ++k)
      max_diag = std::max(max_diag, Band(k, 0).diagonal().maxCoeff());
    const double eps = 1e-12 * std::max(max_diag, 1.0);
    std::vector<Mat6, Eigen::aligned_allocator<Mat6>> R = band_;
    for (int k = 0; k < K_; ++k) {
      Mat6& D = R[static_cast<std::size_t>(N * k)];
      D.diagonal() = D.diagonal() * (1.0 + lambda) + Vec6::Constant(eps);
    }
    const bool g = o_.use_accel;
    Eigen::Matrix<double, Eigen::Dynamic, 3> Rg;
    Eigen::Matrix3d Hg = Hgg_;
    if (g) {
      Rg = border_;
      Hg.diagonal() = Hg.diagonal() * (1.0 + lambda) + Eigen::Vector3d::Constant(eps);
    }
    Eigen::VectorXd y = b_;
    const auto at = [&R](int k, int j) -> Mat6& { return R[static_cast<std::size_t>(N * k + j)]; };
    std::vector<Eigen::LLT<Mat6>> L(static_cast<std::size_t>(K_));
    for (int k = 0; k < K_; ++k) {
      Eigen::LLT<Mat6>& Lk = L[static_cast<std::size_t>(k)];
      Lk.compute(at(k, 0));
      if (Lk.info() != Eigen::Success)
        return false;
      const auto Lkk = Lk.matrixL();
      for (int j = 1; j < N && k + j < K_; ++j)
        Lkk.solveInPlace(at(k, j));
      if (g) {
        Mat63 rg = Rg.template middleRows<6>(6 * k);
        Lkk.solveInPlace(rg);
        Rg.template middleRows<6>(6 * k) = rg;
      }
      Vec6 yk = y.template segment<6>(6 * k);
      Lkk.solveInPlace(yk);
      y.template segment<6>(6 * k) = yk;
      for (int i = 1; i < N && k + i < K_; ++i) {
        const Mat6& Rki = at(k, i);
        for (int j = i; j < N && k + j < K_; ++j)
          at(k + i, j - i).noalias() -= Rki.transpose() * at(k, j);
        if (g)
          Rg.template middleRows<6>(6 * (k + i)).noalias() -=
              Rki.transpose() * Rg.template middleRows<6>(6 * k);
        y.template segment<6>(6 * (k + i)).noalias() -= Rki.transpose() * yk;
      }
      if (g) {
        Hg.noalias() -=
            Rg.template middleRows<6>(6 * k).transpose() * Rg.template middleRows<6>(6 * k);
        y.template tail<3>().noalias() -= Rg.template middleRows<6>(6 * k).transpose() * yk;
      }
    }
    dx->resize(n_);
    Eigen::Vector3d x_g = Eigen::Vector3d::Zero();
    if (g) {
      const Eigen::LLT<Eigen::Matrix3d> Lg(Hg);
      if (Lg.info() != Eigen::Success)
        return false;
      // R_gg = L_g^T: the forward step's L_g^-1 and the backward step's L_g^-T at once.
      x_g = Lg.solve(y.template tail<3>());
      dx->template tail<3>() = x_g;
    }
    for (int k = K_ - 1; k >= 0; --k) {
      Vec6 r = y.template segment<6>(6 * k);
      for (int j = 1; j < N && k + j < K_; ++j)
        r.noalias() -= at(k, j) * dx->template segment<6>(6 * (k + j));
      if (g)
        r.noalias() -= Rg.template middleRows<6>(6 * k) * x_g;
      L[static_cast<std::size_t>(k)].matrixU().solveInPlace(r);
      dx->template segment<6>(6 * k) = r;
    }
    return dx->allFinite();
  }

  void ApplyStep(const Eigen::VectorXd& dx) {
    for (int k = 0; k < K_; ++k) {
      double* x = spline_->KnotData(k);
      const double* d = dx.data() + 6 * k;
      double out[7];
      if constexpr (Rep == Se3Representation::kJoint) {
        se3_.Plus(x, d, out);
        std::copy(out, out + 7, x);
      } else {
        so3_.Plus(x, d, out);
        std::copy(out, out + 4, x);
        for (int i = 0; i < 3; ++i)
          x[4 + i] += d[3 + i];
      }
    }
    if (o_.use_accel)
      g_ += dx.template tail<3>();
  }

  const std::vector<TimedPose>& poses_;
  const std::vector<BaseRateSample>& imu_;
  TrajectoryFitOptions o_;
  Spline* spline_ = nullptr;
  Eigen::Vector3d g_ = Eigen::Vector3d::Zero();
  int K_ = 0;
  int n_ = 0;
  std::vector<Chunk> chunks_;
  std::vector<Mat6, Eigen::aligned_allocator<Mat6>> band_;
  Eigen::Matrix<double, Eigen::Dynamic, 3> border_;
  Eigen::Matrix3d Hgg_ = Eigen::Matrix3d::Zero();
  Eigen::VectorXd b_;
  So3RightManifold so3_;
  Se3RightManifold se3_;
};

}  // namespace spline_internal
}  // namespace ctcal
