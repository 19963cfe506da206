// The simulator's physics, checked with maths written independently in this file (SPEC section 3
// corrections, an orientation integrator, a pinhole/radtan re-projection through the sensors'
// camera model) against the simulator's output.
#include <gtest/gtest.h>

#include <cmath>

#include "ctcal/sensors/camera_model.h"
#include "ctcal/sim/default_rig.h"
#include "ctcal/sim/kinematics.h"
#include "ctcal/sim/scenario.h"
#include "ctcal/sim/simulator.h"
#include "ctcal/spline/so3.h"
#include "ctcal/targets/board.h"

namespace ctcal::sim {
namespace {

// SPEC section 3 stored forms: upper [d11, d12, d22, d13, d23, d33] column-wise, full row-major.
Eigen::Matrix3d FromStored(const std::vector<double>& v) {
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  if (v.size() == 6) {
    M << v[0], v[1], v[3], 0, v[2], v[4], 0, 0, v[5];
  } else if (v.size() == 9) {
    M << v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8];
  }
  return M;
}

// SPEC section 3, imu2: a_I = R_I_a D_a (a_m - b_a), w_I = D_w (w_m - b_g - T_g a_I).
void CorrectImu2(const SensorConfig& s, const InertialSample& m, const BiasState& b,
                 Eigen::Vector3d* w_I, Eigen::Vector3d* a_I) {
  *a_I = s.R_I_a * FromStored(s.D_a) * (m.a_m - b.b_a);
  *w_I = FromStored(s.D_w) * (m.w_m - b.b_g - FromStored(s.T_g) * *a_I);
}

double Seconds(std::int64_t ns) {
  return static_cast<double>(ns) * 1e-9;
}

struct SimRun {
  RigConfig rig;
  std::unique_ptr<Trajectory> traj;
  SimulatedDataset data;
};

SimRun Simulate(Scenario scenario, double duration, bool noise, std::uint64_t seed = 3,
                RigConfig rig = DefaultRig()) {
  SimRun run;
  run.rig = std::move(rig);
  run.traj = MakeTrajectory(scenario, SceneFor(run.rig.target));
  SimOptions options;
  options.duration = duration;
  options.seed = seed;
  options.white_noise = noise;
  options.bias_random_walk = noise;
  run.data = ctcal::sim::Simulate(run.rig, *run.traj, options);
  return run;
}

const InertialData& Inertial(const SimulatedDataset& d, const std::string& name) {
  for (const InertialData& x : d.inertial) {
    if (x.sensor == name)
      return x;
  }
  throw std::logic_error("no sensor " + name);
}

const CameraData& Camera(const SimulatedDataset& d, const std::string& name) {
  for (const CameraData& x : d.cameras) {
    if (x.sensor == name)
      return x;
  }
  throw std::logic_error("no camera " + name);
}

// Integrates the corrected base gyroscope from the true initial orientation:
// q_{k+1} = q_k Exp((w_k + w_{k+1}) dt / 2 + (w_k x w_{k+1}) dt^2 / 12) (third order, with the
// coning term), and returns the largest angle to the ground truth.
double OrientationDrift(const SimRun& run) {
  const InertialData& imu = Inertial(run.data, "imu0");
  const SensorConfig& s = *run.rig.Find("imu0");
  const auto& gt = run.data.groundtruth;
  EXPECT_EQ(gt.size(), imu.samples.size());
  Eigen::Quaterniond q = gt.front().state.q_W_B;
  Eigen::Vector3d w_prev, a_unused;
  CorrectImu2(s, imu.samples[0], imu.biases[0], &w_prev, &a_unused);
  double worst = 0.0;
  for (std::size_t k = 1; k < imu.samples.size(); ++k) {
    Eigen::Vector3d w;
    CorrectImu2(s, imu.samples[k], imu.biases[k], &w, &a_unused);
    const double dt = Seconds(imu.samples[k].t_ns - imu.samples[k - 1].t_ns);
    const Eigen::Vector3d dtheta = 0.5 * (w_prev + w) * dt + w_prev.cross(w) * dt * dt / 12.0;
    q = (q * ExpSO3<double>(dtheta)).normalized();
    worst = std::max(worst, q.angularDistance(gt[k].state.q_W_B));
    w_prev = w;
  }
  return worst;
}

// Integrates the corrected base accelerometer in W along the true orientation (trapezoid) and
// returns the largest velocity error.
double VelocityDrift(const SimRun& run) {
  const InertialData& imu = Inertial(run.data, "imu0");
  const SensorConfig& s = *run.rig.Find("imu0");
  const auto& gt = run.data.groundtruth;
  const Eigen::Vector3d g_W = *run.data.truth.gravity_W;
  const auto acc_W = [&](std::size_t k) {
    Eigen::Vector3d w, a;
    CorrectImu2(s, imu.samples[k], imu.biases[k], &w, &a);
    return Eigen::Vector3d(gt[k].state.q_W_B * a + g_W);
  };
  Eigen::Vector3d v = gt.front().state.v_W;
  Eigen::Vector3d a_prev = acc_W(0);
  double worst = 0.0;
  for (std::size_t k = 1; k < imu.samples.size(); ++k) {
    const Eigen::Vector3d a = acc_W(k);
    v += 0.5 * (a_prev + a) * Seconds(imu.samples[k].t_ns - imu.samples[k - 1].t_ns);
    worst = std::max(worst, (v - gt[k].state.v_W).norm());
    a_prev = a;
  }
  return worst;
}

TEST(Simulator, BaseImuIntegratesToTheGroundTruthWithoutNoise) {
  const SimRun run = Simulate(Scenario::kFull, 10.0, /*noise=*/false);
  // Only the integrators' discretisation error remains; a wrong intrinsic or bias convention
  // would cost > 1e-2 rad (T_g a ~ 1e-2 rad/s for 10 s) and > 1e-1 m/s.
  // (Measured: 3.9e-5 rad, 2.2e-4 m/s.)
  EXPECT_LT(OrientationDrift(run), 2e-4);
  EXPECT_LT(VelocityDrift(run), 1e-3);
}

TEST(Simulator, BaseImuIntegratesToTheGroundTruthWithinTheNoise) {
  const SimRun run = Simulate(Scenario::kFull, 10.0, /*noise=*/true);
  const InertialNoise& n = run.rig.Find("imu0")->noise;
  // White rate noise integrates to an angle random walk of density * sqrt(T) per axis; the
  // largest excursion of a 3-axis walk over the run stays below 4 sigma * sqrt(3) (~1e-4 chance
  // of failure); likewise the velocity random walk of the accelerometer.
  const double T = 10.0;
  EXPECT_LT(OrientationDrift(run), 4.0 * std::sqrt(3.0) * n.gyroscope_noise_density * std::sqrt(T));
  EXPECT_LT(VelocityDrift(run),
            4.0 * std::sqrt(3.0) * n.accelerometer_noise_density * std::sqrt(T));
  // ... and the noise is really there.
  EXPECT_GT(OrientationDrift(run), 0.05 * n.gyroscope_noise_density * std::sqrt(T));
}

TEST(Simulator, AuxiliaryImuSeesTheBaseMotionThroughItsLeverArmAndClock) {
  // Independent of the simulator's kinematics: the auxiliary IMU's corrected readings are
  // predicted from the corrected BASE readings only (interpolated to t_S + time_offset, angular
  // acceleration by differences), with R_B_S and the lever arm t_B_S.
  const SimRun run = Simulate(Scenario::kFull, 5.0, /*noise=*/false);
  const InertialData& base = Inertial(run.data, "imu0");
  const InertialData& aux = Inertial(run.data, "imu1");
  const SensorConfig& sb = *run.rig.Find("imu0");
  const SensorConfig& sa = *run.rig.Find("imu1");
  const Eigen::Matrix3d R_B_S = sa.T_B_S.topLeftCorner<3, 3>();
  const Eigen::Vector3d r = sa.T_B_S.topRightCorner<3, 1>();
  std::vector<Eigen::Vector3d> w_B(base.samples.size()), f_B(base.samples.size());
  for (std::size_t k = 0; k < base.samples.size(); ++k)
    CorrectImu2(sb, base.samples[k], base.biases[k], &w_B[k], &f_B[k]);
  const double t0 = Seconds(base.samples[0].t_ns), dt = 1.0 / sb.noise.update_rate;
  // Cubic (Catmull-Rom) interpolation of a base series at base time t: error ~ dt^4.
  const auto interp = [&](const std::vector<Eigen::Vector3d>& y, double t, bool derivative) {
    const double x = (t - t0) / dt;
    const long i = static_cast<long>(std::floor(x));
    const double u = x - i;
    const Eigen::Vector3d &p0 = y[i - 1], &p1 = y[i], &p2 = y[i + 1], &p3 = y[i + 2];
    if (derivative) {
      return Eigen::Vector3d((0.5 * (p2 - p0) + u * (2 * p0 - 5 * p1 + 4 * p2 - p3) +
                              1.5 * u * u * (-p0 + 3 * p1 - 3 * p2 + p3)) /
                             dt);
    }
    return Eigen::Vector3d(p1 + 0.5 * u * (p2 - p0) + u * u * (p0 - 2.5 * p1 + 2 * p2 - 0.5 * p3) +
                           0.5 * u * u * u * (-p0 + 3 * p1 - 3 * p2 + p3));
  };
  double worst_w = 0.0, worst_a = 0.0, shift_w = 0.0;
  int checked = 0;
  for (std::size_t k = 0; k < aux.samples.size(); ++k) {
    const double t_B = Seconds(aux.samples[k].t_ns) + sa.time_offset;
    if (t_B < t0 + 3 * dt || t_B > Seconds(base.samples.back().t_ns) - 3 * dt)
      continue;
    Eigen::Vector3d w_S, a_S;
    CorrectImu2(sa, aux.samples[k], aux.biases[k], &w_S, &a_S);
    const Eigen::Vector3d w = interp(w_B, t_B, false);
    const Eigen::Vector3d alpha = interp(w_B, t_B, true);
    const Eigen::Vector3d f = interp(f_B, t_B, false);
    worst_w = std::max(worst_w, (R_B_S * w_S - w).norm());
    worst_a = std::max(worst_a, (R_B_S * a_S - (f + alpha.cross(r) + w.cross(w.cross(r)))).norm());
    // The same comparison at the wrong clock (t_S - time_offset) must fail clearly.
    const Eigen::Vector3d w_wrong = interp(w_B, t_B - 2 * sa.time_offset, false);
    shift_w = std::max(shift_w, (R_B_S * w_S - w_wrong).norm());
    ++checked;
  }
  EXPECT_GT(checked, 1000);
  EXPECT_LT(worst_w, 1e-4);
  EXPECT_LT(worst_a, 5e-3);  // lever-arm terms are ~1 m/s^2 here
  EXPECT_GT(shift_w, 2e-2);
}

TEST(Simulator, CornersReprojectFromTheGroundTruthToTheNoiseLevel) {
  const SimRun run = Simulate(Scenario::kFull, 10.0, /*noise=*/true);
  const Board board(run.rig.target);
  for (const std::string name : {"cam0", "cam1"}) {
    const SensorConfig& s = *run.rig.Find(name);
    const CameraModel camera =
        CameraModel::Create(s.camera_model, s.intrinsics, s.distortion_model, s.distortion_coeffs,
                            Eigen::Vector2i(s.width, s.height));
    const CameraData& cam = Camera(run.data, name);
    const Eigen::Matrix3d R_B_C = s.T_B_S.topLeftCorner<3, 3>();
    const Eigen::Vector3d t_B_C = s.T_B_S.topRightCorner<3, 1>();
    double sum2 = 0.0;
    std::size_t n = 0;
    for (const SimulatedCorner& c : cam.corners) {
      const KinematicState x = run.traj->Evaluate(Seconds(c.t_ns) + s.time_offset);
      const Eigen::Matrix3d R_W_C = x.q_W_B.toRotationMatrix() * R_B_C;
      const Eigen::Vector3d t_W_C = x.p_W_B + x.q_W_B * t_B_C;
      Eigen::Vector2d uv;
      ASSERT_TRUE(camera.Project(R_W_C.transpose() * (board.Corner(c.corner_id) - t_W_C), &uv));
      sum2 += ((c.uv - uv) / c.sigma).squaredNorm();
      EXPECT_LT((c.uv_true - uv).norm(), 1e-9);
      n += 2;
    }
    // ~1e5 whitened residuals: their RMS is 1 within ~0.3 % (1 sigma).
    const double rms = std::sqrt(sum2 / n);
    EXPECT_NEAR(rms, 1.0, 0.02) << name;
    // The board is mostly in view.
    EXPECT_GT(static_cast<double>(cam.corners.size()) / cam.frames_ns.size(),
              0.7 * board.NumCorners())
        << name;
  }
}

TEST(Simulator, TimeOffsetsFollowTheSpecSign) {
  // SPEC section 2: a sample stamped t_S was taken at base time t_S + time_offset. Shifting a
  // sensor's offset by d must make its sample stamped t_S equal the unshifted sensor's sample
  // stamped t_S + d (d a whole number of periods, so such stamps exist).
  RigConfig shifted = DefaultRig();
  RigConfig plain = DefaultRig();
  const double d_imu = 3.0 / 300.0, d_cam = 1.0 / 20.0;
  shifted.Find("imu1")->time_offset = plain.Find("imu1")->time_offset + d_imu;
  shifted.Find("cam0")->time_offset = plain.Find("cam0")->time_offset + d_cam;
  const SimRun a = Simulate(Scenario::kFull, 4.0, false, 9, plain);
  const SimRun b = Simulate(Scenario::kFull, 4.0, false, 9, shifted);

  const InertialData& ia = Inertial(a.data, "imu1");
  const InertialData& ib = Inertial(b.data, "imu1");
  int matched = 0;
  double worst = 0.0, same_stamp_difference = 0.0;
  for (const InertialSample& sb : ib.samples) {
    for (const InertialSample& sa : ia.samples) {
      if (std::llabs(sa.t_ns - (sb.t_ns + std::llround(d_imu * 1e9))) <= 2) {
        worst = std::max(worst, (sa.w_m - sb.w_m).norm() + (sa.a_m - sb.a_m).norm());
        ++matched;
      }
      if (sa.t_ns == sb.t_ns)
        same_stamp_difference = std::max(same_stamp_difference, (sa.w_m - sb.w_m).norm());
    }
  }
  EXPECT_GT(matched, 900);
  EXPECT_LT(worst, 1e-6);  // stamps may differ by a rounded nanosecond
  EXPECT_GT(same_stamp_difference, 1e-2);

  const CameraData& ca = Camera(a.data, "cam0");
  const CameraData& cb = Camera(b.data, "cam0");
  std::map<std::pair<std::int64_t, int>, Eigen::Vector2d> by_stamp;
  for (const SimulatedCorner& c : ca.corners)
    by_stamp[{c.t_ns, c.corner_id}] = c.uv;
  int corners = 0;
  double worst_px = 0.0;
  for (const SimulatedCorner& c : cb.corners) {
    for (std::int64_t dn = -2; dn <= 2; ++dn) {
      const auto it = by_stamp.find({c.t_ns + std::llround(d_cam * 1e9) + dn, c.corner_id});
      if (it != by_stamp.end()) {
        worst_px = std::max(worst_px, (it->second - c.uv).norm());
        ++corners;
      }
    }
  }
  EXPECT_GT(corners, 5000);
  EXPECT_LT(worst_px, 1e-4);
}

TEST(Simulator, RollingShutterRowsAreReadAtTheirOwnTime) {
  RigConfig rig = DefaultRig();
  const double line_delay = 3e-5;  // 14 ms over 480 rows
  rig.Find("cam0")->line_delay = line_delay;
  const SimRun run = Simulate(Scenario::kFull, 3.0, /*noise=*/false, 4, rig);
  const SensorConfig& s = *rig.Find("cam0");
  const CameraModel camera =
      CameraModel::Create(s.camera_model, s.intrinsics, s.distortion_model, s.distortion_coeffs,
                          Eigen::Vector2i(s.width, s.height));
  const Board board(rig.target);
  double worst_rs = 0.0, worst_global = 0.0;
  for (const SimulatedCorner& c : Camera(run.data, "cam0").corners) {
    const auto project_at = [&](double t) {
      const Pose T_W_C = SensorPoseInWorld(run.traj->Evaluate(t), s.T_B_S.topLeftCorner<3, 3>(),
                                           s.T_B_S.topRightCorner<3, 1>());
      Eigen::Vector2d uv;
      EXPECT_TRUE(camera.Project(T_W_C.R.transpose() * (board.Corner(c.corner_id) - T_W_C.t), &uv));
      return uv;
    };
    const double t_image = Seconds(c.t_ns) + s.time_offset;
    // SPEC section 2: the row v was read at t_S + v * line_delay (+ the clock offset).
    worst_rs = std::max(worst_rs, (project_at(t_image + c.uv.y() * line_delay) - c.uv).norm());
    worst_global = std::max(worst_global, (project_at(t_image) - c.uv).norm());
  }
  EXPECT_LT(worst_rs, 1e-6);
  EXPECT_GT(worst_global, 2.0);  // the readout really moves the corners
}

TEST(Simulator, BiasesWalkWithTheirDensityAndNoiseHasItsSigma) {
  const SimRun noisy = Simulate(Scenario::kFull, 30.0, true, 11);
  const SimRun clean = Simulate(Scenario::kFull, 30.0, false, 11);
  const InertialData& n = Inertial(noisy.data, "imu1");
  const InertialData& c = Inertial(clean.data, "imu1");
  const InertialNoise& density = noisy.rig.Find("imu1")->noise;
  const double dt = 1.0 / density.update_rate;
  ASSERT_EQ(n.samples.size(), c.samples.size());
  double bg2 = 0, ba2 = 0, wn2 = 0, an2 = 0;
  for (std::size_t k = 1; k < n.samples.size(); ++k) {
    bg2 += (n.biases[k].b_g - n.biases[k - 1].b_g).squaredNorm();
    ba2 += (n.biases[k].b_a - n.biases[k - 1].b_a).squaredNorm();
  }
  // The raw white noise: noisy minus clean readings minus the bias difference (biases and noise
  // are added after the scale matrices, and T_g acts on the true specific force, not on noise).
  for (std::size_t k = 0; k < n.samples.size(); ++k) {
    const Eigen::Vector3d db_g = n.biases[k].b_g - c.biases[k].b_g;
    const Eigen::Vector3d db_a = n.biases[k].b_a - c.biases[k].b_a;
    const Eigen::Vector3d na = n.samples[k].a_m - c.samples[k].a_m - db_a;
    wn2 += (n.samples[k].w_m - c.samples[k].w_m - db_g).squaredNorm();
    an2 += na.squaredNorm();
  }
  const double m = 3.0 * (n.samples.size() - 1);
  // ~27000 increments: the sample standard deviations are within ~1 % of the truth.
  EXPECT_NEAR(std::sqrt(bg2 / m), density.GyroBiasSigma(dt), 0.05 * density.GyroBiasSigma(dt));
  EXPECT_NEAR(std::sqrt(ba2 / m), density.AccelBiasSigma(dt), 0.05 * density.AccelBiasSigma(dt));
  EXPECT_NEAR(std::sqrt(wn2 / (m + 3)), density.GyroSampleSigma(),
              0.05 * density.GyroSampleSigma());
  EXPECT_NEAR(std::sqrt(an2 / (m + 3)), density.AccelSampleSigma(),
              0.05 * density.AccelSampleSigma());
}

TEST(Simulator, ClocksStayInsideTheBaseInterval) {
  const SimRun run = Simulate(Scenario::kYaw, 6.0, true);
  const auto& gt = run.data.groundtruth;
  const double t0 = Seconds(gt.front().t_ns), t1 = Seconds(gt.back().t_ns);
  EXPECT_NEAR(t1 - t0, 6.0, 1e-9);
  for (const SensorConfig& s : run.rig.sensors) {
    const bool base = s.name == run.rig.base_imu;
    std::vector<std::int64_t> stamps;
    if (s.IsInertial()) {
      for (const InertialSample& x : Inertial(run.data, s.name).samples)
        stamps.push_back(x.t_ns);
    } else {
      stamps = Camera(run.data, s.name).frames_ns;
    }
    ASSERT_FALSE(stamps.empty()) << s.name;
    const double offset = base ? 0.0 : s.time_offset;
    EXPECT_GE(Seconds(stamps.front()) + offset, t0 - 1e-9) << s.name;
    EXPECT_LE(Seconds(stamps.back()) + offset, t1 + 1e-9) << s.name;
    const double rate = s.IsInertial() ? s.noise.update_rate : 20.0;
    EXPECT_NEAR(static_cast<double>(stamps.size()), 6.0 * rate, 1.0) << s.name;
  }
}

TEST(Simulator, CameraOnlyRigUsesTheReferenceCameraAsBase) {
  RigConfig rig = DefaultRig();
  rig.sensors.erase(rig.sensors.begin(), rig.sensors.begin() + 3);  // drop imu0, imu1, gyro0
  rig.base_imu = "cam0";
  // cam1 relative to cam0.
  const Eigen::Matrix4d T_B_C0 = DefaultRig().Find("cam0")->T_B_S;
  rig.Find("cam1")->T_B_S = T_B_C0.inverse() * rig.Find("cam1")->T_B_S;
  rig.Find("cam0")->T_B_S.setIdentity();
  rig.Find("cam0")->time_offset = 0.0;
  ASSERT_TRUE(rig.IsCameraOnly());
  const auto motion = MakeTrajectory(Scenario::kFull, SceneFor(rig.target));
  const Eigen::Matrix3d mount = ScenarioMount(rig);
  // The camera's optical axis z_B points down the scenario's -z_T.
  EXPECT_EQ((mount * Eigen::Vector3d::UnitZ()).z(), -1.0);
  const RotatedTrajectory traj(*motion, mount);
  SimOptions options;
  options.duration = 3.0;
  const SimulatedDataset data = ctcal::sim::Simulate(rig, traj, options);
  EXPECT_FALSE(data.truth.gravity_W.has_value());
  EXPECT_EQ(data.groundtruth.size(), Camera(data, "cam0").frames_ns.size());
  EXPECT_GT(Camera(data, "cam0").corners.size(), 100u * 60);
  EXPECT_GT(Camera(data, "cam1").corners.size(), 100u * 60);
  // The default rig keeps its own axes.
  EXPECT_TRUE(ScenarioMount(DefaultRig()).isIdentity(0.0));
}

TEST(Simulator, RejectsWhatItCannotSimulate) {
  RigConfig rig = DefaultRig();
  rig.Find("imu1")->noise.update_rate = 0.0;
  const auto traj = MakeTrajectory(Scenario::kStatic, SceneFor(rig.target));
  SimOptions options;
  options.duration = 1.0;
  try {
    ctcal::sim::Simulate(rig, *traj, options);
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("imu1"), std::string::npos) << e.what();
  }
  RigConfig late = DefaultRig();
  late.Find("cam1")->line_delay = 0.01;  // a 5 s readout does not fit into 1 s
  try {
    ctcal::sim::Simulate(late, *traj, options);
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("cam1"), std::string::npos) << e.what();
  }
  options.duration = -1.0;
  EXPECT_THROW(ctcal::sim::Simulate(DefaultRig(), *traj, options), std::invalid_argument);
}

}  // namespace
}  // namespace ctcal::sim
