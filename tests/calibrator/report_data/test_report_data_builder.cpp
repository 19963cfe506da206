// The report data builder (calibrator/report_data_builder.h): measurements made from the models
// themselves at a known trajectory come back with zero error (an exact round trip of every
// measurement model, the lever arm and time offset of an auxiliary IMU included), a perturbed
// measurement comes back as exactly its perturbation, and the correlation of a known covariance.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "ctcal/calibrator/discrete/discrete_residuals.h"
#include "ctcal/calibrator/report_data_builder.h"
#include "ctcal/sensors/gyro_intrinsics.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal {
namespace {

// A smooth motion with every derivative non-zero, in closed form.
Se3Kinematics<double> Motion(std::int64_t t_ns, int /*derivatives*/) {
  const double t = 1e-9 * static_cast<double>(t_ns);
  Se3Kinematics<double> k;
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
  const double a = 0.4 * std::sin(1.3 * t), da = 0.52 * std::cos(1.3 * t),
               dda = -0.676 * std::sin(1.3 * t);
  k.R_W_B = Eigen::AngleAxisd(a, axis).toRotationMatrix() *
            Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  // Rotation about a fixed world axis: w_W = da axis, alpha_W = dda axis.
  k.w_B = k.R_W_B.transpose() * (da * axis);
  k.alpha_B = k.R_W_B.transpose() * (dda * axis);
  k.p_W_B = Eigen::Vector3d(0.2 * std::cos(t), 0.1 * std::sin(2 * t), 0.8);
  k.v_W = Eigen::Vector3d(-0.2 * std::sin(t), 0.2 * std::cos(2 * t), 0.0);
  k.a_W = Eigen::Vector3d(-0.2 * std::cos(t), -0.4 * std::sin(2 * t), 0.0);
  return k;
}

class ReportDataBuilder : public ::testing::Test {
 protected:
  void SetUp() override {
    rig_ = LoadRig(std::string(CTCAL_SOURCE_DIR) + "/configs/default_rig_truth.yaml");
    state_ = std::make_unique<CalibrationState>(rig_);
    state_->SetGravity(Eigen::Vector3d(0.1, -0.2, -9.8));
  }
  SensorState& Sensor(const std::string& name) { return *state_->Find(name); }

  RigConfig rig_;
  std::unique_ptr<CalibrationState> state_;
};

TEST_F(ReportDataBuilder, ModelMadeMeasurementsHaveZeroError) {
  ReportInputs in;
  in.t0_ns = 1'000'000'000;
  in.t1_ns = 3'000'000'000;
  // A corner: the board point seen by cam0 at its read-out time, projected by its model.
  SensorState& cam = Sensor("cam0");
  cam.time_offset = 0.0123;
  cam.line_delay = 0.0;
  for (int i = 0; i < 5; ++i) {
    ReportCorner c;
    c.t_ns = 1'500'000'000 + i * 100'000'000;
    c.corner_id = i;
    const Se3Kinematics<double> kin = Motion(c.t_ns + 12'300'000, 0);
    // A point 1 m in front of the camera, expressed on the board (world).
    const Eigen::Vector3d p_C(0.05 * i, -0.03 * i, 1.0);
    const Eigen::Vector3d p_B = cam.R_B_S() * p_C + cam.p_B_S();
    c.p_W = kin.R_W_B * p_B + kin.p_W_B;
    ASSERT_TRUE(cam.camera->Project(p_C, &c.uv));
    c.sigma_px = 0.5;
    c.outlier = i == 4;
    in.corners["cam0"].push_back(c);
  }
  // Inertial samples from the models, with biases and (for imu1) its lever arm and offset.
  for (const std::string name : {"imu0", "imu1"}) {
    SensorState& s = Sensor(name);
    s.bias_gyro.timing = KnotTiming{0, 1'000'000'000};
    s.bias_gyro.knots = {1e-3, 2e-3, -1e-3, 2e-3, 1e-3, 0.0, 0.0, 3e-3, 1e-3, 1e-3, 1e-3, 1e-3};
    s.bias_accel = s.bias_gyro;
    if (!s.is_base)
      s.time_offset = -0.004;
    for (int i = 0; i < 50; ++i) {
      const std::int64_t t_ns = 1'100'000'000 + i * 5'000'000;
      const double offset = s.is_base ? 0.0 : s.time_offset;
      const Se3Kinematics<double> k = Motion(t_ns + std::llround(offset * 1e9), 2);
      const Eigen::Vector3d r = s.p_B_S();
      const Eigen::Matrix3d M = s.R_B_S().transpose();
      const Eigen::Vector3d f_B = k.R_W_B.transpose() * (k.a_W - state_->gravity());
      const Eigen::Vector3d w_S = M * k.w_B;
      const Eigen::Vector3d a_S = M * (f_B + k.alpha_B.cross(r) + k.w_B.cross(k.w_B.cross(r)));
      ImuSample z;
      z.t_ns = t_ns;
      s.imu->RawFromTrue(w_S, a_S, s.bias_gyro.Evaluate(t_ns), s.bias_accel.Evaluate(t_ns), &z.w_m,
                         &z.a_m);
      in.imu[name].push_back(z);
    }
  }
  {
    SensorState& s = Sensor("gyro0");
    s.time_offset = 0.002;
    for (int i = 0; i < 50; ++i) {
      GyroSample z;
      z.t_ns = 1'200'000'000 + i * 5'000'000;
      const Se3Kinematics<double> k = Motion(z.t_ns + 2'000'000, 1);
      z.w_m = GyroRawFromTrue<double>(s.gyro->model(), s.gyro->Dw(),
                                      Eigen::Vector3d(s.R_B_S().transpose() * k.w_B),
                                      Eigen::Vector3d::Zero());
      in.gyro["gyro0"].push_back(z);
    }
  }

  const report::ReportData d = BuildReportData(*state_, in, Motion);
  ASSERT_EQ(d.corners.at("cam0").size(), 5u);
  for (const auto& r : d.corners.at("cam0")) {
    EXPECT_NEAR(r.du, 0.0, 1e-9);
    EXPECT_NEAR(r.dv, 0.0, 1e-9);
    EXPECT_NEAR(r.whitened, 0.0, 2e-9);
    EXPECT_EQ(r.frame, r.corner_id);  // one corner per image here
  }
  EXPECT_TRUE(d.corners.at("cam0").back().outlier);
  for (const std::string name : {"imu0", "imu1", "gyro0"}) {
    for (const auto& r : d.gyro.at(name))
      EXPECT_LT((r.meas - r.pred).norm(), 1e-12) << name;
  }
  for (const std::string name : {"imu0", "imu1"}) {
    ASSERT_EQ(d.accel.at(name).size(), 50u);
    for (const auto& r : d.accel.at(name))
      EXPECT_LT((r.meas - r.pred).norm(), 1e-11) << name;
    // One bias row per 10 samples and the last: the estimate and the random-walk sigma.
    const report::BiasTrack& b = d.bias.at(name);
    ASSERT_EQ(b.gyro.size(), 6u);
    ASSERT_EQ(b.accel.size(), 6u);
    EXPECT_EQ(b.gyro.front().sigma.norm(), 0.0);
    const double dt = 1e-9 * static_cast<double>(b.gyro.back().t_ns - b.gyro.front().t_ns);
    const SensorState& s = Sensor(name);
    EXPECT_DOUBLE_EQ(b.accel.back().sigma.z(),
                     s.config.noise.accelerometer_random_walk * std::sqrt(dt));
    EXPECT_LT((b.gyro[1].b - s.bias_gyro.Evaluate(b.gyro[1].t_ns)).norm(), 1e-15);
  }
  EXPECT_TRUE(d.bias.at("gyro0").accel.empty());
  // Trajectory at 20 Hz over [t0, t1], both ends included.
  ASSERT_EQ(d.trajectory.size(), 41u);
  EXPECT_LT((d.trajectory[7].p_W_B - Motion(d.trajectory[7].t_ns, 0).p_W_B).norm(), 1e-15);
}

TEST_F(ReportDataBuilder, CornerErrorIsTheMeasurementsDisplacement) {
  SensorState& cam = Sensor("cam0");
  cam.time_offset = 0.0;
  cam.line_delay = 0.0;
  ReportInputs in;
  ReportCorner c;
  c.t_ns = 2'000'000'000;
  const Se3Kinematics<double> kin = Motion(c.t_ns, 0);
  const Eigen::Vector3d p_C(0.1, 0.05, 1.2);
  c.p_W = kin.R_W_B * (cam.R_B_S() * p_C + cam.p_B_S()) + kin.p_W_B;
  ASSERT_TRUE(cam.camera->Project(p_C, &c.uv));
  c.uv += Eigen::Vector2d(0.6, -0.8);
  c.sigma_px = 0.5;
  in.corners["cam0"].push_back(c);
  const report::ReportData d = BuildReportData(*state_, in, Motion);
  const report::CornerResidual& r = d.corners.at("cam0").front();
  EXPECT_NEAR(r.du, 0.6, 1e-9);
  EXPECT_NEAR(r.dv, -0.8, 1e-9);
  EXPECT_NEAR(r.whitened, 2.0, 1e-9);  // |(0.6, -0.8)| / 0.5
}

TEST(ReportCorrelation, FromCovarianceWithUndeterminedRows) {
  Eigen::Matrix3d cov;
  cov << 4.0, 1.0, 0.5, 1.0, 9.0, 0.0, 0.5, 0.0, 1.0;
  const report::Correlation c = CorrelationFromCovariance(cov, {"a", "b", "c"});
  EXPECT_EQ(c.values(0, 0), 1.0);
  EXPECT_NEAR(c.values(0, 1), 1.0 / 6.0, 1e-15);
  EXPECT_NEAR(c.values(2, 0), 0.25, 1e-15);
  const report::Correlation u =
      CorrelationFromCovariance(cov, {"a", "b", "c"}, {false, true, false});
  EXPECT_TRUE(u.values.row(1).array().isNaN().all());
  EXPECT_TRUE(u.values.col(1).array().isNaN().all());
  EXPECT_NEAR(u.values(0, 2), 0.25, 1e-15);
  EXPECT_THROW(CorrelationFromCovariance(cov, {"a", "b"}), std::invalid_argument);
}

TEST(ReportVersions, NameEveryLibrary) {
  const report::RunInfo v = LibraryVersions();
  ASSERT_EQ(v.size(), 4u);
  EXPECT_EQ(v[0].first, "version.ceres");
  EXPECT_EQ(v[0].second.substr(0, 2), "2.");
  for (const auto& [key, value] : v)
    EXPECT_FALSE(value.empty()) << key;
}

// The discrete method's keyframe states made from the closed-form motion (base readings from
// the base IMU's model, zero biases): poses read as the corner residuals read them (A.1 / A.2),
// and the C2 interpolation of rates and accelerations reproduces the motion.
TEST_F(ReportDataBuilder, KeyframeTrajectoryReadsPosesAsTheResidualsAndInterpolatesRates) {
  SensorState& base = state_->base();
  const Eigen::Vector3d g_W = state_->gravity();
  std::vector<discrete::Keyframe> kf(41);
  for (std::size_t k = 0; k < kf.size(); ++k) {
    discrete::Keyframe& f = kf[k];
    f.t = 0.05 * static_cast<double>(k);
    const Se3Kinematics<double> m = Motion(static_cast<std::int64_t>(std::llround(f.t * 1e9)), 2);
    const Eigen::Quaterniond q(m.R_W_B);
    f.q_W_B = {q.x(), q.y(), q.z(), q.w()};
    f.p_W_B = {m.p_W_B.x(), m.p_W_B.y(), m.p_W_B.z()};
    f.v_W = {m.v_W.x(), m.v_W.y(), m.v_W.z()};
    f.raw.t = f.t;
    base.imu->RawFromTrue(m.w_B, m.SpecificForce(g_W), Eigen::Vector3d::Zero(),
                          Eigen::Vector3d::Zero(), &f.raw.w_m, &f.raw.a_m);
  }
  // Slots as the discrete problem chooses them: A.1 within 10 ms of a keyframe, else A.2.
  const auto slot = [&](double t) {
    const int k = std::clamp(static_cast<int>(std::floor(t / 0.05)), 0, 39);
    if (t - kf[k].t <= 0.01)
      return KeyframeSlot{k, true};
    if (kf[k + 1].t - t <= 0.01)
      return KeyframeSlot{k + 1, true};
    return KeyframeSlot{k, false};
  };
  const TrajectoryEvaluator traj = KeyframeTrajectory(kf, &*base.imu, g_W, 0, slot);
  const auto at = [](double t) { return static_cast<std::int64_t>(std::llround(t * 1e9)); };
  // A.2 at mid-interval: the geodesic's midpoint, p = (p_k + p_k1) / 2.
  {
    const Se3Kinematics<double> m = traj(at(0.525), 0);
    const Eigen::Vector3d mid =
        0.5 * (Eigen::Vector3d(kf[10].p_W_B.data()) + Eigen::Vector3d(kf[11].p_W_B.data()));
    EXPECT_NEAR((m.p_W_B - mid).norm(), 0.0, 1e-12);
  }
  // A.1 5 ms after keyframe 10 (midpoint rule, pose_interpolation.h; the keyframes' raw rates
  // are zero here, so the reading is the keyframe's): p_k + v_k s + (R_mid a_B + g) s^2 / 2 with
  // R_mid = R_k Exp(w_B s / 2).
  {
    const double s = 0.005;
    const Se3Kinematics<double> truth = Motion(at(0.5), 2);
    const Eigen::Vector3d a_B = truth.R_W_B.transpose() * (truth.a_W - g_W);
    const Eigen::Vector3d acc_W =
        truth.R_W_B * (ExpSO3<double>(Eigen::Vector3d(truth.w_B * (0.5 * s))) * a_B) + g_W;
    const Eigen::Vector3d expect = truth.p_W_B + truth.v_W * s + 0.5 * acc_W * s * s;
    EXPECT_NEAR((traj(at(0.5 + s), 0).p_W_B - expect).norm(), 0.0, 1e-9);
  }
  // Rates and accelerations: exact at the keyframes, the motion's to interpolation accuracy
  // between them (a 0.05 s spacing of a 1.3 rad/s motion).
  for (const double t : {0.5, 0.51, 0.525, 1.234, 1.7}) {
    const Se3Kinematics<double> m = traj(at(t), 2), truth = Motion(at(t), 2);
    const double tol = std::abs(t - 0.05 * std::round(t / 0.05)) < 1e-12 ? 1e-9 : 5e-5;
    EXPECT_NEAR((m.w_B - truth.w_B).norm(), 0.0, tol) << t;
    EXPECT_NEAR((m.a_W - truth.a_W).norm(), 0.0, 10 * tol) << t;
    EXPECT_NEAR((m.alpha_B - truth.alpha_B).norm(), 0.0, 1e-3) << t;
    EXPECT_NEAR((m.p_W_B - truth.p_W_B).norm(), 0.0, 1e-6) << t;
    EXPECT_NEAR((m.R_W_B.transpose() * truth.R_W_B - Eigen::Matrix3d::Identity()).norm(), 0.0, 1e-6)
        << t;
  }
}

// Keyframe biases are held over each interval (as the preintegration factors use them), on the
// base clock reached from the sensor's own by + time_offset.
TEST(KeyframeBiases, HeldPerIntervalOnTheBaseClock) {
  const BiasEvaluator b = KeyframeBiases(
      {0.0, 0.1, 0.2},
      {Eigen::Vector3d::Constant(1), Eigen::Vector3d::Constant(2), Eigen::Vector3d::Constant(3)},
      {}, 1'000'000'000, 0.03);
  Eigen::Vector3d bg, ba = Eigen::Vector3d::Constant(-7);
  b(1'000'000'000 + 60'000'000, &bg, &ba);  // own 0.06 s = base 0.09 s: interval 0
  EXPECT_EQ(bg.x(), 1.0);
  EXPECT_EQ(ba.x(), -7.0);                  // a gyroscope: b_a left alone
  b(1'000'000'000 + 80'000'000, &bg, &ba);  // base 0.11 s: interval 1
  EXPECT_EQ(bg.x(), 2.0);
  b(1'000'000'000 + 900'000'000, &bg, &ba);  // past the last keyframe: its value
  EXPECT_EQ(bg.x(), 3.0);
  EXPECT_THROW(KeyframeBiases({0.0}, {}, {}, 0, 0.0), std::invalid_argument);
}

}  // namespace
}  // namespace ctcal
