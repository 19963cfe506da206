// Base IMU preintegration and its residual (discrete MVIS formulation) on simulated data: the
// sim library's analytic "full" trajectory sampled by an IMU with non-trivial intrinsics.
#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <memory>
#include <random>
#include <vector>

#include "ctcal/calibrator/discrete/preintegration.h"
#include "ctcal/calibrator/discrete/preintegration_residual.h"
#include "ctcal/sensors/inertial_noise.h"
#include "ctcal/sim/scenario.h"
#include "ctcal/spline/so3_manifold.h"

namespace ctcal::discrete {
namespace {

constexpr double kRate = 200.0;
const Eigen::Vector3d kGravityW(0.0, 0.0, -9.81);

// imu2 with upper T_g: every correction term of ImuTrueFromRaw is exercised.
ImuIntrinsics TestIntrinsics() {
  ImuIntrinsics intr(ImuModel::kImu2, GSensitivity::kUpper);
  Eigen::Matrix3d D_w, D_a, T_g;
  D_w << 1.01, 0.004, -0.003, 0, 0.99, 0.002, 0, 0, 1.005;
  D_a << 0.995, -0.003, 0.002, 0, 1.008, 0.004, 0, 0, 0.997;
  T_g << 1e-3, 2e-4, -3e-4, 0, -5e-4, 1e-4, 0, 0, 8e-4;
  intr.SetD_w(D_w);
  intr.SetD_a(D_a);
  intr.SetT_g(T_g);
  intr.SetRotation(ExpSO3<double>(Eigen::Vector3d(0.01, -0.02, 0.015)).toRotationMatrix());
  return intr;
}

struct Truth {
  Eigen::Quaterniond q;
  Eigen::Vector3d p, v;
};

class DiscretePreintegration : public ::testing::Test {
 protected:
  void SetUp() override {
    traj_ = sim::MakeTrajectory(sim::Scenario::kFull, sim::Scene{});
    for (int k = 0; k <= static_cast<int>(kRate * 8.0); ++k)
      clean_.push_back(Sample(1.0 + k / kRate));
  }

  RawImuSample Sample(double t) const {
    const sim::KinematicState x = traj_->Evaluate(t);
    RawImuSample s;
    s.t = t;
    intr_.RawFromTrue(x.w_B, x.q_W_B.conjugate() * (x.a_W - kGravityW), b_g_, b_a_, &s.w_m, &s.a_m);
    return s;
  }

  Truth At(double t) const {
    const sim::KinematicState x = traj_->Evaluate(t);
    return {x.q_W_B, x.p_W_B, x.v_W};
  }

  // The clean samples with fresh white noise of the sample sigma (density * sqrt(rate)).
  std::vector<RawImuSample> Noisy(std::mt19937* rng) const {
    std::normal_distribution<double> n(0.0, 1.0);
    const double sg = noise_.GyroSampleSigma(), sa = noise_.AccelSampleSigma();
    std::vector<RawImuSample> out = clean_;
    for (RawImuSample& s : out) {
      s.w_m += sg * Eigen::Vector3d(n(*rng), n(*rng), n(*rng));
      s.a_m += sa * Eigen::Vector3d(n(*rng), n(*rng), n(*rng));
    }
    return out;
  }

  // The unwhitened residual of the bias-linearised deltas against the true states.
  Eigen::Matrix<double, 9, 1> ResidualAtTruth(const Preintegration& pre) const {
    const Truth a = At(pre.t_i()), b = At(pre.t_j());
    return PreintegrationError<double>(pre.Corrected<double>(b_g_, b_a_), pre.dt(), kGravityW, a.q,
                                       a.p, a.v, b.q, b.p, b.v);
  }

  std::unique_ptr<sim::Trajectory> traj_;
  ImuIntrinsics intr_ = TestIntrinsics();
  InertialNoise noise_ = EurocAdis16448Noise(kRate);
  Eigen::Vector3d b_g_ = Eigen::Vector3d(0.004, -0.003, 0.002);
  Eigen::Vector3d b_a_ = Eigen::Vector3d(0.05, -0.03, 0.04);
  std::vector<RawImuSample> clean_;
};

// Keyframe times between samples (partial first/last sub-intervals), 0.1 s apart (cam0 at 10 Hz)
// and 0.05 s apart: the deltas reproduce the analytic relative motion to the integration error.
TEST_F(DiscretePreintegration, NoiseFreeReproducesTruthRelativeMotion) {
  for (double spacing : {0.05, 0.1}) {
    double max_r = 0, max_v = 0, max_p = 0;
    for (int n = 0; n < 40; ++n) {
      const double t_i = 1.5 + 0.1537 * n + 0.0013;
      const Preintegration pre(clean_, t_i, t_i + spacing, intr_, noise_, b_g_, b_a_);
      const Eigen::Matrix<double, 9, 1> r = ResidualAtTruth(pre);
      max_r = std::max(max_r, r.head<3>().norm());
      max_v = std::max(max_v, r.segment<3>(3).norm());
      max_p = std::max(max_p, r.tail<3>().norm());
    }
    std::printf("spacing %.2f s: max |r_R| %.2e rad, |r_v| %.2e m/s, |r_p| %.2e m\n", spacing,
                max_r, max_v, max_p);
    // Cubic readings + RK4 (preintegration.h): the bound is 1e-6 rad over 0.1 s (the
    // midpoint rule had 2.6e-5 rad, 2.3e-4 m/s, 2.2e-5 m).
    EXPECT_LT(max_r, 1e-6);
    EXPECT_LT(max_v, 1e-5);
    EXPECT_LT(max_p, 1e-6);
  }
}

// Keyframes on sample times and between them give the same deltas as the same interval split
// differently: integrating [t_i, t_m] and [t_m, t_j] and composing equals [t_i, t_j].
TEST_F(DiscretePreintegration, ComposesAcrossASplitBetweenSamples) {
  const double t_i = 2.0, t_m = 2.0421, t_j = 2.1007;
  const Preintegration a(clean_, t_i, t_m, intr_, noise_, b_g_, b_a_);
  const Preintegration b(clean_, t_m, t_j, intr_, noise_, b_g_, b_a_);
  const Preintegration ab(clean_, t_i, t_j, intr_, noise_, b_g_, b_a_);
  const auto& da = a.deltas();
  const auto& db = b.deltas();
  const Eigen::Quaterniond dR = da.dR * db.dR;
  const Eigen::Vector3d dv = da.dv + da.dR * db.dv;
  const Eigen::Vector3d dp = da.dp + da.dv * b.dt() + da.dR * db.dp;
  // Only the sub-interval containing t_m differs (one midpoint step split in two).
  EXPECT_LT(RotationError<double>(dR, ab.deltas().dR).norm(), 1e-7);
  EXPECT_LT((dv - ab.deltas().dv).norm(), 1e-5);
  EXPECT_LT((dp - ab.deltas().dp).norm(), 1e-6);
}

// With white noise of the stated densities, the whitened residual at the true states is
// chi-square with 9 degrees of freedom: its mean square over many intervals is ~9 and each of
// the three blocks contributes ~3.
TEST_F(DiscretePreintegration, WhitenedResidualIsConsistentUnderNoise) {
  std::mt19937 rng(7);
  constexpr int kIntervals = 400;
  double sum = 0;
  Eigen::Vector3d per_block = Eigen::Vector3d::Zero();
  for (int n = 0; n < kIntervals; ++n) {
    const std::vector<RawImuSample> noisy = Noisy(&rng);
    const double t_i = 1.5 + 0.0153 * n + 0.0011;
    const Preintegration pre(noisy, t_i, t_i + 0.1, intr_, noise_, b_g_, b_a_);
    const Eigen::Matrix<double, 9, 1> r = pre.sqrt_information() * ResidualAtTruth(pre);
    // Block contributions need the covariance's own blocks (S mixes them).
    const Eigen::Matrix<double, 9, 1> u = ResidualAtTruth(pre);
    for (int b = 0; b < 3; ++b)
      per_block[b] += u.segment<3>(3 * b).dot(
          pre.covariance().block<3, 3>(3 * b, 3 * b).ldlt().solve(u.segment<3>(3 * b)));
    sum += r.squaredNorm();
  }
  const double mean = sum / kIntervals;
  per_block /= kIntervals;
  std::printf("mean whitened |r|^2 %.3f (9 expected), per block %.3f %.3f %.3f (3 expected)\n",
              mean, per_block[0], per_block[1], per_block[2]);
  // Standard deviation of the mean of 400 chi2(9): sqrt(18 / 400) = 0.21.
  EXPECT_NEAR(mean, 9.0, 0.75);
  for (int b = 0; b < 3; ++b)
    EXPECT_NEAR(per_block[b], 3.0, 0.45);
}

// The bias Jacobians equal central differences of re-integration, and the first-order correction
// tracks a re-integration at perturbed biases to second order.
TEST_F(DiscretePreintegration, BiasJacobiansMatchReintegration) {
  const Preintegration pre(clean_, 3.0021, 3.1021, intr_, noise_, b_g_, b_a_);
  const ImuBlocks<double> blocks = intr_.blocks();
  const auto integrate = [&](const Eigen::Matrix<double, 6, 1>& db) {
    return IntegrateDeltas<double>(pre.readings(), intr_.layout(), blocks,
                                   Eigen::Vector3d(b_g_ + db.head<3>()),
                                   Eigen::Vector3d(b_a_ + db.tail<3>()));
  };
  const PreintegratedDeltas<double> d0 = integrate(Eigen::Matrix<double, 6, 1>::Zero());
  EXPECT_LT(RotationError<double>(d0.dR, pre.deltas().dR).norm(), 1e-14);
  Eigen::Matrix<double, 9, 6> J_num;
  const double eps = 1e-5;
  for (int c = 0; c < 6; ++c) {
    Eigen::Matrix<double, 6, 1> db = Eigen::Matrix<double, 6, 1>::Zero();
    db[c] = eps;
    const PreintegratedDeltas<double> p = integrate(db), m = integrate(-db);
    J_num.block<3, 1>(0, c) =
        LogSO3<double>(Eigen::Quaterniond(m.dR.conjugate() * p.dR)) / (2 * eps);
    J_num.block<3, 1>(3, c) = (p.dv - m.dv) / (2 * eps);
    J_num.block<3, 1>(6, c) = (p.dp - m.dp) / (2 * eps);
  }
  EXPECT_LT((J_num - pre.J_delta_bias()).norm(), 1e-6 * J_num.norm()) << "numeric\n"
                                                                      << J_num << "\nanalytic\n"
                                                                      << pre.J_delta_bias();

  // A realistic bias error (0.01 rad/s, 0.1 m/s^2): first-order correction vs re-integration.
  Eigen::Matrix<double, 6, 1> db;
  db << 0.01, -0.007, 0.005, 0.1, -0.08, 0.06;
  const PreintegratedDeltas<double> exact = integrate(db);
  const PreintegratedDeltas<double> lin = pre.Corrected<double>(
      Eigen::Vector3d(b_g_ + db.head<3>()), Eigen::Vector3d(b_a_ + db.tail<3>()));
  const double e_R = RotationError<double>(lin.dR, exact.dR).norm();
  const double e_v = (lin.dv - exact.dv).norm();
  const double e_p = (lin.dp - exact.dp).norm();
  std::printf("first-order bias correction error: %.2e rad %.2e m/s %.2e m\n", e_R, e_v, e_p);
  // Second order in db: (0.01 rad/s * 0.1 s)^2 ~ 1e-6 rad; velocity ~ |a| * that * dt.
  EXPECT_LT(e_R, 1e-6);
  EXPECT_LT(e_v, 1e-5);
  EXPECT_LT(e_p, 1e-6);
}

// Tangent-space Jacobian check of a cost function: Ceres' Jet Jacobians lifted through each
// block's PlusJacobian against central differences of the residual along Plus.
void ExpectJacobiansMatchNumeric(const ceres::CostFunction& cost,
                                 std::vector<std::vector<double>> x,
                                 const std::vector<bool>& is_quaternion) {
  const int nr = cost.num_residuals();
  const std::size_t nb = x.size();
  std::vector<const double*> ptrs(nb);
  std::vector<std::vector<double>> jac(nb);
  std::vector<double*> jptrs(nb);
  for (std::size_t b = 0; b < nb; ++b) {
    ptrs[b] = x[b].data();
    jac[b].resize(nr * x[b].size());
    jptrs[b] = jac[b].data();
  }
  Eigen::VectorXd r0(nr);
  ASSERT_TRUE(cost.Evaluate(ptrs.data(), r0.data(), jptrs.data()));
  So3LeftManifold so3;
  for (std::size_t b = 0; b < nb; ++b) {
    const int n_amb = static_cast<int>(x[b].size());
    const int n_tan = is_quaternion[b] ? 3 : n_amb;
    const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>
        J_amb(jac[b].data(), nr, n_amb);
    Eigen::MatrixXd J_tan = J_amb;
    if (is_quaternion[b]) {
      Eigen::Matrix<double, 4, 3, Eigen::RowMajor> P;
      so3.PlusJacobian(x[b].data(), P.data());
      J_tan = J_amb * P;
    }
    Eigen::MatrixXd J_num(nr, n_tan);
    const std::vector<double> x0 = x[b];
    const double eps = 1e-6;
    for (int c = 0; c < n_tan; ++c) {
      Eigen::VectorXd rp(nr), rm(nr);
      for (double sign : {1.0, -1.0}) {
        std::vector<double> delta(n_tan, 0.0);
        delta[c] = sign * eps;
        if (is_quaternion[b]) {
          so3.Plus(x0.data(), delta.data(), x[b].data());
        } else {
          x[b] = x0;
          x[b][c] += delta[c];
        }
        ASSERT_TRUE(cost.Evaluate(ptrs.data(), sign > 0 ? rp.data() : rm.data(), nullptr));
      }
      x[b] = x0;
      J_num.col(c) = (rp - rm) / (2 * eps);
    }
    EXPECT_LT((J_num - J_tan).norm(), 1e-6 * std::max(1.0, J_num.norm()))
        << "block " << b << "\nnumeric\n"
        << J_num << "\njet\n"
        << J_tan;
  }
}

std::vector<double> Quat(const Eigen::Quaterniond& q) {
  return {q.x(), q.y(), q.z(), q.w()};
}
std::vector<double> Vec(const Eigen::Vector3d& v) {
  return {v.x(), v.y(), v.z()};
}

// At the true states the whitened residual is at the level of the integration error (<< 1),
// and its Jet Jacobians match numeric differentiation at a perturbed state, for both factors.
TEST_F(DiscretePreintegration, ResidualZeroAtTruthAndJacobiansMatchNumeric) {
  auto pre = std::make_shared<Preintegration>(clean_, 4.0013, 4.1013, intr_, noise_, b_g_, b_a_);
  const Truth a = At(pre->t_i()), b = At(pre->t_j());
  std::vector<std::vector<double>> x = {Quat(a.q), Vec(a.p), Vec(a.v), Vec(b_g_),     Vec(b_a_),
                                        Quat(b.q), Vec(b.p), Vec(b.v), Vec(kGravityW)};
  std::vector<bool> is_q = {true, false, false, false, false, true, false, false, false};
  std::unique_ptr<ceres::CostFunction> fixed(PreintegrationFactor::Create(pre));
  std::vector<std::vector<double>> xr = x;
  std::vector<bool> is_qr = is_q;
  ImuIntrinsics intr = intr_;
  xr.push_back({intr.Dw(), intr.Dw() + intr.DwSize()});
  xr.push_back({intr.Da(), intr.Da() + intr.DaSize()});
  xr.push_back({intr.Tg(), intr.Tg() + intr.TgSize()});
  xr.push_back({intr.q_rotation(), intr.q_rotation() + 4});
  is_qr.insert(is_qr.end(), {false, false, false, true});
  std::unique_ptr<ceres::CostFunction> reint(ReintegrationFactor::Create(pre, intr_));

  for (const auto& [cost, xx] :
       {std::pair<ceres::CostFunction*, std::vector<std::vector<double>>*>{fixed.get(), &x},
        {reint.get(), &xr}}) {
    std::vector<const double*> ptrs;
    for (const auto& blk : *xx)
      ptrs.push_back(blk.data());
    Eigen::Matrix<double, 9, 1> r;
    ASSERT_TRUE(cost->Evaluate(ptrs.data(), r.data(), nullptr));
    // Whitened: the integration error above is ~0.4 of the noise sigma over 0.1 s.
    EXPECT_LT(r.norm(), 1.0) << r.transpose();
  }

  // Away from the truth (biases off the linearisation point, states perturbed).
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  for (auto* xx : {&x, &xr}) {
    for (std::size_t blk = 0; blk < 9; ++blk)
      for (double& v : (*xx)[blk])
        v += 0.01 * n(rng);
    for (int q : {0, 5})
      Eigen::Map<Eigen::Quaterniond>((*xx)[q].data()).normalize();
  }
  ExpectJacobiansMatchNumeric(*fixed, x, is_q);
  ExpectJacobiansMatchNumeric(*reint, xr, is_qr);
}

TEST_F(DiscretePreintegration, BadIntervalsThrowNamingTheTimes) {
  EXPECT_THROW(Preintegration(clean_, 2.0, 2.0, intr_, noise_, b_g_, b_a_), std::invalid_argument);
  EXPECT_THROW(Preintegration(clean_, 0.5, 1.2, intr_, noise_, b_g_, b_a_), std::invalid_argument);
  EXPECT_THROW(Preintegration(clean_, 8.9, 9.5, intr_, noise_, b_g_, b_a_), std::invalid_argument);
  try {
    Preintegration(clean_, 8.9, 9.5, intr_, noise_, b_g_, b_a_);
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("[8.9, 9.5]"), std::string::npos) << e.what();
  }
  InertialNoise bad = noise_;
  bad.update_rate = 0;
  EXPECT_THROW(Preintegration(clean_, 2.0, 2.1, intr_, bad, b_g_, b_a_), std::invalid_argument);
}

}  // namespace
}  // namespace ctcal::discrete
