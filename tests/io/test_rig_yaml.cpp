// Rig / result YAML of SPEC section 7: exact round trips, the keys-and-defaults table, and the
// checks a rig must pass.
#include <gtest/gtest.h>

#include <unistd.h>
#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>

#include "ctcal/sensors/number_format.h"
#include "ctcal/sensors/rig_yaml.h"
#include "io_test_util.h"

namespace ctcal {
namespace {

// Warnings of reads whose warnings are not under test.
std::vector<std::string> g_warnings;

const std::string kExample = std::string(CTCAL_SOURCE_DIR) + "/configs/example_rig.yaml";

// The message of reading `text` as `file`, or "(read without error)".
std::string ParseError(const std::string& text, const std::string& file) {
  try {
    ParseRigString(text, file, &g_warnings);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(read without error)";
}

constexpr char kMinimal[] = R"(
base_imu: imu0
target: {target_type: aprilgrid, tagCols: 6, tagRows: 6, tagSize: 0.088, tagSpacing: 0.3}
sensors:
  imu0:
    type: imu
    noise: {gyroscope_noise_density: 1.0e-4, gyroscope_random_walk: 1.0e-5,
            accelerometer_noise_density: 1.0e-3, accelerometer_random_walk: 1.0e-4,
            update_rate: 200}
  cam0:
    type: camera
    camera_model: pinhole
    intrinsics: [400, 400, 320, 240]
    resolution: [640, 480]
)";

using test::RandomDouble;

Eigen::Matrix3d RandomRotation(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized().toRotationMatrix();
}

Eigen::Matrix4d RandomPose(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = RandomRotation(rng);
  T.topRightCorner<3, 1>() = Eigen::Vector3d(n(rng), n(rng), n(rng));
  return T;
}

std::vector<double> RandomVector(std::mt19937_64& rng, int n) {
  std::vector<double> v(static_cast<std::size_t>(n));
  for (double& x : v)
    x = RandomDouble(rng);
  return v;
}

// A result file with every optional part filled with awkward numbers.
RigConfig RandomResult(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const RigConfig base = ParseRigString(kMinimal, "minimal", &g_warnings);
  RigConfig rig = base;
  rig.gravity_magnitude = 9.80665;
  rig.gravity_W = Eigen::Vector3d(RandomDouble(rng), RandomDouble(rng), -9.81);
  rig.sigma_gravity_W = Eigen::Vector3d(0.01, std::numeric_limits<double>::infinity(), 1e-300);
  SensorConfig& imu0 = rig.sensors[0];
  imu0.g_sensitivity = GSensitivity::kFull;
  imu0.D_w = RandomVector(rng, 6);
  imu0.D_a = RandomVector(rng, 6);
  imu0.T_g = RandomVector(rng, 9);
  imu0.R_I_a = RandomRotation(rng);
  imu0.estimate = {EstimateItem::kIntrinsics};
  imu0.sigma.values["Dw"] = {1e-3, std::numeric_limits<double>::infinity(), 0.0, 1e-9, 2.5, 3};
  imu0.sigma.values["R_I_a"] = {std::numeric_limits<double>::quiet_NaN(), 1e-4, 1e-4};
  imu0.rostopic = "/imu0";
  imu0.noise_estimated = imu0.noise;
  imu0.noise_estimated->gyroscope_noise_density = std::abs(RandomDouble(rng));
  imu0.noise_estimated->accelerometer_noise_density = std::abs(RandomDouble(rng));

  SensorConfig imu1 = imu0;
  imu1.name = "imu1";
  imu1.imu_model = ImuModel::kImu3;
  imu1.g_sensitivity = GSensitivity::kUpper;
  imu1.D_w = RandomVector(rng, 9);
  imu1.D_a = RandomVector(rng, 6);
  imu1.T_g = RandomVector(rng, 6);
  imu1.R_I_a.setIdentity();
  imu1.T_B_S = RandomPose(rng);
  imu1.time_offset = -0.0123456789012345678;
  imu1.estimate = {EstimateItem::kIntrinsics, EstimateItem::kExtrinsics, EstimateItem::kTimeOffset};
  imu1.sigma = {};
  imu1.prior_sigma.values["time_offset"] = {std::numeric_limits<double>::infinity()};
  imu1.prior_sigma.values["t_B_S"] = {0.01, 0.02, 0.03};
  imu1.rostopic.reset();
  imu1.noise_estimated.reset();
  rig.sensors.push_back(imu1);

  SensorConfig gyro;
  gyro.name = "gyro0";
  gyro.type = SensorType::kGyro;
  gyro.gyro_model = GyroModel::kFull;
  gyro.D_w = RandomVector(rng, 9);
  gyro.noise = rig.sensors[0].noise;  // imu0 dangles: the push_backs above reallocated
  gyro.noise.accelerometer_noise_density = 0.0;
  gyro.noise.accelerometer_random_walk = 0.0;
  gyro.T_B_S = RandomPose(rng);
  gyro.estimate = {EstimateItem::kIntrinsics, EstimateItem::kTimeOffset};
  gyro.sigma.values["Dw"] = RandomVector(rng, 9);
  for (double& x : gyro.sigma.values["Dw"])
    x = std::abs(x);
  rig.sensors.push_back(gyro);

  SensorConfig& cam0 = rig.sensors[1];
  cam0.camera_model = "ds";
  cam0.intrinsics = RandomVector(rng, 6);
  cam0.distortion_model = "none";
  cam0.line_delay = 3.1e-5;
  cam0.pixel_sigma = 0.35;
  cam0.pixel_sigma_estimated = 0.123456789012345678;
  cam0.T_B_S = RandomPose(rng);
  cam0.time_offset = 1e-17;
  cam0.estimate = {EstimateItem::kIntrinsics, EstimateItem::kExtrinsics, EstimateItem::kTimeOffset,
                   EstimateItem::kLineDelay};
  cam0.sigma.values["intrinsics"] = {0.1, 0.1, 0.2, 0.3, 0.4, 0.5};
  cam0.sigma.values["R_B_S"] = {1e-3, 2e-3, 3e-3};
  cam0.sigma.values["t_B_S"] = {1e-3, 2e-3, 3e-3};
  cam0.sigma.values["time_offset"] = {1e-5};
  cam0.sigma.values["line_delay"] = {std::numeric_limits<double>::infinity()};

  rig.solver = SolverSummary{"spline", 17, RandomDouble(rng), 12.5};
  SensorResiduals r_cam;
  r_cam.count = 123456789012;
  r_cam.rms_px = 0.31;
  r_cam.rms_whitened = 1.02;
  rig.residuals["cam0"] = r_cam;
  SensorResiduals r_imu;
  r_imu.count = 6000;
  r_imu.rms_gyro = 1e-3;
  r_imu.rms_accel = 2e-2;
  r_imu.rms_whitened_gyro = 0.99;
  r_imu.rms_whitened_accel = 1.01;
  rig.residuals["imu0"] = r_imu;
  Observability o;
  o.unobservable = {"cam0.line_delay"};
  o.weak = {"imu0.Tg[3]", "gravity_W[2]"};
  o.directions.push_back({1e-12, {{"cam0.line_delay", 0.99}, {"cam0.time_offset", -0.1}}});
  o.directions.push_back({3.5, {}});
  o.motion.push_back({"constant_velocity", "imu0", Eigen::Vector3d(0, 0, 1), 1.5, 2.25});
  o.predicted_unobservable = {"cam0.t_B_S[2]"};
  rig.observability = o;
  return rig;
}

TEST(NumberFormat, ShortestExactWithADotAndYamlNonFinites) {
  EXPECT_EQ(FormatDouble(9.81), "9.81");
  EXPECT_EQ(FormatDouble(1.0), "1.0");
  EXPECT_EQ(FormatDouble(2e-05), "2.0e-05");
  EXPECT_EQ(FormatDouble(-0.0), "-0.0");
  EXPECT_EQ(FormatDouble(std::numeric_limits<double>::infinity()), ".inf");
  EXPECT_EQ(FormatDouble(-std::numeric_limits<double>::infinity()), "-.inf");
  EXPECT_EQ(FormatDouble(std::numeric_limits<double>::quiet_NaN()), ".nan");
  for (const double x : {5e-324, std::numeric_limits<double>::min() / 3.0,
                         std::numeric_limits<double>::max(), -1.0 / 3.0, 0.1, -0.0, 1e300}) {
    double y = 0.0;
    ASSERT_TRUE(ParseDouble(FormatDouble(x), &y)) << FormatDouble(x);
    EXPECT_EQ(std::memcmp(&x, &y, sizeof(double)), 0) << FormatDouble(x);
  }
  double y = 0.0;
  EXPECT_TRUE(ParseDouble(".Inf", &y) && std::isinf(y) && y > 0);
  EXPECT_TRUE(ParseDouble("-.INF", &y) && std::isinf(y) && y < 0);
  EXPECT_TRUE(ParseDouble("+1.5e3", &y) && y == 1500.0);
  for (const char* bad : {"", "1.2.3", "1e", "abc", "1,5", " 1", "1e999", "+-1", "+", "+-.inf"})
    EXPECT_FALSE(ParseDouble(bad, &y)) << bad;
}

TEST(RigYaml, ExampleRigRoundTripIsExact) {
  std::vector<std::string> warnings;
  const RigConfig rig = LoadRig(kExample, &warnings);
  EXPECT_TRUE(warnings.empty());
  ASSERT_EQ(rig.sensors.size(), 4u);
  const std::string text = EmitRig(rig);
  const RigConfig again = ParseRigString(text, "emitted", &warnings);
  EXPECT_TRUE(again == rig);
  // Writing is deterministic: the second generation is the same text.
  EXPECT_EQ(EmitRig(again), text);
}

// Files written by other programs / by hand: every rig in configs/ and the shared EuRoC reference
// (block style, some optional keys absent) read, and round-trip exactly.
TEST(RigYaml, ConfigsAndSharedReferenceReadAndRoundTrip) {
  std::vector<std::string> paths;
  for (const auto& e :
       std::filesystem::directory_iterator(std::string(CTCAL_SOURCE_DIR) + "/configs")) {
    if (e.path().extension() == ".yaml")
      paths.push_back(e.path().string());
  }
  const std::string shared = std::string(CTCAL_SHARED_DATA_DIR) + "/euroc_cam_april/reference.yaml";
  if (std::filesystem::is_regular_file(shared))
    paths.push_back(shared);
  ASSERT_FALSE(paths.empty());
  for (const std::string& path : paths) {
    std::vector<std::string> warnings;
    const RigConfig rig = LoadRig(path, &warnings);
    EXPECT_TRUE(ParseRigString(EmitRig(rig), "emitted", &warnings) == rig) << path;
  }
}

TEST(RigYaml, RandomResultRoundTripIsExact) {
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const RigConfig rig = RandomResult(seed);
    std::vector<std::string> warnings;
    const RigConfig again = ParseRigString(EmitRig(rig), "emitted", &warnings);
    ASSERT_TRUE(again == rig) << "seed " << seed << "\n" << EmitRig(rig);
  }
}

TEST(RigYaml, EqualityDetectsAOneUlpChange) {
  const RigConfig rig = RandomResult(3);
  RigConfig changed = rig;
  changed.sensors[1].intrinsics[2] =
      std::nextafter(changed.sensors[1].intrinsics[2], std::numeric_limits<double>::infinity());
  EXPECT_FALSE(changed == rig);
  EXPECT_FALSE(ParseRigString(EmitRig(changed), "x", &g_warnings) == rig);
}

TEST(RigYaml, AbsentKeysTakeTheSpecDefaults) {
  std::vector<std::string> warnings;
  const RigConfig rig = ParseRigString(kMinimal, "minimal.yaml", &warnings);
  EXPECT_EQ(rig.gravity_magnitude, 9.81);
  const SensorConfig& imu = *rig.Find("imu0");
  EXPECT_EQ(imu.imu_model, ImuModel::kImu2);
  EXPECT_EQ(imu.g_sensitivity, GSensitivity::kNone);
  EXPECT_EQ(imu.D_w, (std::vector<double>{1, 0, 1, 0, 0, 1}));
  EXPECT_EQ(imu.D_a, (std::vector<double>{1, 0, 1, 0, 0, 1}));
  EXPECT_TRUE(imu.T_g.empty());
  EXPECT_EQ(imu.R_I_a, Eigen::Matrix3d::Identity());
  EXPECT_TRUE(imu.estimate.empty());
  EXPECT_TRUE(imu.prior_sigma.empty());
  EXPECT_FALSE(imu.rostopic.has_value());
  const SensorConfig& cam = *rig.Find("cam0");
  EXPECT_EQ(cam.distortion_model, "none");
  EXPECT_TRUE(cam.distortion_coeffs.empty());
  EXPECT_EQ(cam.line_delay, 0.0);
  EXPECT_EQ(cam.pixel_sigma, 1.0);
  EXPECT_EQ(cam.T_B_S, Eigen::Matrix4d::Identity());
  EXPECT_EQ(cam.time_offset, 0.0);
  EXPECT_EQ(cam.estimate,
            (std::set<EstimateItem>{EstimateItem::kExtrinsics, EstimateItem::kTimeOffset}));
  EXPECT_FALSE(rig.gravity_W.has_value());
  EXPECT_FALSE(rig.solver.has_value());
  EXPECT_FALSE(rig.observability.has_value());
  // T_B_S absent on a non-base sensor: one warning naming the sensor.
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("minimal.yaml"), std::string::npos);
  EXPECT_NE(warnings[0].find("sensors.cam0"), std::string::npos);
  EXPECT_NE(warnings[0].find("give a guess"), std::string::npos);
}

TEST(RigYaml, ModelDefaultsHaveTheModelsCounts) {
  const std::string text = R"(
base_imu: a
target: {target_type: checkerboard, targetCols: 7, targetRows: 6, rowSpacingMeters: 0.03,
         colSpacingMeters: 0.03}
sensors:
  a: {type: imu, model: imu3, g_sensitivity: upper,
      noise: {gyroscope_noise_density: 1, gyroscope_random_walk: 1,
              accelerometer_noise_density: 1, accelerometer_random_walk: 1, update_rate: 100}}
  b: {type: imu, model: imu4, g_sensitivity: full, T_B_S: [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]],
      noise: {gyroscope_noise_density: 1, gyroscope_random_walk: 1,
              accelerometer_noise_density: 1, accelerometer_random_walk: 1, update_rate: 100}}
  g: {type: gyro, model: full, T_B_S: [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]],
      noise: {gyroscope_noise_density: 1, gyroscope_random_walk: 1, update_rate: 100}}
  c: {type: gyro, model: none, T_B_S: [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]],
      noise: {gyroscope_noise_density: 1, gyroscope_random_walk: 1, update_rate: 100}}
)";
  const RigConfig rig = ParseRigString(text, "models", &g_warnings);
  EXPECT_EQ(rig.Find("a")->D_w, (std::vector<double>{1, 0, 0, 0, 1, 0, 0, 0, 1}));
  EXPECT_EQ(rig.Find("a")->D_a.size(), 6u);
  EXPECT_EQ(rig.Find("a")->T_g, std::vector<double>(6, 0.0));
  EXPECT_EQ(rig.Find("b")->D_w.size(), 6u);
  EXPECT_EQ(rig.Find("b")->D_a.size(), 9u);
  EXPECT_EQ(rig.Find("b")->T_g, std::vector<double>(9, 0.0));
  EXPECT_EQ(rig.Find("g")->D_w.size(), 9u);
  EXPECT_TRUE(rig.Find("c")->D_w.empty());
  EXPECT_TRUE(ParseRigString(EmitRig(rig), "again", &g_warnings) == rig);
}

TEST(RigYaml, BlockAndFlowStyleReadAlike) {
  const std::string block = R"(
base_imu: imu0
target:
  target_type: aprilgrid
  tagCols: 6
  tagRows: 6
  tagSize: 0.088
  tagSpacing: 0.3
sensors:
  imu0:
    type: imu
    noise:
      gyroscope_noise_density: 1.0e-4
      gyroscope_random_walk: 1.0e-5
      accelerometer_noise_density: 1.0e-3
      accelerometer_random_walk: 1.0e-4
      update_rate: 200
  cam0:
    type: camera
    camera_model: pinhole
    intrinsics:
      - 400
      - 400
      - 320
      - 240
    resolution:
      - 640
      - 480
)";
  EXPECT_TRUE(ParseRigString(block, "block", &g_warnings) ==
              ParseRigString(kMinimal, "flow", &g_warnings));
}

TEST(RigYaml, SigmaReadsInfAndNanAsYamlWritesThem) {
  std::string text = kMinimal;
  text += R"(    T_B_S: [[1,0,0,0.1],[0,1,0,0],[0,0,1,0],[0,0,0,1]]
    sigma: {R_B_S: [.inf, .Inf, 0.001], t_B_S: [.nan, 1e-3, 2.0e-3], time_offset: .INF}
)";
  const RigConfig rig = ParseRigString(text, "sigma", &g_warnings);
  const std::vector<double>& r = *rig.Find("cam0")->sigma.Find("R_B_S");
  EXPECT_TRUE(std::isinf(r[0]) && std::isinf(r[1]));
  EXPECT_EQ(r[2], 0.001);
  EXPECT_TRUE(std::isnan(rig.Find("cam0")->sigma.Find("t_B_S")->at(0)));
  EXPECT_TRUE(std::isinf(rig.Find("cam0")->sigma.Find("time_offset")->at(0)));
  const std::string out = EmitRig(rig);
  EXPECT_NE(out.find(".inf"), std::string::npos);
  EXPECT_NE(out.find(".nan"), std::string::npos);
}

// SPEC section 2: "Timestamps in files are integer nanoseconds", so a motion window's t0 / t1
// are written as integers (base clock) and a number with a fraction is refused. (In memory they
// are seconds, which resolve 0.24 us at unix-epoch stamps; the values here are exact.)
TEST(RigYaml, MotionWindowsAreIntegerNanosecondsInFiles) {
  RigConfig rig = RandomResult(1);
  rig.observability->motion = {
      {"one_axis_rotation", "imu0", Eigen::Vector3d(0, 0, 1), 1.5, 1'700'000'000.5}};
  const std::string text = EmitRig(rig);
  EXPECT_NE(text.find("t0: 1500000000,"), std::string::npos) << text;
  EXPECT_NE(text.find("t1: 1700000000500000000}"), std::string::npos) << text;
  EXPECT_TRUE(ParseRigString(text, "emitted", &g_warnings) == rig);

  std::string seconds = text;
  seconds.replace(seconds.find("t0: 1500000000,"), 15, "t0: 1.5,");
  const std::string error = ParseError(seconds, "result.yaml");
  EXPECT_NE(error.find("result.yaml:"), std::string::npos) << error;
  EXPECT_NE(error.find("observability.motion.t0 (integer nanoseconds)"), std::string::npos)
      << error;
}

// SPEC section 7 gives every sensor's T_B_S the sigma keys R_B_S and t_B_S; a gyroscope's
// position enters no measurement, so its t_B_S (as a SPEC-literal writer gives it) is checked
// and ignored, with a warning when it would have been a prior.
TEST(RigYaml, GyroSigmaAndPriorMayCarryATranslation) {
  std::string text = kMinimal;
  text += R"(    T_B_S: [[1,0,0,0.1],[0,1,0,0],[0,0,1,0],[0,0,0,1]]
  gyro0:
    type: gyro
    noise: {gyroscope_noise_density: 1.0e-4, gyroscope_random_walk: 1.0e-5, update_rate: 200}
    T_B_S: [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]
    prior_sigma: {R_B_S: [0.01, 0.01, 0.01], t_B_S: [0.01, 0.01, 0.01], time_offset: 0.01}
    sigma: {R_B_S: [0.001, 0.001, 0.001], t_B_S: [.inf, .inf, .inf], time_offset: 1.0e-5}
)";
  std::vector<std::string> warnings;
  const RigConfig rig = ParseRigString(text, "gyro.yaml", &warnings);
  const SensorConfig& gyro = *rig.Find("gyro0");
  EXPECT_EQ(gyro.prior_sigma.Find("t_B_S"), nullptr);
  EXPECT_EQ(gyro.sigma.Find("t_B_S"), nullptr);
  EXPECT_EQ(*gyro.prior_sigma.Find("R_B_S"), (std::vector<double>{0.01, 0.01, 0.01}));
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("sensors.gyro0.prior_sigma.t_B_S: ignored"), std::string::npos)
      << warnings[0];

  std::string bad = text;
  bad.replace(bad.find("t_B_S: [0.01, 0.01, 0.01]"), 25, "t_B_S: [0.01, 0.01]");
  const std::string error = ParseError(bad, "gyro.yaml");
  EXPECT_NE(error.find("sensors.gyro0.prior_sigma.t_B_S"), std::string::npos) << error;
}

// SPEC section 3: a gyro's noise block may be a whole Kalibr imu.yaml block; its accelerometer
// keys (and rostopic) are ignored with one warning, the gyroscope's are read. Another key is
// still an error.
TEST(RigYaml, GyroNoiseMayBeAWholeKalibrImuBlock) {
  std::string text = kMinimal;
  text += R"(    T_B_S: [[1,0,0,0.1],[0,1,0,0],[0,0,1,0],[0,0,0,1]]
  gyro0:
    type: gyro
    noise:
      accelerometer_noise_density: 1.86e-03
      accelerometer_random_walk: 4.33e-04
      gyroscope_noise_density: 1.87e-04
      gyroscope_random_walk: 2.66e-05
      rostopic: /imu0
      update_rate: 200.0
    T_B_S: [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]
)";
  std::vector<std::string> warnings;
  const RigConfig rig = ParseRigString(text, "gyro.yaml", &warnings);
  const SensorConfig& gyro = *rig.Find("gyro0");
  EXPECT_EQ(gyro.noise.gyroscope_noise_density, 1.87e-04);
  EXPECT_EQ(gyro.noise.gyroscope_random_walk, 2.66e-05);
  EXPECT_EQ(gyro.noise.update_rate, 200.0);
  EXPECT_EQ(gyro.noise.accelerometer_noise_density, 0.0);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("sensors.gyro0.noise: accelerometer_noise_density, "
                             "accelerometer_random_walk, rostopic ignored"),
            std::string::npos)
      << warnings[0];
  std::string bad = text;
  bad.replace(bad.find("rostopic: /imu0"), 15, "magnetometer: 1");
  const std::string error = ParseError(bad, "gyro.yaml");
  EXPECT_NE(error.find("unknown key 'magnetometer'"), std::string::npos) << error;
}

// SPEC section 7: T_B_S and time_offset are for "all but the base". A file that spells out the
// base's definition (identity, 0) reads as the file without them; another value is an error.
TEST(RigYaml, BaseMayStateItsIdentityExtrinsicAndZeroOffset) {
  std::string text = kMinimal;
  const RigConfig plain = ParseRigString(text, "plain.yaml", &g_warnings);
  const std::string base_keys = "            update_rate: 200}\n";
  text.replace(text.find(base_keys), base_keys.size(),
               base_keys +
                   "    T_B_S: [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, "
                   "0.0], [0.0, 0.0, 0.0, 1.0]]\n    time_offset: 0.0\n");
  const RigConfig stated = ParseRigString(text, "stated.yaml", &g_warnings);
  EXPECT_TRUE(stated == plain);
  const std::string emitted = EmitRig(stated);  // only cam0 carries the two keys
  EXPECT_EQ(emitted.find("time_offset:"), emitted.rfind("time_offset:")) << emitted;
  EXPECT_EQ(emitted.find("T_B_S:"), emitted.rfind("T_B_S:")) << emitted;

  std::string shifted = text;
  shifted.replace(shifted.find("time_offset: 0.0"), 16, "time_offset: 0.001");
  const std::string error = ParseError(shifted, "shifted.yaml");
  EXPECT_NE(error.find("shifted.yaml:"), std::string::npos) << error;
  EXPECT_NE(error.find("sensors.imu0"), std::string::npos) << error;
  EXPECT_NE(error.find("time_offset is not allowed on the base"), std::string::npos) << error;
}

// A drawing's rotation rounded to 4 decimals is taken as the nearest rotation with a warning
// naming the file, line and key; an exact one is kept bit for bit; a matrix further from a
// rotation than 1e-3 stays an error.
TEST(RigYaml, RoundedRotationIsTakenAsTheNearestWithAWarning) {
  std::string text = kMinimal;
  text +=
      "    T_B_S: [[0.9962, -0.0872, 0, 0.1], [0.0872, 0.9962, 0, 0], [0, 0, 1, 0], [0, 0, 0, "
      "1]]\n";
  std::vector<std::string> warnings;
  const RigConfig rig = ParseRigString(text, "drawing.yaml", &warnings);
  const Eigen::Matrix3d R = rig.Find("cam0")->T_B_S.topLeftCorner<3, 3>();
  EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  EXPECT_NEAR(R(0, 0), 0.9962, 1e-4);
  EXPECT_NEAR(R(1, 0), 0.0872, 1e-4);
  EXPECT_EQ(rig.Find("cam0")->T_B_S(0, 3), 0.1);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("drawing.yaml:15: warning: sensors.cam0.T_B_S: rotation not "
                             "orthonormal"),
            std::string::npos)
      << warnings[0];

  std::string far = text;
  far.replace(far.find("0.9962, -0.0872"), 15, "0.9862, -0.0872");
  const std::string error = ParseError(far, "far.yaml");
  EXPECT_NE(error.find("far.yaml:15:"), std::string::npos) << error;
  EXPECT_NE(error.find("not a rigid transform"), std::string::npos) << error;
}

TEST(RigYaml, CameraOnlyRigHasNoTimeOffsets) {
  const std::string text = R"(
base_imu: left
target: {target_type: aprilgrid, tagCols: 6, tagRows: 6, tagSize: 0.088, tagSpacing: 0.3}
sensors:
  left: {type: camera, camera_model: pinhole, intrinsics: [400, 400, 320, 240], resolution: [640, 480]}
  right: {type: camera, camera_model: pinhole, intrinsics: [400, 400, 320, 240], resolution: [640, 480],
          T_B_S: [[1,0,0,0.1],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}
)";
  const RigConfig rig = ParseRigString(text, "stereo", &g_warnings);
  EXPECT_TRUE(rig.IsCameraOnly());
  EXPECT_EQ(rig.Find("right")->estimate, std::set<EstimateItem>{EstimateItem::kExtrinsics});
  std::string with_offset = text;
  with_offset.insert(with_offset.rfind("]]}") + 2, ", estimate: [extrinsics, time_offset]");
  try {
    ParseRigString(with_offset, "stereo.yaml", &g_warnings);
    FAIL() << "time_offset estimated in a camera-only rig";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("sensors.right"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("time_offset"), std::string::npos) << e.what();
  }
}

TEST(RigYaml, WriterRefusesAnInvalidRig) {
  RigConfig rig = ParseRigString(kMinimal, "minimal", &g_warnings);
  rig.sensors[1].T_B_S(0, 0) = 2.0;  // not a rotation
  EXPECT_THROW(EmitRig(rig), std::runtime_error);
  rig = ParseRigString(kMinimal, "minimal", &g_warnings);
  rig.sensors[0].D_w = {1, 0, 1};  // wrong count for imu2
  EXPECT_THROW(EmitRig(rig), std::runtime_error);
  rig = ParseRigString(kMinimal, "minimal", &g_warnings);
  rig.base_imu = "cam0";  // a camera cannot be the base of a rig with an IMU
  EXPECT_THROW(EmitRig(rig), std::runtime_error);
}

TEST(RigYaml, SaveAndLoadThroughAFile) {
  const RigConfig rig = RandomResult(7);
  const std::string path =
      ::testing::TempDir() + "/ctcal_rig_roundtrip_" + std::to_string(getpid()) + ".yaml";
  SaveRig(rig, path);
  std::vector<std::string> warnings;
  EXPECT_TRUE(LoadRig(path, &warnings) == rig);
  EXPECT_THROW(LoadRig(path + ".missing", &warnings), std::runtime_error);
}

}  // namespace
}  // namespace ctcal
