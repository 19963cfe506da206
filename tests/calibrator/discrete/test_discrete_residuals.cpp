// The discrete problem's interpolated residuals (discrete_residuals.h): every block's Jet Jacobian
// against central differences on the block's manifold (A.1 and A.2 corners, rolling shutter,
// auxiliary IMU with state and rigid velocity, auxiliary gyroscope), and the gyroscope's rotation
// preintegration against the analytic trajectory.
#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <memory>
#include <random>
#include <set>
#include <vector>

#include "ctcal/calibrator/discrete/discrete_residuals.h"
#include "ctcal/sim/scenario.h"
#include "ctcal/spline/so3_manifold.h"
#include "discrete_test_utils.h"

namespace ctcal::discrete {
namespace {

using test::Rand3;
using test::SetQuat;

// Central differences of `cost` on every block (quaternions through So3LeftManifold::Plus)
// against its Jet Jacobian lifted to the same tangent space.
void ExpectJacobiansMatchNumeric(const ceres::CostFunction& cost, const BlockList& list,
                                 const std::set<const double*>& quaternions) {
  const int nr = cost.num_residuals();
  const std::vector<double*>& x = list.blocks();
  const std::size_t nb = x.size();
  std::vector<std::vector<double>> jac(nb);
  std::vector<double*> jptrs(nb);
  for (std::size_t b = 0; b < nb; ++b) {
    jac[b].resize(static_cast<std::size_t>(nr * list.sizes()[b]));
    jptrs[b] = jac[b].data();
  }
  Eigen::VectorXd r0(nr);
  ASSERT_TRUE(cost.Evaluate(x.data(), r0.data(), jptrs.data()));
  So3LeftManifold so3;
  for (std::size_t b = 0; b < nb; ++b) {
    const int n_amb = list.sizes()[b];
    const bool quat = quaternions.count(x[b]) > 0;
    const int n_tan = quat ? 3 : n_amb;
    const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>
        J_amb(jac[b].data(), nr, n_amb);
    Eigen::MatrixXd J_tan = J_amb;
    if (quat) {
      Eigen::Matrix<double, 4, 3, Eigen::RowMajor> P;
      so3.PlusJacobian(x[b], P.data());
      J_tan = J_amb * P;
    }
    const std::vector<double> x0(x[b], x[b] + n_amb);
    // Central differences at h and h/2 combined (Richardson): truncation O(h^4), so that the
    // time blocks, whose Jacobians are ~1e6 px/s, are checked as tightly as the rest.
    const auto central = [&](int c, double h) -> Eigen::VectorXd {
      Eigen::VectorXd rp(nr), rm(nr);
      for (double sign : {1.0, -1.0}) {
        std::vector<double> delta(static_cast<std::size_t>(n_tan), 0.0);
        delta[static_cast<std::size_t>(c)] = sign * h;
        if (quat) {
          so3.Plus(x0.data(), delta.data(), x[b]);
        } else {
          std::copy(x0.begin(), x0.end(), x[b]);
          x[b][c] += delta[static_cast<std::size_t>(c)];
        }
        EXPECT_TRUE(cost.Evaluate(x.data(), sign > 0 ? rp.data() : rm.data(), nullptr));
      }
      std::copy(x0.begin(), x0.end(), x[b]);
      return (rp - rm) / (2 * h);
    };
    // A step that moves the residual by ~1e-2 at most (line delay: ~1e-9 s/row).
    const double eps = 1e-5 / std::max(1.0, J_tan.norm() / 1e3);
    Eigen::MatrixXd J_num(nr, n_tan);
    for (int c = 0; c < n_tan; ++c)
      J_num.col(c) = (4.0 * central(c, 0.5 * eps) - central(c, eps)) / 3.0;
    // Rounding of the residual's value over the step (the random states are far from
    // consistent, so |r| is large).
    const double rounding = 1e-15 * r0.norm() / eps;
    EXPECT_LT((J_num - J_tan).norm(), 2e-6 * std::max(1.0, J_num.norm()) + rounding)
        << "block " << b << " (size " << n_amb << ")\nnumeric\n"
        << J_num << "\njet\n"
        << J_tan;
  }
}

// The two-pass Jacobians of SplitIntegrationCost against the one-pass Jet Jacobians of the same
// functor, every block wanted, and with only the state blocks wanted (the integration pass
// skipped).
void ExpectSplitMatchesOnePass(const ceres::CostFunction& split, const ceres::CostFunction& ref,
                               const std::vector<double*>& x,
                               const std::vector<bool>& integration) {
  const int nr = ref.num_residuals();
  ASSERT_EQ(split.num_residuals(), nr);
  ASSERT_EQ(split.parameter_block_sizes(), ref.parameter_block_sizes());
  const std::size_t nb = x.size();
  for (const bool states_only : {false, true}) {
    std::vector<std::vector<double>> ja(nb), jb(nb);
    std::vector<double*> pa(nb, nullptr), pb(nb, nullptr);
    for (std::size_t b = 0; b < nb; ++b) {
      if (states_only && integration[b])
        continue;
      const std::size_t size = static_cast<std::size_t>(nr * ref.parameter_block_sizes()[b]);
      ja[b].assign(size, 0.0);
      jb[b].assign(size, 0.0);
      pa[b] = ja[b].data();
      pb[b] = jb[b].data();
    }
    Eigen::VectorXd ra(nr), rb(nr), r0(nr);
    ASSERT_TRUE(ref.Evaluate(x.data(), ra.data(), pa.data()));
    ASSERT_TRUE(split.Evaluate(x.data(), rb.data(), pb.data()));
    ASSERT_TRUE(split.Evaluate(x.data(), r0.data(), nullptr));
    EXPECT_LT((rb - ra).norm(), 1e-12 * std::max(1.0, ra.norm()));
    EXPECT_LT((r0 - ra).norm(), 1e-12 * std::max(1.0, ra.norm()));
    for (std::size_t b = 0; b < nb; ++b) {
      const Eigen::Map<const Eigen::VectorXd> A(ja[b].data(),
                                                static_cast<Eigen::Index>(ja[b].size()));
      const Eigen::Map<const Eigen::VectorXd> B(jb[b].data(),
                                                static_cast<Eigen::Index>(jb[b].size()));
      EXPECT_LT((B - A).norm(), 1e-9 * std::max(1.0, A.norm()))
          << "block " << b << (integration[b] ? " (integration)" : " (state)")
          << (states_only ? ", states only" : "");
    }
  }
}

// Two keyframes 30 ms apart with random states, a base IMU with every intrinsic block, gravity.
class DiscreteResiduals : public ::testing::Test {
 protected:
  void SetUp() override {
    std::mt19937 rng(7);
    test::RandomKeyframes(&rng, 1.0, 0.3, Eigen::Vector3d(0, 0, -0.8), 0.03, &k0_, &k1_);
    for (Keyframe* k : {&k0_, &k1_}) {
      k->raw_rate.w_m = Rand3(&rng, 5.0);
      k->raw_rate.a_m = Rand3(&rng, 20.0);
    }
    test::SetBaseScaleAndRotation(&base_);
    Eigen::Matrix3d T_g;
    T_g << 1e-3, 2e-4, -3e-4, 4e-4, -5e-4, 1e-4, 2e-4, 3e-4, 8e-4;
    base_.SetT_g(T_g);
    // Smooth raw samples of an auxiliary sensor (any values: the checks are of derivatives).
    for (int k = 0; k < 100; ++k) {
      const double t = 0.9 + k / 300.0;
      RawImuSample s;
      s.t = t;
      s.w_m = Eigen::Vector3d(std::sin(3 * t), std::cos(2 * t), 0.5 * std::sin(5 * t));
      s.a_m = Eigen::Vector3d(std::cos(4 * t), 9.8 + std::sin(t), std::sin(6 * t));
      aux_samples_.push_back(s);
    }
    noise_.gyroscope_noise_density = 1.7e-4;
    noise_.gyroscope_random_walk = 2e-5;
    noise_.accelerometer_noise_density = 2e-3;
    noise_.accelerometer_random_walk = 3e-3;
    noise_.update_rate = 300.0;
    Eigen::Quaterniond q(q_B_S_[3], q_B_S_[0], q_B_S_[1], q_B_S_[2]);
    SetQuat(&q_B_S_, q.normalized());
  }

  std::set<const double*> Quaternions() const {
    return {k0_.q_W_B.data(), k1_.q_W_B.data(), base_.q_rotation(), aux_imu_.q_rotation(),
            q_B_S_.data()};
  }

  // The auxiliary IMU's factor between the two keyframes (A.1 sources), its blocks in *list;
  // rigid: appendix B, without the auxiliary velocities.
  AuxImuFunctor AuxImuBetweenKeyframes(bool rigid, BlockList* list) {
    const BaseSource src_i = BaseSource::Add(list, &k0_, nullptr, &base_, g_W_.data());
    const BaseSource src_j = BaseSource::Add(list, &k1_, nullptr, &base_, g_W_.data());
    AuxImuIndex ix;
    ix.intr = ImuBlockIndex::Add(list, &aux_imu_);
    ix.q_B_A = list->Add(q_B_S_.data(), 4);
    ix.t_B_A = list->Add(t_B_S_.data(), 3);
    ix.time_offset = list->Add(&time_offset_, 1);
    if (!rigid) {
      ix.v_i = list->Add(v_i_.data(), 3);
      ix.v_j = list->Add(v_j_.data(), 3);
    }
    ix.bg = list->Add(bg_.data(), 3);
    ix.ba = list->Add(ba_.data(), 3);
    auto pre = std::make_shared<Preintegration>(
        aux_samples_, k0_.t - time_offset_, k1_.t - time_offset_, aux_imu_, noise_,
        Eigen::Vector3d(bg_.data()), Eigen::Vector3d(ba_.data()));
    return AuxImuFunctor{pre, src_i, src_j, ix};
  }

  Keyframe k0_, k1_;
  ImuIntrinsics base_{ImuModel::kImu2, GSensitivity::kFull};
  ImuIntrinsics aux_imu_{ImuModel::kImu1, GSensitivity::kUpper};
  GyroIntrinsics gyro_{GyroModel::kUpper};
  std::array<double, 3> g_W_{0.1, -0.2, -9.8};
  std::array<double, 4> q_B_S_{0.1, -0.2, 0.3, 0.927};
  std::array<double, 3> t_B_S_{0.05, -0.02, 0.07};
  double time_offset_ = 0.004;
  double line_delay_ = 3e-5;
  std::array<double, 3> v_i_{0.3, -0.1, 0.2}, v_j_{0.25, -0.05, 0.3};
  std::array<double, 3> bg_{0.003, -0.002, 0.001}, ba_{0.02, 0.01, -0.03};
  std::vector<RawImuSample> aux_samples_;
  InertialNoise noise_;
};

TEST_F(DiscreteResiduals, CornerJacobiansMatchNumericA1AndA2) {
  const Eigen::Quaterniond q(q_B_S_[3], q_B_S_[0], q_B_S_[1], q_B_S_[2]);
  // pinhole-radtan: fu fv cu cv k1 k2 p1 p2
  std::vector<double> params{460.0, 458.0, 370.0, 245.0, -0.28, 0.07, 2e-4, -1e-4};
  for (const bool kinematic : {true, false}) {
    BlockList list;
    const BaseSource src =
        BaseSource::Add(&list, &k0_, kinematic ? nullptr : &k1_, &base_, g_W_.data());
    CornerIndex c;
    c.q_B_C = list.Add(q_B_S_.data(), 4);
    c.t_B_C = list.Add(t_B_S_.data(), 3);
    c.time_offset = list.Add(&time_offset_, 1);
    c.line_delay = list.Add(&line_delay_, 1);
    c.params = list.Add(params.data(), 8);
    // A board corner in front of the camera at the keyframe pose.
    const Eigen::Quaterniond q_W_B(k0_.q_W_B[3], k0_.q_W_B[0], k0_.q_W_B[1], k0_.q_W_B[2]);
    const Eigen::Vector3d p_W_B(k0_.p_W_B.data());
    CornerMeasurement m;
    m.p_W = p_W_B + q_W_B * (q * Eigen::Vector3d(0.1, -0.05, 0.8) + Eigen::Vector3d(t_B_S_.data()));
    m.uv = Eigen::Vector2d(400.0, 260.0);
    m.sigma_px = 0.7;
    const double stamp = kinematic ? k0_.t - time_offset_ - 0.002 : k0_.t + 0.011;
    std::unique_ptr<ceres::CostFunction> cost(
        MakeDiscreteCorner(CameraModelType::kPinholeRadtan, m, stamp, src, c, list));
    SCOPED_TRACE(kinematic ? "A.1" : "A.2");
    ExpectJacobiansMatchNumeric(*cost, list, Quaternions());
  }
}

TEST_F(DiscreteResiduals, AuxImuJacobiansMatchNumericStateAndRigid) {
  for (const bool rigid : {false, true}) {
    BlockList list;
    const AuxImuFunctor f = AuxImuBetweenKeyframes(rigid, &list);
    std::unique_ptr<ceres::CostFunction> cost(
        MakeDynamicAutoDiff(new AuxImuFunctor(f), list.sizes(), 9));
    SCOPED_TRACE(rigid ? "rigid" : "state");
    ExpectJacobiansMatchNumeric(*cost, list, Quaternions());
  }
}

TEST_F(DiscreteResiduals, AuxGyroJacobiansMatchNumeric) {
  BlockList list;
  const BaseSource src_i = BaseSource::Add(&list, &k0_, nullptr, &base_, g_W_.data());
  const BaseSource src_j = BaseSource::Add(&list, &k1_, nullptr, &base_, g_W_.data());
  AuxGyroIndex ix;
  ix.model = gyro_.model();
  ix.Dw = list.Add(gyro_.Dw(), gyro_.DwSize());
  ix.q_B_G = list.Add(q_B_S_.data(), 4);
  ix.time_offset = list.Add(&time_offset_, 1);
  ix.bg = list.Add(bg_.data(), 3);
  auto pre =
      std::make_shared<GyroPreintegration>(aux_samples_, k0_.t - time_offset_, k1_.t - time_offset_,
                                           gyro_, noise_, Eigen::Vector3d(bg_.data()));
  std::unique_ptr<ceres::CostFunction> cost(
      MakeDynamicAutoDiff(new AuxGyroFunctor{pre, src_i, src_j, ix}, list.sizes(), 3));
  ExpectJacobiansMatchNumeric(*cost, list, Quaternions());
}

TEST_F(DiscreteResiduals, SplitIntegrationMatchesOnePassJacobians) {
  for (const bool rigid : {false, true}) {
    BlockList list;
    const AuxImuFunctor f = AuxImuBetweenKeyframes(rigid, &list);
    std::unique_ptr<ceres::CostFunction> ref(
        MakeDynamicAutoDiff(new AuxImuFunctor(f), list.sizes(), 9));
    std::unique_ptr<ceres::CostFunction> split(MakeSplitIntegration(f, list, 9));
    SCOPED_TRACE(rigid ? "aux imu, rigid" : "aux imu, state");
    ExpectSplitMatchesOnePass(*split, *ref, list.blocks(),
                              f.IntegrationBlocks(list.sizes().size()));
  }
  {
    BlockList list;
    const BaseSource src_i = BaseSource::Add(&list, &k0_, nullptr, &base_, g_W_.data());
    // An A.2 source at the end (the split must not depend on the pose's form).
    const BaseSource src_j = BaseSource::Add(&list, &k0_, &k1_, &base_, g_W_.data());
    AuxGyroIndex ix;
    ix.model = gyro_.model();
    ix.Dw = list.Add(gyro_.Dw(), gyro_.DwSize());
    ix.q_B_G = list.Add(q_B_S_.data(), 4);
    ix.time_offset = list.Add(&time_offset_, 1);
    ix.bg = list.Add(bg_.data(), 3);
    auto pre = std::make_shared<GyroPreintegration>(aux_samples_, k0_.t - time_offset_,
                                                    k1_.t - time_offset_, gyro_, noise_,
                                                    Eigen::Vector3d(bg_.data()));
    const AuxGyroFunctor f{pre, src_i, src_j, ix};
    std::unique_ptr<ceres::CostFunction> ref(
        MakeDynamicAutoDiff(new AuxGyroFunctor(f), list.sizes(), 3));
    std::unique_ptr<ceres::CostFunction> split(MakeSplitIntegration(f, list, 3));
    SCOPED_TRACE("aux gyro");
    ExpectSplitMatchesOnePass(*split, *ref, list.blocks(),
                              f.IntegrationBlocks(list.sizes().size()));
  }
  {
    // The base IMU's re-integration factor (eq. 37) between the two keyframes.
    auto pre = std::make_shared<Preintegration>(aux_samples_, k0_.t, k1_.t, base_, noise_,
                                                Eigen::Vector3d(k0_.b_g.data()),
                                                Eigen::Vector3d(k0_.b_a.data()));
    std::vector<double*> x{k0_.q_W_B.data(), k0_.p_W_B.data(), k0_.v_W.data(),
                           k0_.b_g.data(),   k0_.b_a.data(),   k1_.q_W_B.data(),
                           k1_.p_W_B.data(), k1_.v_W.data(),   g_W_.data()};
    for (double* p : {base_.Dw(), base_.Da(), base_.Tg(), base_.q_rotation()}) {
      if (p != nullptr)
        x.push_back(p);
    }
    std::unique_ptr<ceres::CostFunction> ref(ReintegrationFactor::Create(pre, base_));
    std::unique_ptr<ceres::CostFunction> split(ReintegrationFactor::CreateSplit(pre, base_));
    std::vector<bool> integration(x.size(), true);
    for (const std::size_t b : {0, 1, 2, 5, 6, 7, 8})
      integration[b] = false;
    SCOPED_TRACE("base re-integration");
    ExpectSplitMatchesOnePass(*split, *ref, x, integration);
  }
}

// The gyroscope's rotation preintegration (same nodes and RK4 as the base IMU's) reproduces the
// analytic relative rotation of the "full" motion, and its whitening is consistent under noise.
TEST_F(DiscreteResiduals, GyroPreintegrationMatchesTruthAndIsConsistent) {
  const auto traj = sim::MakeTrajectory(sim::Scenario::kFull, sim::Scene{});
  const double rate = 200.0;
  Eigen::Matrix3d D;
  D << 1.01, 0.004, -0.003, 0, 0.99, 0.002, 0, 0, 1.005;
  gyro_.SetD_w(D);
  const Eigen::Vector3d b_g(0.004, -0.003, 0.002);
  std::vector<RawImuSample> clean;
  for (int k = 0; k <= static_cast<int>(rate * 8.0); ++k) {
    RawImuSample s;
    s.t = 1.0 + k / rate;
    s.w_m = gyro_.RawFromTrue(traj->Evaluate(s.t).w_B, b_g);
    clean.push_back(s);
  }
  InertialNoise noise = noise_;
  noise.update_rate = rate;
  const auto truth = [&](double t_i, double t_j) {
    return Eigen::Quaterniond(traj->Evaluate(t_i).q_W_B.conjugate() * traj->Evaluate(t_j).q_W_B);
  };
  double max_err = 0.0;
  for (int n = 0; n < 40; ++n) {
    const double t_i = 1.5 + 0.1537 * n + 0.0013;
    const GyroPreintegration pre(clean, t_i, t_i + 0.1, gyro_, noise, b_g);
    max_err = std::max(max_err, RotationError<double>(pre.dR(), truth(t_i, t_i + 0.1)).norm());
  }
  std::printf("gyro preintegration, 0.1 s: max rotation error %.2e rad\n", max_err);
  EXPECT_LT(max_err, 1e-6);

  std::mt19937 rng(3);
  std::normal_distribution<double> nd(0.0, 1.0);
  double chi2 = 0.0;
  const int trials = 300;
  for (int n = 0; n < trials; ++n) {
    std::vector<RawImuSample> noisy = clean;
    for (RawImuSample& s : noisy)
      s.w_m += noise.GyroSampleSigma() * Eigen::Vector3d(nd(rng), nd(rng), nd(rng));
    const double t_i = 1.5 + 0.021 * n;
    const GyroPreintegration pre(noisy, t_i, t_i + 0.1, gyro_, noise, b_g);
    // Right-perturbation error of dR, the covariance's convention.
    const Eigen::Vector3d r =
        pre.sqrt_information() * LogSO3<double>(pre.dR().conjugate() * truth(t_i, t_i + 0.1));
    chi2 += r.squaredNorm();
  }
  std::printf("gyro preintegration: mean whitened chi2 %.3f (3)\n", chi2 / trials);
  EXPECT_NEAR(chi2 / trials, 3.0, 0.45);
}

}  // namespace
}  // namespace ctcal::discrete
