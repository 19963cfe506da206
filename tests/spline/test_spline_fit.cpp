// Fitting: splines fitted to samples of a closed-form trajectory (analytic_trajectory.h) recover
// its pose and derivatives within stated tolerances; the split and joint representations agree on a
// dense-knot fit; an orientation spline is recovered from angular velocities; bad input throws.
#include "ctcal/spline/spline_fit.h"

#include <gtest/gtest.h>

#include "ctcal/spline/analytic_trajectory.h"

namespace ctcal {
namespace {

constexpr std::int64_t kSecond = 1'000'000'000;

std::vector<PoseSample> SamplePoses(const AnalyticTrajectory& traj, double seconds,
                                    double rate_hz) {
  std::vector<PoseSample> samples;
  const auto n = static_cast<int>(seconds * rate_hz);
  for (int i = 0; i <= n; ++i) {
    const std::int64_t t_ns = static_cast<std::int64_t>(i * (1e9 / rate_hz));
    const Se3Kinematics<double> k = traj.At(1e-9 * static_cast<double>(t_ns));
    samples.push_back(PoseSample{t_ns, k.q_W_B(), k.p_W_B});
  }
  return samples;
}

struct Errors {
  double rotation = 0, position = 0, w = 0, alpha = 0, v = 0, a = 0, f = 0;
};

// Largest errors against the analytic trajectory on [margin, end - margin] (the ends of a
// smoothing spline have one-sided support).
template <typename Spline>
Errors MaxErrors(const Spline& s, const AnalyticTrajectory& traj, std::int64_t margin_ns) {
  const Eigen::Vector3d g_W(0, 0, -9.81);
  Errors e;
  for (std::int64_t t = s.MinTimeNs() + margin_ns; t <= s.MaxTimeNs() - margin_ns; t += 3'333'333) {
    const Se3Kinematics<double> k = s.Evaluate(t, 2);
    const Se3Kinematics<double> ref = traj.At(1e-9 * static_cast<double>(t));
    e.rotation = std::max(e.rotation, RotationError<double>(k.q_W_B(), ref.q_W_B()).norm());
    e.position = std::max(e.position, (k.p_W_B - ref.p_W_B).norm());
    e.w = std::max(e.w, (k.w_B - ref.w_B).norm());
    e.alpha = std::max(e.alpha, (k.alpha_B - ref.alpha_B).norm());
    e.v = std::max(e.v, (k.v_W - ref.v_W).norm());
    e.a = std::max(e.a, (k.a_W - ref.a_W).norm());
    e.f = std::max(e.f, (k.SpecificForce(g_W) - ref.SpecificForce(g_W)).norm());
  }
  return e;
}

template <int kN>
struct Order {
  static constexpr int N = kN;
};
template <typename C>
class SplineFitTest : public ::testing::Test {};
using Orders = ::testing::Types<Order<4>, Order<5>, Order<6>>;
TYPED_TEST_SUITE(SplineFitTest, Orders);

// 100 Hz exact poses, 50 ms knots: the fit is limited by the spline's approximation power.
TYPED_TEST(SplineFitTest, PoseFitRecoversTheAnalyticTrajectory) {
  const AnalyticTrajectory traj;
  SplineFitOptions options;
  options.dt_ns = 50'000'000;
  SplineFitReport report;
  const auto spline = FitSe3Spline<TypeParam::N>(SamplePoses(traj, 6.0, 100.0), options, &report);
  EXPECT_TRUE(report.converged);
  EXPECT_EQ(spline.MinTimeNs(), 0);
  EXPECT_GE(spline.MaxTimeNs(), 6 * kSecond);
  const Errors e = MaxErrors(spline, traj, kSecond / 4);
  EXPECT_LT(e.rotation, 1e-5);  // rad
  EXPECT_LT(e.position, 1e-5);  // m
  EXPECT_LT(e.w, 1e-3);         // rad/s
  EXPECT_LT(e.v, 1e-3);         // m/s
  EXPECT_LT(e.alpha, 0.05);     // rad/s^2
  EXPECT_LT(e.a, 0.05);         // m/s^2
  EXPECT_LT(e.f, 0.05);         // m/s^2
}

TYPED_TEST(SplineFitTest, JointSe3PoseFitRecoversTheAnalyticTrajectory) {
  const AnalyticTrajectory traj;
  SplineFitOptions options;
  options.dt_ns = 50'000'000;
  const auto spline =
      FitSe3Spline<TypeParam::N, Se3Representation::kJoint>(SamplePoses(traj, 6.0, 100.0), options);
  const Errors e = MaxErrors(spline, traj, kSecond / 4);
  EXPECT_LT(e.rotation, 1e-5);
  EXPECT_LT(e.position, 1e-5);
  EXPECT_LT(e.w, 1e-3);
  EXPECT_LT(e.v, 1e-3);
  EXPECT_LT(e.alpha, 0.05);
  EXPECT_LT(e.a, 0.05);
  EXPECT_LT(e.f, 0.05);
}

// The two representations interpolate differently between knots but converge to the same
// trajectory as the knots get dense: with 20 ms knots they agree far below the fit tolerance.
TEST(SplineFitAgreement, SplitAndJointAgreeOnADenseKnotFit) {
  const AnalyticTrajectory traj;
  SplineFitOptions options;
  options.dt_ns = 20'000'000;
  const auto samples = SamplePoses(traj, 3.0, 200.0);
  const auto split = FitSe3Spline<4, Se3Representation::kSplit>(samples, options);
  const auto joint = FitSe3Spline<4, Se3Representation::kJoint>(samples, options);
  double rot = 0, pos = 0, w = 0, v = 0, a = 0;
  for (std::int64_t t = kSecond / 4; t <= 11 * kSecond / 4; t += 7'000'000) {
    const auto ks = split.Evaluate(t, 2);
    const auto kj = joint.Evaluate(t, 2);
    rot = std::max(rot, RotationError<double>(ks.q_W_B(), kj.q_W_B()).norm());
    pos = std::max(pos, (ks.p_W_B - kj.p_W_B).norm());
    w = std::max(w, (ks.w_B - kj.w_B).norm());
    v = std::max(v, (ks.v_W - kj.v_W).norm());
    a = std::max(a, (ks.a_W - kj.a_W).norm());
  }
  EXPECT_LT(rot, 1e-5);
  EXPECT_LT(pos, 1e-5);
  EXPECT_LT(w, 1e-3);
  EXPECT_LT(v, 1e-3);
  EXPECT_LT(a, 0.05);
}

TYPED_TEST(SplineFitTest, AngularVelocityFitRecoversTheOrientation) {
  const AnalyticTrajectory traj;
  std::vector<AngularVelocitySample> samples;
  for (int i = 0; i <= 1000; ++i) {  // 5 s at 200 Hz
    const std::int64_t t_ns = i * 5'000'000LL;
    samples.push_back({t_ns, traj.At(1e-9 * static_cast<double>(t_ns)).w_B});
  }
  SplineFitOptions options;
  options.dt_ns = 50'000'000;
  SplineFitReport report;
  const auto spline =
      FitSo3SplineToAngularVelocity<TypeParam::N>(samples, traj.At(0.0).q_W_B(), options, &report);
  EXPECT_TRUE(report.converged);
  double rot = 0, w = 0;
  for (std::int64_t t = kSecond / 4; t <= 19 * kSecond / 4; t += 10'000'000) {
    const Se3Kinematics<double> ref = traj.At(1e-9 * static_cast<double>(t));
    rot = std::max(rot, RotationError<double>(spline.Orientation(t), ref.q_W_B()).norm());
    w = std::max(w, (spline.AngularVelocity(t) - ref.w_B).norm());
  }
  EXPECT_LT(rot, 1e-4);  // rad, accumulated over 5 s from integrated rates
  EXPECT_LT(w, 1e-3);    // rad/s
}

TEST(SplineFitErrors, BadInputThrowsWithAReason) {
  SplineFitOptions options;
  EXPECT_THROW(FitSe3Spline<4>({PoseSample{}}, options), std::invalid_argument);
  std::vector<PoseSample> unsorted = {PoseSample{}, PoseSample{}};
  unsorted[0].t_ns = 10;
  try {
    FitSe3Spline<4>(unsorted, options);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("sample 1 at 0 ns follows 10 ns"), std::string::npos)
        << e.what();
  }
  options.dt_ns = 0;
  EXPECT_THROW(FitSe3Spline<4>(SamplePoses(AnalyticTrajectory{}, 1.0, 10.0), options),
               std::invalid_argument);
}

}  // namespace
}  // namespace ctcal
