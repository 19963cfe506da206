// SolveLevenbergMarquardt against ceres::Solve on a small problem with the spline problem's
// ingredients: quaternion manifolds, a band of nuisance blocks (a chain of poses) with a border
// of calibration blocks read by every observation, a constant block, a bound that is active at
// the optimum, robust losses (one concave: Cauchy; one convex, whose Triggs correction has
// rho'' > 0) and a start far enough for Levenberg-Marquardt to reject steps.
#include <ceres/ceres.h>
#include <ceres/evaluation_callback.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "ctcal/calibrator/lm_solver.h"

namespace ctcal {
namespace {

// z = s (R_c (R_k X + p_k) + t_c): a point X seen from pose k through the calibration (R_c, t_c)
// and a scale s.
struct Observation {
  Eigen::Vector3d X, z;
  double inv_sigma;
  template <typename T>
  bool operator()(const T* q_k, const T* p_k, const T* q_c, const T* t_c, const T* s, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> Rk(q_k), Rc(q_c);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> pk(p_k), tc(t_c);
    const Eigen::Matrix<T, 3, 1> y = s[0] * (Rc * (Rk * X.cast<T>() + pk) + tc);
    for (int i = 0; i < 3; ++i)
      r[i] = (y(i) - T(z(i))) * inv_sigma;
    return true;
  }
};

// The relative pose of consecutive poses: 2 vec(dq^-1 q_k^-1 q_k+1) and p_k+1 - p_k - dp.
struct Odometry {
  Eigen::Quaterniond dq;
  Eigen::Vector3d dp;
  double inv_sigma;
  template <typename T>
  bool operator()(const T* q0, const T* p0, const T* q1, const T* p1, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> a(q0), b(q1);
    const Eigen::Quaternion<T> e = dq.conjugate().cast<T>() * a.conjugate() * b;
    const T sign = e.w() < T(0) ? T(-1) : T(1);
    for (int i = 0; i < 3; ++i) {
      r[i] = T(2) * sign * e.vec()(i) * inv_sigma;
      r[3 + i] = (p1[i] - p0[i] - T(dp(i))) * inv_sigma;
    }
    return true;
  }
};

// rho(s) = s + s^2 / 20: convex (rho'' > 0), so Ceres applies its full curvature correction.
class ConvexLoss : public ceres::LossFunction {
 public:
  void Evaluate(double s, double rho[3]) const override {
    rho[0] = s + s * s / 20.0;
    rho[1] = 1.0 + s / 10.0;
    rho[2] = 1.0 / 10.0;
  }
};

struct TestProblem {
  static constexpr int kPoses = 25;
  std::vector<Eigen::Quaterniond> q;
  std::vector<Eigen::Vector3d> p;
  Eigen::Quaterniond q_c;
  Eigen::Vector3d t_c;
  double s = 1.0;
  std::unique_ptr<ceres::Problem> problem;
  ceres::EigenQuaternionManifold quaternion;

  std::vector<double*> Border() { return {q_c.coeffs().data(), t_c.data(), &s}; }
  std::vector<double> Values() const {
    std::vector<double> v;
    for (int k = 0; k < kPoses; ++k) {
      v.insert(v.end(), q[k].coeffs().data(), q[k].coeffs().data() + 4);
      v.insert(v.end(), p[k].data(), p[k].data() + 3);
    }
    v.insert(v.end(), q_c.coeffs().data(), q_c.coeffs().data() + 4);
    v.insert(v.end(), t_c.data(), t_c.data() + 3);
    v.push_back(s);
    return v;
  }
};

// The truth, then noisy measurements, then a start perturbed by ~25 deg and ~0.4 m.
void MakeProblem(TestProblem* t, bool robust) {
  std::mt19937 rng(7);
  std::normal_distribution<double> n01(0.0, 1.0);
  const auto rot = [&](double sigma) {
    const Eigen::Vector3d w(sigma * n01(rng), sigma * n01(rng), sigma * n01(rng));
    return Eigen::Quaterniond(Eigen::AngleAxisd(w.norm(), w.normalized()));
  };
  std::vector<Eigen::Quaterniond> q_true;
  std::vector<Eigen::Vector3d> p_true;
  for (int k = 0; k < TestProblem::kPoses; ++k) {
    q_true.push_back(
        Eigen::Quaterniond(Eigen::AngleAxisd(0.2 * k, Eigen::Vector3d(0.3, 1, 0.2).normalized())));
    p_true.emplace_back(std::cos(0.3 * k), std::sin(0.3 * k), 0.1 * k);
  }
  const Eigen::Quaterniond qc_true = rot(0.3);
  const Eigen::Vector3d tc_true(0.1, -0.05, 0.2);
  std::vector<Eigen::Vector3d> X;
  for (int j = 0; j < 8; ++j)
    X.emplace_back(3 * n01(rng), 3 * n01(rng), 5 + n01(rng));

  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;  // the test problem's member
  t->problem = std::make_unique<ceres::Problem>(po);
  ceres::Problem& P = *t->problem;
  t->q_c = qc_true * rot(0.4);
  t->t_c = tc_true + Eigen::Vector3d(0.3, -0.2, 0.1);
  t->s = 0.95;
  t->q.resize(TestProblem::kPoses);
  t->p.resize(TestProblem::kPoses);
  for (int k = 0; k < TestProblem::kPoses; ++k) {
    t->q[k] = k == 0 ? q_true[0] : q_true[k] * rot(0.4);
    t->p[k] =
        k == 0 ? p_true[0]
               : Eigen::Vector3d(p_true[k] + 0.25 * Eigen::Vector3d(n01(rng), n01(rng), n01(rng)));
    P.AddParameterBlock(t->q[k].coeffs().data(), 4, &t->quaternion);
    P.AddParameterBlock(t->p[k].data(), 3);
  }
  P.AddParameterBlock(t->q_c.coeffs().data(), 4, &t->quaternion);
  P.AddParameterBlock(t->t_c.data(), 3);
  P.AddParameterBlock(&t->s, 1);
  // The gauge: the first pose is known.
  P.SetParameterBlockConstant(t->q[0].coeffs().data());
  P.SetParameterBlockConstant(t->p[0].data());
  // True scale 1, bounded below it: the bound is active at the optimum.
  P.SetParameterUpperBound(&t->s, 0, 0.999);
  for (int k = 0; k < TestProblem::kPoses; ++k) {
    for (std::size_t j = 0; j < X.size(); ++j) {
      Observation o{X[j], qc_true * (q_true[k] * X[j] + p_true[k]) + tc_true, 100.0};
      o.z += 0.01 * Eigen::Vector3d(n01(rng), n01(rng), n01(rng));
      if (robust && (k * 8 + j) % 17 == 3)
        o.z += Eigen::Vector3d(0.5, -0.3, 0.2);  // an outlier
      P.AddResidualBlock(
          new ceres::AutoDiffCostFunction<Observation, 3, 4, 3, 4, 3, 1>(new Observation(o)),
          robust ? new ceres::CauchyLoss(1.0) : nullptr, t->q[k].coeffs().data(), t->p[k].data(),
          t->q_c.coeffs().data(), t->t_c.data(), &t->s);
    }
    if (k + 1 < TestProblem::kPoses) {
      Odometry od{rot(0.01) * q_true[k].conjugate() * q_true[k + 1],
                  p_true[k + 1] - p_true[k] + 0.01 * Eigen::Vector3d(n01(rng), n01(rng), 0.0),
                  100.0};
      P.AddResidualBlock(new ceres::AutoDiffCostFunction<Odometry, 6, 4, 3, 4, 3>(new Odometry(od)),
                         robust ? new ConvexLoss : nullptr, t->q[k].coeffs().data(), t->p[k].data(),
                         t->q[k + 1].coeffs().data(), t->p[k + 1].data());
    }
  }
}

ceres::Solver::Options Options(int threads) {
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  so.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  so.jacobi_scaling = false;
  so.initial_trust_region_radius = 1e8;  // as the spline solves: Gauss-Newton steps at first
  so.function_tolerance = 1e-12;
  so.parameter_tolerance = 1e-12;
  so.gradient_tolerance = 1e-14;
  so.max_num_iterations = 100;
  so.num_threads = threads;
  return so;
}

struct Case {
  bool robust;
  bool border;
  int threads;
};

class LmSolverTest : public ::testing::TestWithParam<Case> {};

// The same optimum as Ceres' Levenberg-Marquardt: the cost to 1e-10 relative, every value to
// 1e-7 (the optimum's conditioning amplifies rounding), the same accepted and rejected steps.
TEST_P(LmSolverTest, ReachesCeresOptimum) {
  const Case c = GetParam();
  TestProblem ceres_run, ours;
  MakeProblem(&ceres_run, c.robust);
  MakeProblem(&ours, c.robust);
  ceres::Solver::Summary ref, summary;
  ceres::Solve(Options(c.threads), ceres_run.problem.get(), &ref);
  SolveLevenbergMarquardt(Options(c.threads), c.border ? ours.Border() : std::vector<double*>{},
                          ours.problem.get(), &summary);
  ASSERT_EQ(ref.termination_type, ceres::CONVERGENCE) << ref.FullReport();
  EXPECT_EQ(summary.termination_type, ceres::CONVERGENCE) << summary.message;
  EXPECT_NEAR(summary.initial_cost, ref.initial_cost, 1e-12 * ref.initial_cost);
  EXPECT_NEAR(summary.final_cost, ref.final_cost, 1e-10 * ref.final_cost);
  EXPECT_EQ(summary.num_successful_steps, ref.num_successful_steps);
  EXPECT_EQ(summary.num_unsuccessful_steps, ref.num_unsuccessful_steps);
  // The start is far enough for rejected steps (the trust region shrinking).
  EXPECT_GT(summary.num_unsuccessful_steps, 0);
  const std::vector<double> a = ours.Values(), b = ceres_run.Values();
  for (std::size_t i = 0; i < a.size(); ++i)
    EXPECT_NEAR(a[i], b[i], 1e-7) << "value " << i;
  EXPECT_DOUBLE_EQ(ours.s, 0.999);  // on the bound
  // The problem's cost at the returned values is the reported one.
  double cost = 0.0;
  ours.problem->Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, nullptr);
  EXPECT_NEAR(cost, summary.final_cost, 1e-12 * cost);
}

INSTANTIATE_TEST_SUITE_P(Variants, LmSolverTest,
                         ::testing::Values(Case{false, true, 1}, Case{true, true, 2},
                                           Case{true, false, 2}, Case{false, false, 1}));

// The thread count changes only the order of the sums: the same estimates to rounding. The threads
// assemble one H, each its own range of the trajectory plus the blocks that straddle two ranges
// afterwards: an entry written by two threads at once, or a block assembled twice or never, would
// show here (3 and more threads: ranges with a cut on both sides).
TEST(LmSolver, ThreadsChangeOnlyRounding) {
  for (const bool border : {true, false}) {
    const auto solve = [&](int threads, TestProblem* t, ceres::Solver::Summary* s) {
      MakeProblem(t, true);
      SolveLevenbergMarquardt(Options(threads), border ? t->Border() : std::vector<double*>{},
                              t->problem.get(), s);
    };
    TestProblem one;
    ceres::Solver::Summary s1;
    solve(1, &one, &s1);
    const std::vector<double> a = one.Values();
    for (const int threads : {2, 3, 5}) {
      TestProblem many;
      ceres::Solver::Summary s;
      solve(threads, &many, &s);
      SCOPED_TRACE(std::to_string(threads) + " threads, border " + std::to_string(border));
      EXPECT_EQ(s1.iterations.size(), s.iterations.size());
      EXPECT_NEAR(s.final_cost, s1.final_cost, 1e-12 * s1.final_cost);
      const std::vector<double> b = many.Values();
      for (std::size_t i = 0; i < a.size(); ++i)
        EXPECT_NEAR(a[i], b[i], 1e-10) << "value " << i;
    }
  }
}

// A callback's SOLVER_TERMINATE_SUCCESSFULLY ends the solve at the current (accepted) point, and
// the callbacks see every iteration, as in Ceres.
TEST(LmSolver, CallbackEndsTheSolveAtTheCurrentPoint) {
  struct StopAfter : ceres::IterationCallback {
    int seen = 0;
    ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
      ++seen;
      return s.iteration == 2 ? ceres::SOLVER_TERMINATE_SUCCESSFULLY : ceres::SOLVER_CONTINUE;
    }
  };
  TestProblem ceres_run, ours;
  MakeProblem(&ceres_run, false);
  MakeProblem(&ours, false);
  StopAfter a, b;
  ceres::Solver::Options so = Options(1);
  so.callbacks.push_back(&a);
  ceres::Solver::Summary ref, summary;
  ceres::Solve(so, ceres_run.problem.get(), &ref);
  so.callbacks = {&b};
  SolveLevenbergMarquardt(so, ours.Border(), ours.problem.get(), &summary);
  EXPECT_EQ(summary.termination_type, ceres::USER_SUCCESS);
  EXPECT_EQ(a.seen, 3);
  EXPECT_EQ(b.seen, 3);
  EXPECT_NEAR(summary.final_cost, ref.final_cost, 1e-9 * ref.final_cost);
  double cost = 0.0;
  ours.problem->Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, nullptr);
  EXPECT_NEAR(cost, summary.final_cost, 1e-12 * cost);
}

// The problem's evaluation callback (the spline problem's PointInMemory, which the inertial row
// groups' shared factorisation keys on) is called before every evaluation pass, with the point
// already in the parameter blocks' memory: at least once per trial step plus the start, and the
// points it saw are the ones the solver moved through (the first the start, some later one not).
TEST(LmSolver, EvaluationCallbackSeesEveryPointInMemory) {
  struct Points : ceres::EvaluationCallback {
    explicit Points(TestProblem* p) : problem(p) {}
    void PrepareForEvaluation(bool, bool new_point) override {
      EXPECT_TRUE(new_point);
      seen.push_back(problem->Values());
    }
    TestProblem* problem;
    std::vector<std::vector<double>> seen;
  };
  TestProblem t;
  MakeProblem(&t, true);
  const std::vector<double> start = t.Values();
  Points points(&t);
  ceres::Solver::Summary summary;
  SolveLevenbergMarquardt(Options(2), t.Border(), t.problem.get(), &summary, &points);
  const int steps = summary.num_successful_steps + summary.num_unsuccessful_steps;
  ASSERT_GT(steps, 2);
  EXPECT_GE(static_cast<int>(points.seen.size()), steps + 1);
  EXPECT_EQ(points.seen.front(), start);
  EXPECT_TRUE(std::find(points.seen.begin(), points.seen.end(), t.Values()) != points.seen.end())
      << "the final point was never announced";
}

// The border's information at the final point from the solver's last normal equations equals
// ComputeMarginalInformation's from a fresh pass over the Jacobian there (the covariance).
TEST(LmSolver, BorderInformationIsTheMarginalInformationAtTheSolution) {
  TestProblem t;
  MakeProblem(&t, true);
  LevenbergMarquardt lm(Options(2), t.Border(), t.problem.get());
  EXPECT_THROW(lm.MarginalizeToBorder(), std::logic_error);
  ceres::Solver::Summary summary;
  lm.Solve(&summary);
  ASSERT_EQ(summary.termination_type, ceres::CONVERGENCE);
  ASSERT_EQ(lm.Border(), t.Border());
  const MarginalInformation solved = lm.MarginalizeToBorder();
  const MarginalInformation fresh = ComputeMarginalInformation(
      *t.problem, {{t.q_c.coeffs().data(), {"q0", "q1", "q2"}, {1, 1, 1}},
                   {t.t_c.data(), {"t0", "t1", "t2"}, {1, 1, 1}},
                   {&t.s, {"s"}, {1}}});
  ASSERT_EQ(solved.information.rows(), 7);
  EXPECT_EQ(solved.nuisance_dimension, fresh.nuisance_dimension);
  EXPECT_EQ(solved.nuisance_damping, 0.0);
  const double scale = fresh.information.cwiseAbs().maxCoeff();
  EXPECT_LT((solved.information - fresh.information).cwiseAbs().maxCoeff(), 1e-10 * scale)
      << solved.information << "\n\n"
      << fresh.information;
  EXPECT_THROW(lm.MarginalizeToBorder(), std::logic_error);  // taken over once
}

// The border's stop (StopOnBorderDecrease): the solve ends once the step's predicted decrease of
// the calibration alone is below the tolerance, at a border within sqrt(2 tolerance) of the fully
// converged one in the marginal metric there; a tolerance above the first step's share ends it
// before any step. (The scale's bound is lifted: a border held on a bound has a step share the
// bound does not let it take, and the rule never fires.)
TEST(LmSolver, BorderStopEndsWithinItsToleranceOfTheConvergedBorder) {
  const auto unbounded = [](TestProblem* t) {
    MakeProblem(t, false);
    t->problem->SetParameterUpperBound(&t->s, 0, std::numeric_limits<double>::max());
  };
  TestProblem full;
  unbounded(&full);
  LevenbergMarquardt reference(Options(2), full.Border(), full.problem.get());
  ceres::Solver::Summary converged;
  reference.Solve(&converged);
  ASSERT_EQ(converged.termination_type, ceres::CONVERGENCE);
  const Eigen::MatrixXd S = reference.MarginalizeToBorder().information;
  ASSERT_EQ(S.rows(), 7);
  // The border's tangent offset from the converged one (the quaternion manifold's left
  // perturbation: q = Exp(d) q_ref, d half the rotation vector).
  const auto offset = [&](const TestProblem& t) {
    Eigen::VectorXd d(7);
    const Eigen::Quaterniond e = t.q_c * full.q_c.conjugate();
    d.head<3>() = (e.w() < 0.0 ? -1.0 : 1.0) * e.vec();
    d.segment<3>(3) = t.t_c - full.t_c;
    d(6) = t.s - full.s;
    return d;
  };
  for (const double tolerance : {1e-2, 1.0}) {
    TestProblem t;
    unbounded(&t);
    LevenbergMarquardt lm(Options(2), t.Border(), t.problem.get());
    lm.StopOnBorderDecrease(tolerance);
    ceres::Solver::Summary summary;
    lm.Solve(&summary);
    SCOPED_TRACE("tolerance " + std::to_string(tolerance));
    EXPECT_EQ(summary.termination_type, ceres::CONVERGENCE);
    EXPECT_NE(summary.message.find("Border"), std::string::npos) << summary.message;
    EXPECT_LT(summary.iterations.size(), converged.iterations.size());
    const Eigen::VectorXd d = offset(t);
    // The quadratic model's bound, with room for the model's error a step away.
    EXPECT_LT(d.dot(S * d), 2.0 * (2.0 * tolerance)) << d.transpose();
  }
  TestProblem first;
  unbounded(&first);
  const std::vector<double> start = first.Values();
  LevenbergMarquardt lm(Options(2), first.Border(), first.problem.get());
  lm.StopOnBorderDecrease(1e12);
  ceres::Solver::Summary summary;
  lm.Solve(&summary);
  EXPECT_EQ(summary.num_successful_steps, 1);  // iteration 0 only
  EXPECT_EQ(first.Values(), start);
  // Without a border there is no calibration to have converged: the solve runs to its optimum.
  TestProblem none;
  unbounded(&none);
  LevenbergMarquardt plain(Options(2), {}, none.problem.get());
  plain.StopOnBorderDecrease(1e12);
  plain.Solve(&summary);
  EXPECT_EQ(summary.termination_type, ceres::CONVERGENCE);
  EXPECT_EQ(summary.message.find("Border"), std::string::npos) << summary.message;
  EXPECT_NEAR(summary.final_cost, converged.final_cost, 1e-10 * converged.final_cost);
}

}  // namespace
}  // namespace ctcal
