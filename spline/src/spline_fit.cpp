#include "ctcal/spline/spline_fit.h"

#include <ceres/autodiff_cost_function.h>
#include <ceres/cost_function.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include <algorithm>
#include <memory>
#include <stdexcept>
#include <string>

#include "ctcal/spline/so3_manifold.h"

namespace ctcal {
namespace {

using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

template <typename Sample>
void CheckSamples(const std::vector<Sample>& samples, const SplineFitOptions& options,
                  const char* what) {
  if (samples.size() < 2) {
    throw std::invalid_argument(std::string(what) + ": need at least two samples, got " +
                                std::to_string(samples.size()));
  }
  if (options.dt_ns <= 0) {
    throw std::invalid_argument(std::string(what) + ": knot spacing dt_ns must be positive, got " +
                                std::to_string(options.dt_ns));
  }
  for (std::size_t i = 1; i < samples.size(); ++i) {
    if (samples[i].t_ns <= samples[i - 1].t_ns) {
      throw std::invalid_argument(std::string(what) +
                                  ": sample times must increase strictly; sample " +
                                  std::to_string(i) + " at " + std::to_string(samples[i].t_ns) +
                                  " ns follows " + std::to_string(samples[i - 1].t_ns) + " ns");
    }
  }
}

// Knots so that segment 0 starts at the first sample and the last segment covers the last one.
template <int N>
int NumKnotsCovering(std::int64_t t_first, std::int64_t t_last, std::int64_t dt_ns) {
  const std::int64_t segments = std::max<std::int64_t>(1, (t_last - t_first + dt_ns - 1) / dt_ns);
  return static_cast<int>(segments) + N - 1;
}

// Slerp / lerp between the samples around t, clamped to the first / last sample.
PoseSample InterpolatePose(const std::vector<PoseSample>& samples, std::int64_t t_ns) {
  if (t_ns <= samples.front().t_ns)
    return samples.front();
  if (t_ns >= samples.back().t_ns)
    return samples.back();
  const auto next =
      std::upper_bound(samples.begin(), samples.end(), t_ns,
                       [](std::int64_t t, const PoseSample& s) { return t < s.t_ns; });
  const PoseSample& b = *next;
  const PoseSample& a = *(next - 1);
  const double s = static_cast<double>(t_ns - a.t_ns) / static_cast<double>(b.t_ns - a.t_ns);
  PoseSample out;
  out.t_ns = t_ns;
  out.q_W_B = a.q_W_B.slerp(s, b.q_W_B);
  out.p_W_B = (1.0 - s) * a.p_W_B + s * b.p_W_B;
  return out;
}

// Ceres wants Jacobians with respect to the ambient parameters: lift the tangent columns of every
// block through its manifold (so3_manifold.h).
template <int Rows, typename Spline>
void LiftBlocks(const Eigen::Matrix<double, Rows, 6 * Spline::kOrder>& J_tangent,
                const ceres::Manifold* const* manifolds, double const* const* parameters,
                double** jacobians) {
  for (int b = 0; b < Spline::kNumBlocks; ++b) {
    if (jacobians[b] == nullptr)
      continue;
    LiftToAmbient(manifolds[b], parameters[b],
                  J_tangent.middleCols(Spline::TangentOffset(b), Spline::TangentSize(b)),
                  jacobians[b]);
  }
}

// Measured pose at a fixed time on a fixed segment:
//   r = [Log(R_meas^T R_W_B(t)) / sigma_R;  (p_W_B(t) - p_meas) / sigma_p],
//   dr_R = Jr^-1(r_R) dtheta  for R_W_B = R_hat Exp(dtheta).
template <int N, Se3Representation Rep>
class PoseResidual final : public ceres::CostFunction {
  using Spline = Se3Spline<N, Rep>;

 public:
  PoseResidual(const PoseSample& sample, const SegmentLocation<double>& loc,
               const SplineFitOptions& options, const ceres::Manifold* const* manifolds)
      : sample_(sample), loc_(loc), manifolds_(manifolds) {
    inv_sigma_rotation_ = 1.0 / options.rotation_sigma;
    inv_sigma_position_ = 1.0 / options.position_sigma;
    set_num_residuals(6);
    for (int b = 0; b < Spline::kNumBlocks; ++b) {
      mutable_parameter_block_sizes()->push_back(Spline::AmbientSize(b));
    }
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    using Block = typename Se3Jacobians<double, N>::Block;
    Block J_R, J_p;
    Se3Jacobians<double, N> J;
    J.J_R_knots = &J_R;
    J.J_p_knots = &J_p;
    Se3Kinematics<double> kin;
    Spline::template EvaluateSegment<double>(parameters, loc_.u, loc_.inv_dt, 0, nullptr, &kin,
                                             jacobians != nullptr ? &J : nullptr);
    const Eigen::Vector3d r_R = LogSO3<double>(sample_.q_W_B.conjugate() * kin.q_W_B());
    Eigen::Map<Vec6T<double>> r(residuals);
    r.head<3>() = inv_sigma_rotation_ * r_R;
    r.tail<3>() = inv_sigma_position_ * (kin.p_W_B - sample_.p_W_B);
    if (jacobians == nullptr)
      return true;
    Eigen::Matrix<double, 6, 6 * N> J_r;
    J_r.template topRows<3>() = inv_sigma_rotation_ * RightJacobianInvSO3<double>(r_R) * J_R;
    J_r.template bottomRows<3>() = inv_sigma_position_ * J_p;
    LiftBlocks<6, Spline>(J_r, manifolds_, parameters, jacobians);
    return true;
  }

 private:
  PoseSample sample_;
  SegmentLocation<double> loc_;
  const ceres::Manifold* const* manifolds_;
  double inv_sigma_rotation_;
  double inv_sigma_position_;
};

// Gyro reading on a fixed segment: r = (w_B(t) - w_meas) / sigma_w.
template <int N>
class AngularVelocityResidual final : public ceres::CostFunction {
  using Segment = CumulativeLieSegment<So3Group, N>;

 public:
  AngularVelocityResidual(const Eigen::Vector3d& w_B, const SegmentLocation<double>& loc,
                          double sigma)
      : w_B_(w_B), loc_(loc), inv_sigma_(1.0 / sigma) {
    set_num_residuals(3);
    for (int b = 0; b < N; ++b)
      mutable_parameter_block_sizes()->push_back(4);
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    typename Segment::template KnotJacobians<double> J_w;
    typename Segment::template Jacobians<double> J;
    J.J_velocity_knots = &J_w;
    typename Segment::template Output<double> out;
    Segment::Evaluate(parameters, loc_.u, loc_.inv_dt, 1, false, &out,
                      jacobians != nullptr ? &J : nullptr);
    Eigen::Map<Eigen::Vector3d> r(residuals);
    r = inv_sigma_ * (out.velocity - w_B_);
    if (jacobians == nullptr)
      return true;
    for (int b = 0; b < N; ++b) {
      if (jacobians[b] == nullptr)
        continue;
      Eigen::Map<Eigen::Matrix<double, 3, 4, Eigen::RowMajor>> J_b(jacobians[b]);
      J_b = inv_sigma_ * J_w[b] * So3RightManifold::MinusJacobianAt(parameters[b]);
    }
    return true;
  }

 private:
  Eigen::Vector3d w_B_;
  SegmentLocation<double> loc_;
  double inv_sigma_;
};

// Known orientation on a fixed segment: r = Log(R_meas^T R_W_B(t)) / sigma.
template <int N>
class OrientationResidual final : public ceres::CostFunction {
  using Segment = CumulativeLieSegment<So3Group, N>;

 public:
  OrientationResidual(const Eigen::Quaterniond& q_W_B, const SegmentLocation<double>& loc,
                      double sigma)
      : q_W_B_(q_W_B), loc_(loc), inv_sigma_(1.0 / sigma) {
    set_num_residuals(3);
    for (int b = 0; b < N; ++b)
      mutable_parameter_block_sizes()->push_back(4);
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    typename Segment::template KnotJacobians<double> J_R;
    typename Segment::template Jacobians<double> J;
    J.J_value_knots = &J_R;
    typename Segment::template Output<double> out;
    Segment::Evaluate(parameters, loc_.u, loc_.inv_dt, 0, true, &out,
                      jacobians != nullptr ? &J : nullptr);
    const Eigen::Vector3d r_R = LogSO3<double>(q_W_B_.conjugate() * Eigen::Quaterniond(out.value));
    Eigen::Map<Eigen::Vector3d> r(residuals);
    r = inv_sigma_ * r_R;
    if (jacobians == nullptr)
      return true;
    const Eigen::Matrix3d Jr_inv = inv_sigma_ * RightJacobianInvSO3<double>(r_R);
    for (int b = 0; b < N; ++b) {
      if (jacobians[b] == nullptr)
        continue;
      Eigen::Map<Eigen::Matrix<double, 3, 4, Eigen::RowMajor>> J_b(jacobians[b]);
      J_b = Jr_inv * J_R[b] * So3RightManifold::MinusJacobianAt(parameters[b]);
    }
    return true;
  }

 private:
  Eigen::Quaterniond q_W_B_;
  SegmentLocation<double> loc_;
  double inv_sigma_;
};

// Smoothness prior on three consecutive knots of a Lie group: the second difference of the knot
// sequence in the tangent space, whitened per tangent coordinate.
template <template <typename> class Group>
struct LieSecondDifference {
  static constexpr int kDof = Group<double>::kDof;
  Eigen::Matrix<double, kDof, 1> inv_sigma;

  template <typename T>
  bool operator()(const T* a, const T* b, const T* c, T* residuals) const {
    const auto d = (Group<T>::LogBetween(b, c) - Group<T>::LogBetween(a, b)).eval();
    for (int i = 0; i < kDof; ++i)
      residuals[i] = d[i] * T(inv_sigma[i]);
    return true;
  }
};

struct EuclideanSecondDifference {
  double inv_sigma;

  template <typename T>
  bool operator()(const T* a, const T* b, const T* c, T* residuals) const {
    for (int i = 0; i < 3; ++i)
      residuals[i] = (a[i] - T(2) * b[i] + c[i]) * T(inv_sigma);
    return true;
  }
};

void Solve(ceres::Problem* problem, int num_knots, const SplineFitOptions& options,
           SplineFitReport* report) {
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.num_threads = options.num_threads;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, problem, &summary);
  if (report != nullptr) {
    report->num_knots = num_knots;
    report->iterations = static_cast<int>(summary.iterations.size());
    report->initial_cost = summary.initial_cost;
    report->final_cost = summary.final_cost;
    report->converged = summary.termination_type == ceres::CONVERGENCE;
  }
}

}  // namespace

template <int N, Se3Representation Rep>
Se3Spline<N, Rep> FitSe3Spline(const std::vector<PoseSample>& samples,
                               const SplineFitOptions& options, SplineFitReport* report) {
  using Spline = Se3Spline<N, Rep>;
  CheckSamples(samples, options, "FitSe3Spline");
  const std::int64_t t_first = samples.front().t_ns;
  Spline spline(KnotTiming{t_first, options.dt_ns},
                NumKnotsCovering<N>(t_first, samples.back().t_ns, options.dt_ns));
  for (int k = 0; k < spline.NumKnots(); ++k) {
    const PoseSample guess = InterpolatePose(samples, spline.KnotCentreTimeNs(k));
    spline.KnotRotation(k) = guess.q_W_B.normalized();
    spline.KnotPosition(k) = guess.p_W_B;
  }

  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  So3RightManifold so3_right;
  Se3RightManifold se3_right;
  constexpr bool kJoint = Rep == Se3Representation::kJoint;
  // Manifold of every parameter block of a segment (nullptr: Euclidean).
  std::array<const ceres::Manifold*, Spline::kNumBlocks> manifolds;
  for (int b = 0; b < Spline::kNumBlocks; ++b) {
    manifolds[b] =
        kJoint ? static_cast<const ceres::Manifold*>(&se3_right) : (b < N ? &so3_right : nullptr);
  }
  for (int k = 0; k < spline.NumKnots(); ++k) {
    if (kJoint) {
      problem.AddParameterBlock(spline.KnotData(k), 7, &se3_right);
    } else {
      problem.AddParameterBlock(spline.KnotData(k), 4, &so3_right);
      problem.AddParameterBlock(spline.KnotData(k) + 4, 3);
    }
  }
  for (const PoseSample& s : samples) {
    const SegmentLocation<double> loc = spline.ComputeIndexOrThrow(s.t_ns);
    const auto blocks = spline.SegmentBlocks(loc.first_index);
    problem.AddResidualBlock(new PoseResidual<N, Rep>(s, loc, options, manifolds.data()), nullptr,
                             std::vector<double*>(blocks.begin(), blocks.end()));
  }
  const double dt2 = spline.timing().dt_s() * spline.timing().dt_s();
  for (int k = 1; k + 1 < spline.NumKnots(); ++k) {
    double* a = spline.KnotData(k - 1);
    double* b = spline.KnotData(k);
    double* c = spline.KnotData(k + 1);
    if (kJoint) {
      auto* f = new LieSecondDifference<Se3Group>;
      f->inv_sigma << Eigen::Vector3d::Constant(1.0 / (dt2 * options.linear_acceleration_sigma)),
          Eigen::Vector3d::Constant(1.0 / (dt2 * options.angular_acceleration_sigma));
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<LieSecondDifference<Se3Group>, 6, 7, 7, 7>(f), nullptr, a,
          b, c);
    } else {
      auto* f = new LieSecondDifference<So3Group>;
      f->inv_sigma.setConstant(1.0 / (dt2 * options.angular_acceleration_sigma));
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<LieSecondDifference<So3Group>, 3, 4, 4, 4>(f), nullptr, a,
          b, c);
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<EuclideanSecondDifference, 3, 3, 3, 3>(
              new EuclideanSecondDifference{1.0 / (dt2 * options.linear_acceleration_sigma)}),
          nullptr, a + 4, b + 4, c + 4);
    }
  }
  Solve(&problem, spline.NumKnots(), options, report);
  return spline;
}

template <int N>
So3Spline<N> FitSo3SplineToAngularVelocity(const std::vector<AngularVelocitySample>& samples,
                                           const Eigen::Quaterniond& q_W_B_first,
                                           const SplineFitOptions& options,
                                           SplineFitReport* report) {
  CheckSamples(samples, options, "FitSo3SplineToAngularVelocity");
  // Initial guess: integrate the readings (trapezoidal rate, right-multiplied body increments).
  std::vector<PoseSample> integrated(samples.size());
  integrated[0].t_ns = samples[0].t_ns;
  integrated[0].q_W_B = q_W_B_first.normalized();
  for (std::size_t i = 1; i < samples.size(); ++i) {
    const double dt = 1e-9 * static_cast<double>(samples[i].t_ns - samples[i - 1].t_ns);
    const Eigen::Vector3d w_mid = 0.5 * (samples[i].w_B + samples[i - 1].w_B);
    integrated[i].t_ns = samples[i].t_ns;
    integrated[i].q_W_B =
        (integrated[i - 1].q_W_B * ExpSO3<double>(Eigen::Vector3d(w_mid * dt))).normalized();
  }
  const std::int64_t t_first = samples.front().t_ns;
  So3Spline<N> spline(KnotTiming{t_first, options.dt_ns},
                      NumKnotsCovering<N>(t_first, samples.back().t_ns, options.dt_ns));
  for (int k = 0; k < spline.NumKnots(); ++k) {
    spline.Knot(k) = InterpolatePose(integrated, spline.KnotCentreTimeNs(k)).q_W_B.normalized();
  }

  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  So3RightManifold so3_right;
  for (int k = 0; k < spline.NumKnots(); ++k) {
    problem.AddParameterBlock(spline.KnotData(k), 4, &so3_right);
  }
  const auto segment_blocks = [&spline](int first) {
    std::vector<double*> blocks(N);
    for (int i = 0; i < N; ++i)
      blocks[i] = spline.KnotData(first + i);
    return blocks;
  };
  for (const AngularVelocitySample& s : samples) {
    const SegmentLocation<double> loc = spline.ComputeIndexOrThrow(s.t_ns);
    problem.AddResidualBlock(
        new AngularVelocityResidual<N>(s.w_B, loc, options.angular_velocity_sigma), nullptr,
        segment_blocks(loc.first_index));
  }
  const SegmentLocation<double> first = spline.ComputeIndexOrThrow(t_first);
  problem.AddResidualBlock(
      new OrientationResidual<N>(q_W_B_first, first, options.initial_rotation_sigma), nullptr,
      segment_blocks(first.first_index));
  const double dt2 = spline.timing().dt_s() * spline.timing().dt_s();
  for (int k = 1; k + 1 < spline.NumKnots(); ++k) {
    auto* f = new LieSecondDifference<So3Group>;
    f->inv_sigma.setConstant(1.0 / (dt2 * options.angular_acceleration_sigma));
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<LieSecondDifference<So3Group>, 3, 4, 4, 4>(f), nullptr,
        spline.KnotData(k - 1), spline.KnotData(k), spline.KnotData(k + 1));
  }
  Solve(&problem, spline.NumKnots(), options, report);
  return spline;
}

#define CTCAL_INSTANTIATE_SPLINE_FIT(N)                                                        \
  template Se3Spline<N, Se3Representation::kSplit> FitSe3Spline<N, Se3Representation::kSplit>( \
      const std::vector<PoseSample>&, const SplineFitOptions&, SplineFitReport*);              \
  template Se3Spline<N, Se3Representation::kJoint> FitSe3Spline<N, Se3Representation::kJoint>( \
      const std::vector<PoseSample>&, const SplineFitOptions&, SplineFitReport*);              \
  template So3Spline<N> FitSo3SplineToAngularVelocity<N>(                                      \
      const std::vector<AngularVelocitySample>&, const Eigen::Quaterniond&,                    \
      const SplineFitOptions&, SplineFitReport*);
CTCAL_INSTANTIATE_SPLINE_FIT(4)
CTCAL_INSTANTIATE_SPLINE_FIT(5)
CTCAL_INSTANTIATE_SPLINE_FIT(6)
#undef CTCAL_INSTANTIATE_SPLINE_FIT

}  // namespace ctcal
