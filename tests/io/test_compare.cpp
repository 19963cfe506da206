// Parameter names of SPEC section 7 and `ctcal compare`'s core (sensors/compare.h).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "ctcal/sensors/compare.h"
#include "ctcal/sensors/parameter_names.h"
#include "ctcal/sensors/rig_yaml.h"
#include "ctcal/spline/so3.h"

namespace ctcal {
namespace {

const std::string kExample = std::string(CTCAL_SOURCE_DIR) + "/configs/example_rig.yaml";

RigConfig Example() {
  std::vector<std::string> warnings;
  RigConfig rig = LoadRig(kExample, &warnings);
  rig.gravity_W = Eigen::Vector3d(0.1, -0.2, -9.8);
  return rig;
}

std::vector<std::string> Names(const std::vector<ScalarParameter>& ps) {
  std::vector<std::string> names;
  for (const ScalarParameter& p : ps)
    names.push_back(p.name);
  return names;
}

bool Has(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

TEST(ParameterNames, SpecExamplesExistAndCountsFollowTheModels) {
  const RigConfig rig = Example();
  const std::vector<std::string> all = Names(ScalarParameters(rig, false));
  for (const char* name :
       {"imu0.Dw[0]", "imu0.Da[5]", "imu0.Tg[8]", "imu0.R_I_a[0]", "imu1.R_I_w[2]", "imu1.t_B_S[2]",
        "imu1.time_offset", "gyro0.R_B_S[2]", "gyro0.Dw[5]", "cam0.intrinsics[2]",
        "cam0.distortion_coeffs[1]", "cam0.line_delay", "cam0.time_offset", "gravity_W[1]"}) {
    EXPECT_TRUE(Has(all, name)) << name;
  }
  // The base has no extrinsics; a gyro has no position; imu2 has no R_I_w.
  EXPECT_FALSE(Has(all, "imu0.R_B_S[0]"));
  EXPECT_FALSE(Has(all, "imu0.time_offset"));
  EXPECT_FALSE(Has(all, "gyro0.t_B_S[0]"));
  EXPECT_FALSE(Has(all, "imu0.R_I_w[0]"));
  EXPECT_FALSE(Has(all, "gyro0.Dw[6]"));
  // imu0: Dw 6 + Da 6 + Tg 9 + R_I_a 3; imu1: 6+6+3 + R_B_S, t_B_S, time_offset 7;
  // gyro0: 6 + 3 + 1; cam0: 4 + 4 + 1 + 7; gravity 3.
  EXPECT_EQ(all.size(), 24u + 22u + 10u + 16u + 3u);
  // Only the estimate sets: cam0 does not estimate its line delay.
  const std::vector<std::string> est = Names(ScalarParameters(rig, true));
  EXPECT_FALSE(Has(est, "cam0.line_delay"));
  EXPECT_TRUE(Has(est, "cam0.intrinsics[0]"));
  EXPECT_EQ(est.size(), all.size() - 1);
}

TEST(ParameterNames, AccessorsReturnTheStoredValues) {
  RigConfig rig = Example();
  SensorConfig& cam = *rig.Find("cam0");
  cam.sigma.values["t_B_S"] = {1e-3, 2e-3, std::numeric_limits<double>::infinity()};
  rig.sigma_gravity_W = Eigen::Vector3d(0.01, 0.02, 0.03);
  auto value = [&](const std::string& n) { return ParameterValue(rig, *FindParameter(rig, n)); };
  auto sigma = [&](const std::string& n) { return ParameterSigma(rig, *FindParameter(rig, n)); };
  EXPECT_EQ(value("cam0.intrinsics[2]"), 367.215);
  EXPECT_EQ(value("cam0.distortion_coeffs[3]"), 1.76187114e-05);
  EXPECT_EQ(value("cam0.t_B_S[1]"), -0.064676986768);
  EXPECT_EQ(value("imu1.t_B_S[0]"), 0.05);
  EXPECT_EQ(value("imu0.Dw[2]"), 1.0);
  EXPECT_EQ(value("gravity_W[2]"), -9.8);
  EXPECT_EQ(*sigma("cam0.t_B_S[1]"), 2e-3);
  EXPECT_TRUE(std::isinf(*sigma("cam0.t_B_S[2]")));
  EXPECT_FALSE(sigma("cam0.t_B_S[0]") == std::nullopt);
  EXPECT_FALSE(sigma("cam0.intrinsics[0]").has_value());
  EXPECT_EQ(*sigma("gravity_W[1]"), 0.02);
  EXPECT_EQ(*ParameterPriorSigma(rig, *FindParameter(rig, "cam0.time_offset")), 0.01);
  // A rotation component is the component of Log(R).
  const Eigen::Matrix3d R = cam.T_B_S.topLeftCorner<3, 3>();
  const Eigen::Vector3d phi = LogSO3<double>(Eigen::Quaterniond(R));
  EXPECT_EQ(value("cam0.R_B_S[1]"), phi(1));
  EXPECT_FALSE(FindParameter(rig, "cam0.intrinsics[4]").has_value());
  EXPECT_FALSE(FindParameter(rig, "cam7.time_offset").has_value());
}

TEST(Compare, AFileWithItselfHasAllErrorsExactlyZero) {
  RigConfig rig = Example();
  for (SensorConfig& s : rig.sensors) {
    for (const ParameterKey& k : SensorParameterKeys(rig, s))
      s.sigma.values[k.key] = std::vector<double>(static_cast<std::size_t>(k.size), 0.5);
  }
  rig.sigma_gravity_W = Eigen::Vector3d(0.1, 0.1, 0.1);
  const Comparison c = CompareRigs(rig, rig);
  ASSERT_EQ(c.rows.size(), ScalarParameters(rig, true).size());
  for (const ComparisonRow& r : c.rows) {
    EXPECT_EQ(r.error, 0.0) << r.name;
    EXPECT_EQ(*r.error_over_sigma, 0.0) << r.name;
  }
  for (const RotationComparison& r : c.rotations)
    EXPECT_EQ(r.angle_deg, 0.0) << r.name;
  EXPECT_EQ(c.summary.count, static_cast<int>(c.rows.size()));
  EXPECT_EQ(c.summary.with_sigma, c.summary.count);
  EXPECT_EQ(*c.summary.fraction_within_3_sigma, 1.0);
}

TEST(Compare, RotationErrorIsTheLeftPerturbationAndVectorsSubtract) {
  const RigConfig truth = Example();
  RigConfig result = truth;
  SensorConfig& cam = *result.Find("cam0");
  const Eigen::Vector3d dtheta(1e-3, -2e-3, 0.5e-3);
  const Eigen::Matrix3d R_true = truth.Find("cam0")->T_B_S.topLeftCorner<3, 3>();
  cam.T_B_S.topLeftCorner<3, 3>() = ExpSO3<double>(dtheta).toRotationMatrix() * R_true;
  cam.T_B_S(2, 3) += 0.004;
  cam.intrinsics[0] += 1.5;
  cam.time_offset = 2e-4;
  cam.sigma.values["R_B_S"] = {1e-3, 1e-3, std::numeric_limits<double>::infinity()};
  cam.sigma.values["t_B_S"] = {1e-3, 1e-3, 1e-3};
  cam.sigma.values["intrinsics"] = {0.5, 0.5, 0.5, 0.5};
  // An IMU's own rotation compares alike.
  SensorConfig& imu = *result.Find("imu0");
  const Eigen::Vector3d dI(0.0, 0.0, 0.01);
  imu.R_I_a = ExpSO3<double>(dI).toRotationMatrix() * truth.Find("imu0")->R_I_a;

  const Comparison c = CompareRigs(truth, result);
  auto row = [&](const std::string& name) {
    for (const ComparisonRow& r : c.rows) {
      if (r.name == name)
        return r;
    }
    ADD_FAILURE() << "no row " << name;
    return ComparisonRow{};
  };
  for (int i = 0; i < 3; ++i) {
    const ComparisonRow r = row("cam0.R_B_S[" + std::to_string(i) + "]");
    EXPECT_EQ(r.truth, 0.0);
    EXPECT_NEAR(r.error, dtheta(i), 1e-12);
    EXPECT_EQ(r.estimate, r.error);
    EXPECT_TRUE(r.rotation);
  }
  EXPECT_NEAR(row("imu0.R_I_a[2]").error, 0.01, 1e-12);
  EXPECT_NEAR(row("imu0.R_I_a[0]").error, 0.0, 1e-14);
  EXPECT_NEAR(*row("cam0.R_B_S[0]").error_over_sigma, 1.0, 1e-9);
  EXPECT_FALSE(row("cam0.R_B_S[2]").error_over_sigma.has_value());  // sigma .inf: undetermined
  EXPECT_NEAR(row("cam0.t_B_S[2]").error, 0.004, 1e-15);
  EXPECT_NEAR(*row("cam0.t_B_S[2]").error_over_sigma, 4.0, 1e-9);
  EXPECT_EQ(row("cam0.intrinsics[0]").error, 1.5);
  EXPECT_EQ(row("cam0.intrinsics[0]").truth, 458.654);
  EXPECT_EQ(*row("cam0.intrinsics[0]").error_over_sigma, 3.0);
  EXPECT_EQ(row("cam0.time_offset").error, 2e-4);
  EXPECT_FALSE(row("cam0.time_offset").sigma.has_value());
  bool found = false;
  for (const RotationComparison& r : c.rotations) {
    if (r.name == "cam0.R_B_S") {
      found = true;
      EXPECT_NEAR(r.angle_deg, dtheta.norm() * 180.0 / M_PI, 1e-10);
    }
  }
  EXPECT_TRUE(found);
  // Sigmas: R_B_S[0], R_B_S[1] (2), t_B_S (3), intrinsics (4); within 3 sigma all but t_B_S[2]
  // (4 sigma); intrinsics[0] is exactly 3 sigma (counted within).
  EXPECT_EQ(c.summary.with_sigma, 9);
  EXPECT_EQ(c.summary.within_3_sigma, 8);
  EXPECT_EQ(*c.summary.worst_name, "cam0.t_B_S[2]");
  EXPECT_NEAR(*c.summary.worst_error_over_sigma, 4.0, 1e-9);
}

// Only gravity's direction is estimated; its magnitude is the rig's gravity_magnitude. A result
// that assumed 9.81 against a truth of 9.80665 (standard gravity) with the same direction has no
// gravity error; a turned direction gives the error of the direction at the result's magnitude.
TEST(Compare, GravityIsComparedAtTheResultsMagnitude) {
  RigConfig truth = Example();
  truth.gravity_magnitude = 9.80665;
  const Eigen::Vector3d g_true(-0.6747590697894152, -9.575547194550543, -2.0059861278613442);
  truth.gravity_W = g_true;
  RigConfig result = truth;
  result.gravity_magnitude = 9.81;
  result.gravity_W = g_true.normalized() * 9.81;
  result.sigma_gravity_W = Eigen::Vector3d(3e-3, 6.7e-4, 3e-3);
  auto errors = [&] {
    Eigen::Vector3d e = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
    for (const ComparisonRow& r : CompareRigs(truth, result).rows) {
      if (r.name.rfind("gravity_W[", 0) == 0)
        e(r.name[10] - '0') = r.error;
    }
    return e;
  };
  // Without the magnitude taken out, gravity_W[1] would be off by 0.00327 (4.9 sigma).
  EXPECT_LT(errors().cwiseAbs().maxCoeff(), 1e-14);
  // A direction turned by 0.01 rad about x: the error is that turn of the result's 9.81 vector.
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitX()).toRotationMatrix();
  result.gravity_W = R * g_true.normalized() * 9.81;
  EXPECT_LT((errors() - (R - Eigen::Matrix3d::Identity()) * g_true.normalized() * 9.81)
                .cwiseAbs()
                .maxCoeff(),
            1e-14);
  // Equal magnitudes: the truth as it is (a vector subtraction, whatever the norms).
  result.gravity_magnitude = truth.gravity_magnitude;
  result.gravity_W = g_true + Eigen::Vector3d(0.0, 0.01, 0.0);
  EXPECT_EQ(errors(), Eigen::Vector3d(0.0, (g_true(1) + 0.01) - g_true(1), 0.0));
}

TEST(Compare, JsonHasTheSpecKeysAndNullForUndetermined) {
  const RigConfig truth = Example();
  RigConfig result = truth;
  result.Find("cam0")->sigma.values["time_offset"] = {std::numeric_limits<double>::infinity()};
  result.Find("cam0")->sigma.values["intrinsics"] = {0.5, 0.5, 0.5, 0.5};
  const std::string json = ComparisonJson(CompareRigs(truth, result));
  EXPECT_EQ(json.find("{\n  \"parameters\": ["), 0u);
  EXPECT_NE(json.find("{\"name\": \"cam0.time_offset\", \"truth\": 0.0, \"estimate\": 0.0, "
                      "\"error\": 0.0, \"sigma\": null, \"error_over_sigma\": null"),
            std::string::npos)
      << json;
  EXPECT_NE(json.find("{\"name\": \"cam0.intrinsics[1]\", \"truth\": 457.296, \"estimate\": "
                      "457.296, \"error\": 0.0, \"sigma\": 0.5, \"error_over_sigma\": 0.0"),
            std::string::npos)
      << json;
  EXPECT_NE(json.find("\"summary\": {\"count\": "), std::string::npos);
  EXPECT_NE(json.find("\"fraction_within_3_sigma\": 1.0"), std::string::npos);
  EXPECT_EQ(json.find("inf"), std::string::npos);  // JSON has no infinities
}

TEST(Compare, MissingSensorOrModelMismatchIsAnError) {
  const RigConfig truth = Example();
  RigConfig result = truth;
  result.sensors.push_back(*truth.Find("cam0"));
  result.sensors.back().name = "cam1";
  EXPECT_THROW(CompareRigs(truth, result), std::runtime_error);
  result = truth;
  result.Find("imu0")->g_sensitivity = GSensitivity::kNone;  // fewer parameters: fine
  result.Find("imu0")->T_g.clear();
  EXPECT_NO_THROW(CompareRigs(truth, result));
  EXPECT_THROW(CompareRigs(result, truth), std::runtime_error);  // truth lacks Tg
  // imu1 estimates R_I_w, imu2 R_I_a: not the same parameter.
  result = truth;
  result.Find("imu0")->imu_model = ImuModel::kImu1;
  result.Find("imu0")->R_I_w = result.Find("imu0")->R_I_a;
  result.Find("imu0")->R_I_a.setIdentity();
  EXPECT_THROW(CompareRigs(truth, result), std::runtime_error);
}

// A camera-only result of a visual-inertial truth: its T_B_S are relative to its reference
// camera, so the truth is compared in that camera's frame (exactly, for an exact result); a base
// the truth lacks is an error.
TEST(Compare, ResultWithAnotherBaseIsComparedInItsFrames) {
  RigConfig truth = Example();
  SensorConfig cam1 = *truth.Find("cam0");
  cam1.name = "cam1";
  cam1.T_B_S.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix() *
      cam1.T_B_S.topLeftCorner<3, 3>();
  cam1.T_B_S.topRightCorner<3, 1>() += Eigen::Vector3d(0.1, -0.02, 0.03);
  cam1.time_offset += 0.004;
  truth.sensors.push_back(cam1);
  const SensorConfig& cam0 = *truth.Find("cam0");

  RigConfig result;
  result.base_imu = "cam0";
  result.target = truth.target;
  result.sensors = {cam0, cam1};
  result.sensors[0].T_B_S.setIdentity();
  result.sensors[0].time_offset = 0.0;
  result.sensors[0].estimate = {EstimateItem::kIntrinsics};
  result.sensors[1].T_B_S = cam0.T_B_S.inverse() * cam1.T_B_S;
  result.sensors[1].time_offset = 0.0;
  result.sensors[1].estimate = {EstimateItem::kIntrinsics, EstimateItem::kExtrinsics};
  const Comparison c = CompareRigs(truth, result);
  ASSERT_EQ(c.rows.size(), 4u + 4u + 4u + 4u + 3u + 3u);
  for (const ComparisonRow& row : c.rows)
    EXPECT_NEAR(row.error, 0.0, 1e-12) << row.name;

  result.base_imu = "cam7";
  result.sensors[0].name = "cam7";
  try {
    CompareRigs(truth, result);
    FAIL() << "a base the truth lacks accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("'cam7' is not a sensor of the truth"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace ctcal
