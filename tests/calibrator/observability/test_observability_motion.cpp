// Motion-primitive detection (observability/motion_primitives.h) on short simulated recordings
// of every scenario, on spliced synthetic readings (window segments) and on pure noise (false
// alarms), plus the prediction for each scenario (observability/motion_prediction.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <string>

#include "ctcal/calibrator/observability/motion_prediction.h"
#include "ctcal/calibrator/observability/motion_primitives.h"
#include "ctcal/sim/default_rig.h"
#include "ctcal/sim/scenario.h"
#include "ctcal/sim/simulator.h"

namespace ctcal {
namespace {

constexpr double kDuration = 15.0;  // s

struct Recording {
  RigConfig rig;
  std::map<std::string, SensorData> data;
  Observability observability;
  double t_first = 0.0;  // base IMU's first and last stamps (s)
  double t_last = 0.0;
};

// Simulated once per scenario and process (in memory, no files).
const Recording& Simulated(const std::string& scenario) {
  static std::map<std::string, Recording> cache;
  auto it = cache.find(scenario);
  if (it != cache.end())
    return it->second;
  Recording r;
  r.rig = sim::DefaultRig();
  const auto traj = sim::MakeTrajectory(sim::ParseScenario(scenario), sim::SceneFor(r.rig.target));
  const sim::RotatedTrajectory mounted(*traj, sim::ScenarioMount(r.rig));
  sim::SimOptions options;
  options.duration = kDuration;
  options.seed = 7;
  const sim::SimulatedDataset sim = sim::Simulate(r.rig, mounted, options);
  for (const sim::InertialData& d : sim.inertial) {
    SensorData& out = r.data[d.sensor];
    for (const sim::InertialSample& m : d.samples) {
      if (d.has_accel)
        out.imu.push_back({m.t_ns, m.w_m, m.a_m});
      else
        out.gyro.push_back({m.t_ns, m.w_m});
    }
  }
  const auto& base = r.data.at(r.rig.base_imu).imu;
  r.t_first = 1e-9 * static_cast<double>(base.front().t_ns);
  r.t_last = 1e-9 * static_cast<double>(base.back().t_ns);
  AnalyseMotion(r.rig, r.data, MotionOptions{}, &r.observability);
  return cache.emplace(scenario, std::move(r)).first->second;
}

std::vector<MotionPrimitive> Whole(const Recording& r, const std::string& sensor) {
  std::vector<MotionPrimitive> out;
  for (const MotionPrimitive& p : r.observability.motion)
    if (p.sensor == sensor && p.t0 <= r.t_first + 0.01 && p.t1 >= r.t_last - 0.01)
      out.push_back(p);
  return out;
}

const MotionPrimitive* FindPrimitive(const std::vector<MotionPrimitive>& list,
                                     const std::string& primitive,
                                     const Eigen::Vector3d& axis = Eigen::Vector3d::Zero()) {
  for (const MotionPrimitive& p : list) {
    if (p.primitive != primitive)
      continue;
    // Within 3 deg of the expected axis (the sensors' axes are misaligned by < 1 deg).
    if (axis.norm() == 0.0 || std::abs(p.axis.normalized().dot(axis)) > std::cos(3.0 * M_PI / 180))
      return &p;
  }
  return nullptr;
}

bool Predicted(const Recording& r, const std::string& name) {
  const auto& v = r.observability.predicted_unobservable;
  return std::find(v.begin(), v.end(), name) != v.end();
}

std::string Describe(const std::vector<MotionPrimitive>& list) {
  std::string s;
  for (const MotionPrimitive& p : list)
    s += "  " + p.sensor + " " + p.primitive + " [" + std::to_string(p.axis.x()) + ", " +
         std::to_string(p.axis.y()) + ", " + std::to_string(p.axis.z()) + "] " +
         std::to_string(p.t0) + "-" + std::to_string(p.t1) + "\n";
  return s;
}

std::string Describe(const MotionDetection& d) {
  return "whole:\n" + Describe(d.whole) + "segments:\n" + Describe(d.segments);
}

std::string Describe(const Recording& r) {
  std::string s = "motion:\n" + Describe(r.observability.motion) + "predicted:";
  for (const std::string& n : r.observability.predicted_unobservable)
    s += " " + n;
  return s;
}

TEST(ObservabilityMotion, YawFindsOneAxisRotationAboutBaseZ) {
  const Recording& r = Simulated("yaw");
  SCOPED_TRACE(Describe(r));
  const auto whole = Whole(r, "imu0");
  const MotionPrimitive* p = FindPrimitive(whole, kOneAxisRotation, Eigen::Vector3d::UnitZ());
  ASSERT_NE(p, nullptr);
  EXPECT_NEAR(p->t0, r.t_first, 1e-9);
  EXPECT_NEAR(p->t1, r.t_last, 1e-9);
  // Table I's reading of the same motion: raw w_x and w_y constant.
  EXPECT_NE(FindPrimitive(whole, kConstantAngularVelocity, Eigen::Vector3d::UnitX()), nullptr);
  EXPECT_NE(FindPrimitive(whole, kConstantAngularVelocity, Eigen::Vector3d::UnitY()), nullptr);
  EXPECT_EQ(FindPrimitive(whole, kNoRotation), nullptr);
  EXPECT_EQ(FindPrimitive(whole, kPlanar), nullptr);  // the yaw scenario moves in 3-D
  // gyro0 is turned 90 deg about x_B: it rotates about its own y axis (within its 1 deg tilt).
  EXPECT_NE(FindPrimitive(Whole(r, "gyro0"), kOneAxisRotation, Eigen::Vector3d::UnitY()), nullptr);

  for (const char* name : {"imu0.Dw[0]", "imu0.Dw[1]", "imu0.Dw[2]", "imu1.t_B_S[2]",
                           "cam0.t_B_S[2]", "cam1.t_B_S[2]", "gyro0.R_B_S[2]"})
    EXPECT_TRUE(Predicted(r, name)) << name;
  for (const char* name : {"imu0.Dw[5]", "imu0.Da[0]", "imu0.Tg[0]", "imu1.t_B_S[0]",
                           "cam0.t_B_S[1]", "gyro0.R_B_S[0]", "cam0.time_offset"})
    EXPECT_FALSE(Predicted(r, name)) << name;
}

TEST(ObservabilityMotion, PlanarFindsPlaneNormalToBaseZ) {
  const Recording& r = Simulated("planar");
  SCOPED_TRACE(Describe(r));
  EXPECT_NE(FindPrimitive(Whole(r, "imu0"), kPlanar, Eigen::Vector3d::UnitZ()), nullptr);
  EXPECT_TRUE(Predicted(r, "imu1.t_B_S[2]"));
  EXPECT_TRUE(Predicted(r, "imu0.Da[3]"));  // constant specific force along z: D_a column z
}

TEST(ObservabilityMotion, NoRotationFindsNoRotation) {
  const Recording& r = Simulated("no-rotation");
  SCOPED_TRACE(Describe(r));
  for (const char* sensor : {"imu0", "imu1", "gyro0"})
    EXPECT_NE(FindPrimitive(Whole(r, sensor), kNoRotation), nullptr) << sensor;
  EXPECT_EQ(FindPrimitive(Whole(r, "imu0"), kConstantSpecificForce), nullptr);
  for (const char* name :
       {"imu1.t_B_S[0]", "imu1.t_B_S[1]", "imu1.t_B_S[2]", "cam0.t_B_S[0]", "cam0.t_B_S[2]",
        "cam1.t_B_S[1]", "gyro0.R_B_S[0]", "gyro0.R_B_S[1]", "gyro0.R_B_S[2]", "gyro0.time_offset",
        "imu0.Dw[0]", "imu0.Dw[5]", "imu1.Dw[3]", "gyro0.Dw[4]"})
    EXPECT_TRUE(Predicted(r, name)) << name;
  for (const char* name : {"imu0.Da[0]", "imu1.Da[5]", "imu1.time_offset", "cam0.time_offset",
                           "cam0.R_B_S[0]", "cam0.intrinsics[0]"})
    EXPECT_FALSE(Predicted(r, name)) << name;
}

TEST(ObservabilityMotion, ConstAccelXFindsConstantSpecificForceAlongX) {
  const Recording& r = Simulated("const-accel-x");
  SCOPED_TRACE(Describe(r));
  EXPECT_NE(FindPrimitive(Whole(r, "imu0"), kConstantSpecificForce, Eigen::Vector3d::UnitX()),
            nullptr);
  for (const char* name : {"imu0.Da[0]", "imu0.Tg[0]", "imu0.Tg[3]", "imu0.Tg[6]"})
    EXPECT_TRUE(Predicted(r, name)) << name;
  for (const char* name : {"imu0.Da[2]", "imu0.Tg[1]", "imu0.Dw[0]", "cam0.t_B_S[2]"})
    EXPECT_FALSE(Predicted(r, name)) << name;
}

TEST(ObservabilityMotion, FullFindsNothing) {
  const Recording& r = Simulated("full");
  SCOPED_TRACE(Describe(r));
  for (const char* sensor : {"imu0", "imu1", "gyro0"})
    EXPECT_TRUE(Whole(r, sensor).empty());
  EXPECT_TRUE(r.observability.predicted_unobservable.empty());
}

TEST(ObservabilityMotion, StaticFindsNoRotationAndConstantSpecificForce) {
  const Recording& r = Simulated("static");
  SCOPED_TRACE(Describe(r));
  const auto whole = Whole(r, "imu0");
  EXPECT_NE(FindPrimitive(whole, kNoRotation), nullptr);
  for (int j = 0; j < 3; ++j)
    EXPECT_NE(FindPrimitive(whole, kConstantSpecificForce, Eigen::Vector3d::Unit(j)), nullptr) << j;
  // No rotation implies every angular-velocity primitive; they are not repeated.
  EXPECT_EQ(FindPrimitive(whole, kConstantAngularVelocity), nullptr);
  EXPECT_EQ(FindPrimitive(whole, kOneAxisRotation), nullptr);
  for (const char* name : {"imu0.Dw[0]", "imu0.Da[0]", "imu0.Da[5]", "imu0.Tg[8]", "cam0.t_B_S[0]"})
    EXPECT_TRUE(Predicted(r, name)) << name;
}

// A synthetic sensor at 200 Hz with the default rig's noise: white noise of density * sqrt(rate)
// per sample and biases that walk.
struct NoisySensor {
  InertialNoise noise;
  std::mt19937_64 rng;
  std::normal_distribution<double> n01{0.0, 1.0};
  Eigen::Vector3d b_g, b_a;

  explicit NoisySensor(std::uint64_t seed) : rng(seed) {
    noise.gyroscope_noise_density = 1.6968e-04;
    noise.gyroscope_random_walk = 1.9393e-05;
    noise.accelerometer_noise_density = 2.0e-3;
    noise.accelerometer_random_walk = 3.0e-3;
    noise.update_rate = 200.0;
    b_g = 0.005 * Gauss();
    b_a = 0.05 * Gauss();
  }
  Eigen::Vector3d Gauss() { return {n01(rng), n01(rng), n01(rng)}; }

  // Readings of the true w and a (functions of time) over [t0, t0 + duration).
  void Append(double t0, double duration, const std::function<Eigen::Vector3d(double)>& w,
              const std::function<Eigen::Vector3d(double)>& a, InertialSeries* s) {
    const double dt = 1.0 / noise.update_rate;
    for (double t = t0; t < t0 + duration - 0.5 * dt; t += dt) {
      s->t.push_back(t);
      s->w_m.push_back(w(t) + b_g + noise.GyroSampleSigma() * Gauss());
      s->a_m.push_back(a(t) + b_a + noise.AccelSampleSigma() * Gauss());
      b_g += noise.GyroBiasSigma(dt) * Gauss();
      b_a += noise.AccelBiasSigma(dt) * Gauss();
    }
    s->noise = noise;
  }
};

const Eigen::Vector3d kGravityUp(0.3, -0.2, 9.8);  // a tilted, resting accelerometer

TEST(ObservabilityMotion, PureNoiseIsNotExcitation) {
  // 40 resting sensors of 20 s: every one must read as "no rotation, constant specific force on
  // every axis" over the whole recording (family-wise false-alarm probability 1e-3 per sensor).
  int failures = 0;
  for (std::uint64_t seed = 1; seed <= 40; ++seed) {
    NoisySensor sensor(seed);
    InertialSeries s;
    s.sensor = "imu" + std::to_string(seed);
    sensor.Append(
        1.0, 20.0, [](double) -> Eigen::Vector3d { return Eigen::Vector3d::Zero(); },
        [](double) -> Eigen::Vector3d { return kGravityUp; }, &s);
    const MotionDetection d = DetectMotionPrimitives(s);
    const bool ok = d.segments.empty() && FindPrimitive(d.whole, kNoRotation) &&
                    FindPrimitive(d.whole, kConstantSpecificForce, Eigen::Vector3d::UnitX()) &&
                    FindPrimitive(d.whole, kConstantSpecificForce, Eigen::Vector3d::UnitY()) &&
                    FindPrimitive(d.whole, kConstantSpecificForce, Eigen::Vector3d::UnitZ());
    if (!ok)
      ++failures;
  }
  EXPECT_EQ(failures, 0);
}

TEST(ObservabilityMotion, SmallExcitationAboveNoiseIsDetected) {
  // The power side of the test: a 0.5 Hz rotation about x of 10x the per-sample gyro noise and a
  // specific-force change along y of 10x the accelerometer's are not "constant"; the rest is
  // (x stays fixed and its specific force constant: planar motion about x).
  NoisySensor sensor(99);
  InertialSeries s;
  s.sensor = "imu0";
  const double w_amp = 10.0 * sensor.noise.GyroSampleSigma();
  const double a_amp = 10.0 * sensor.noise.AccelSampleSigma();
  sensor.Append(
      1.0, 20.0,
      [&](double t) -> Eigen::Vector3d {
        return Eigen::Vector3d(w_amp * std::sin(M_PI * t), 0, 0);
      },
      [&](double t) -> Eigen::Vector3d {
        return kGravityUp + Eigen::Vector3d(0, a_amp * std::sin(M_PI * t), 0);
      },
      &s);
  const MotionDetection d = DetectMotionPrimitives(s);
  SCOPED_TRACE(Describe(d));
  EXPECT_EQ(FindPrimitive(d.whole, kNoRotation), nullptr);
  EXPECT_EQ(FindPrimitive(d.whole, kConstantAngularVelocity, Eigen::Vector3d::UnitX()), nullptr);
  EXPECT_NE(FindPrimitive(d.whole, kPlanar, Eigen::Vector3d::UnitX()), nullptr);
  EXPECT_NE(FindPrimitive(d.whole, kConstantAngularVelocity, Eigen::Vector3d::UnitY()), nullptr);
  EXPECT_EQ(FindPrimitive(d.whole, kConstantSpecificForce, Eigen::Vector3d::UnitY()), nullptr);
  EXPECT_NE(FindPrimitive(d.whole, kConstantSpecificForce, Eigen::Vector3d::UnitX()), nullptr);
}

TEST(ObservabilityMotion, WindowsFindWhereEachPrimitiveHolds) {
  // 6 s at rest, 7 s rotating about x, 7 s about an oblique axis u, with varying rates and the
  // specific force varying on every axis while moving. No primitive holds over the whole
  // recording; the windows find each part to within a window (3 s). Rest lies on the x line, so
  // a window straddling rest and the rotation about x is still one-axis.
  NoisySensor sensor(5);
  InertialSeries s;
  s.sensor = "imu0";
  const Eigen::Vector3d u = Eigen::Vector3d(1.0, 2.0, 2.0) / 3.0;
  const auto moving = [](double t) -> Eigen::Vector3d {
    return kGravityUp + Eigen::Vector3d(2.0 * std::cos(1.3 * t), 1.5 * std::sin(0.7 * t),
                                        0.8 * std::sin(2.1 * t));
  };
  sensor.Append(
      1.0, 6.0, [](double) -> Eigen::Vector3d { return Eigen::Vector3d::Zero(); },
      [](double) -> Eigen::Vector3d { return kGravityUp; }, &s);
  sensor.Append(
      7.0, 7.0,
      [](double t) -> Eigen::Vector3d { return Eigen::Vector3d(std::sin(2.0 * t), 0.0, 0.0); },
      moving, &s);
  sensor.Append(
      14.0, 7.0, [&](double t) -> Eigen::Vector3d { return u * std::sin(2.0 * t); }, moving, &s);
  const MotionDetection d = DetectMotionPrimitives(s);
  SCOPED_TRACE(Describe(d));
  EXPECT_TRUE(d.whole.empty());
  const MotionPrimitive* rest = FindPrimitive(d.segments, kNoRotation);
  const MotionPrimitive* about_x =
      FindPrimitive(d.segments, kOneAxisRotation, Eigen::Vector3d::UnitX());
  const MotionPrimitive* about_u = FindPrimitive(d.segments, kOneAxisRotation, u);
  ASSERT_NE(rest, nullptr);
  ASSERT_NE(about_x, nullptr);
  ASSERT_NE(about_u, nullptr);
  EXPECT_NEAR(rest->t0, 1.0, 1e-9);
  EXPECT_GT(rest->t1, 7.0 - 3.0);
  EXPECT_LE(rest->t1, 7.0);
  EXPECT_LE(about_x->t0, 7.0);  // at rest the one-axis test does not hold (no rotation does)
  EXPECT_GT(about_x->t1, 14.0 - 3.0);
  EXPECT_LE(about_x->t1, 14.0);
  EXPECT_GE(about_u->t0, 14.0);
  EXPECT_LT(about_u->t0, 14.0 + 3.0);
  EXPECT_NEAR(about_u->t1, s.t.back(), 1e-9);
  EXPECT_GT(std::abs(about_u->axis.dot(u)), std::cos(1.0 * M_PI / 180));
  EXPECT_EQ(FindPrimitive(d.segments, kConstantSpecificForce, Eigen::Vector3d::UnitX())->t1,
            rest->t1);
}

TEST(ObservabilityMotion, BadInputIsOneClearError) {
  InertialSeries s;
  s.sensor = "gyro7";
  EXPECT_THROW(DetectMotionPrimitives(s), std::invalid_argument);
  NoisySensor sensor(1);
  sensor.Append(
      1.0, 1.0, [](double) -> Eigen::Vector3d { return Eigen::Vector3d::Zero(); },
      [](double) -> Eigen::Vector3d { return kGravityUp; }, &s);
  s.a_m.pop_back();
  try {
    DetectMotionPrimitives(s);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("gyro7"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ctcal
