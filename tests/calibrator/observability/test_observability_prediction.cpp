// The analytic prediction (observability/motion_prediction.h) rule by rule on the default rig,
// the estimate-set filtering, the base-clock series, and the warning lines (warnings.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "ctcal/calibrator/observability/motion_prediction.h"
#include "ctcal/calibrator/observability/warnings.h"
#include "ctcal/sim/default_rig.h"

namespace ctcal {
namespace {

MotionPrimitive Primitive(const std::string& primitive, const std::string& sensor,
                          const Eigen::Vector3d& axis) {
  MotionPrimitive p;
  p.primitive = primitive;
  p.sensor = sensor;
  p.axis = axis;
  p.t0 = 1.0;
  p.t1 = 11.0;
  return p;
}

std::vector<std::string> Sorted(std::vector<std::string> v) {
  std::sort(v.begin(), v.end());
  return v;
}

TEST(ObservabilityPrediction, ConstantAngularVelocityFreesThatColumnOfDw) {
  const RigConfig rig = sim::DefaultRig();
  // Upper-triangular D_w stored [d11, d12, d22, d13, d23, d33]: column z is entries 3, 4, 5.
  EXPECT_EQ(PredictUnobservable(
                rig, {Primitive(kConstantAngularVelocity, "imu0", Eigen::Vector3d::UnitZ())}),
            (std::vector<std::string>{"imu0.Dw[3]", "imu0.Dw[4]", "imu0.Dw[5]"}));
  EXPECT_EQ(PredictUnobservable(
                rig, {Primitive(kConstantAngularVelocity, "gyro0", Eigen::Vector3d::UnitY())}),
            (std::vector<std::string>{"gyro0.Dw[1]", "gyro0.Dw[2]"}));
}

TEST(ObservabilityPrediction, ConstantSpecificForceFreesColumnsOfDaAndTg) {
  const RigConfig rig = sim::DefaultRig();
  // T_g is full (9 numbers, row-major): column x is entries 0, 3, 6.
  EXPECT_EQ(PredictUnobservable(
                rig, {Primitive(kConstantSpecificForce, "imu1", Eigen::Vector3d::UnitX())}),
            (std::vector<std::string>{"imu1.Da[0]", "imu1.Tg[0]", "imu1.Tg[3]", "imu1.Tg[6]"}));
  // An oblique direction frees every column it loads by more than 0.1.
  const auto oblique = PredictUnobservable(
      rig, {Primitive(kConstantSpecificForce, "imu0", Eigen::Vector3d(0.8, 0.6, 0.05))});
  EXPECT_EQ(oblique, (std::vector<std::string>{"imu0.Da[0]", "imu0.Da[1]", "imu0.Da[2]",
                                               "imu0.Tg[0]", "imu0.Tg[1]", "imu0.Tg[3]",
                                               "imu0.Tg[4]", "imu0.Tg[6]", "imu0.Tg[7]"}));
  // An upper-triangular T_g (6 numbers) has column x = entry 0 only.
  RigConfig upper = rig;
  upper.Find("imu0")->g_sensitivity = GSensitivity::kUpper;
  upper.Find("imu0")->T_g = IdentityStored(6);
  EXPECT_EQ(PredictUnobservable(
                upper, {Primitive(kConstantSpecificForce, "imu0", Eigen::Vector3d::UnitX())}),
            (std::vector<std::string>{"imu0.Da[0]", "imu0.Tg[0]"}));
}

TEST(ObservabilityPrediction, BaseOneAxisRotationFreesLeverArmsAndGyroRotationsAlongIt) {
  const RigConfig rig = sim::DefaultRig();
  const auto yaw =
      PredictUnobservable(rig, {Primitive(kOneAxisRotation, "imu0", Eigen::Vector3d::UnitZ())});
  EXPECT_EQ(Sorted(yaw), Sorted({"imu0.Dw[0]", "imu0.Dw[1]", "imu0.Dw[2]", "imu1.t_B_S[2]",
                                 "gyro0.R_B_S[2]", "cam0.t_B_S[2]", "cam1.t_B_S[2]"}));
  // About x tilted by 0.2 rad towards y: only D_w u is seen, so every column loads; lever arms
  // and gyro rotations along x and y.
  const auto tilted = PredictUnobservable(
      rig, {Primitive(kOneAxisRotation, "imu0", Eigen::Vector3d(std::cos(0.2), std::sin(0.2), 0))});
  for (const char* name : {"imu0.Dw[0]", "imu0.Dw[2]", "imu0.Dw[5]", "imu1.t_B_S[0]",
                           "imu1.t_B_S[1]", "gyro0.R_B_S[0]", "gyro0.R_B_S[1]"})
    EXPECT_NE(std::find(tilted.begin(), tilted.end(), name), tilted.end()) << name;
  for (const char* name : {"imu1.t_B_S[2]", "gyro0.R_B_S[2]"})
    EXPECT_EQ(std::find(tilted.begin(), tilted.end(), name), tilted.end()) << name;
  // An auxiliary sensor's own one-axis rotation speaks only about its own intrinsics.
  EXPECT_EQ(
      PredictUnobservable(rig, {Primitive(kOneAxisRotation, "gyro0", Eigen::Vector3d::UnitY())}),
      (std::vector<std::string>{"gyro0.Dw[0]", "gyro0.Dw[3]", "gyro0.Dw[4]", "gyro0.Dw[5]"}));
}

TEST(ObservabilityPrediction, BaseNoRotationFreesTranslationsGyroRotationsAndOffsets) {
  const RigConfig rig = sim::DefaultRig();
  const auto p =
      PredictUnobservable(rig, {Primitive(kNoRotation, "imu0", Eigen::Vector3d::Zero())});
  std::vector<std::string> expected;
  for (int i = 0; i < 6; ++i)
    expected.push_back("imu0.Dw[" + std::to_string(i) + "]");
  for (const char* s : {"imu1", "cam0", "cam1"})
    for (int i = 0; i < 3; ++i)
      expected.push_back(std::string(s) + ".t_B_S[" + std::to_string(i) + "]");
  for (int i = 0; i < 3; ++i)
    expected.push_back("gyro0.R_B_S[" + std::to_string(i) + "]");
  expected.push_back("gyro0.time_offset");
  EXPECT_EQ(Sorted(p), Sorted(expected));
}

TEST(ObservabilityPrediction, ParametersNotEstimatedAreNotListed) {
  RigConfig rig = sim::DefaultRig();
  rig.Find("cam0")->estimate = {EstimateItem::kIntrinsics, EstimateItem::kTimeOffset};
  rig.Find("gyro0")->estimate = {EstimateItem::kExtrinsics};
  rig.Find("imu0")->estimate = {};
  const auto p =
      PredictUnobservable(rig, {Primitive(kNoRotation, "imu0", Eigen::Vector3d::Zero()),
                                Primitive(kNoRotation, "gyro0", Eigen::Vector3d::Zero())});
  EXPECT_EQ(Sorted(p), Sorted({"imu1.t_B_S[0]", "imu1.t_B_S[1]", "imu1.t_B_S[2]", "gyro0.R_B_S[0]",
                               "gyro0.R_B_S[1]", "gyro0.R_B_S[2]", "cam1.t_B_S[0]", "cam1.t_B_S[1]",
                               "cam1.t_B_S[2]"}));
}

TEST(ObservabilityPrediction, SeriesIsOnTheBaseClock) {
  const RigConfig rig = sim::DefaultRig();
  SensorData data;
  data.gyro.push_back({2'000'000'000, Eigen::Vector3d(0.1, 0.2, 0.3)});
  const InertialSeries s = MakeInertialSeries(rig, *rig.Find("gyro0"), data);
  ASSERT_EQ(s.t.size(), 1u);
  EXPECT_DOUBLE_EQ(s.t[0], 2.0 + rig.Find("gyro0")->time_offset);
  EXPECT_TRUE(s.a_m.empty());
  EXPECT_THROW(MakeInertialSeries(rig, *rig.Find("cam0"), data), std::invalid_argument);
  EXPECT_THROW(MakeInertialSeries(rig, *rig.Find("imu1"), SensorData{}), std::invalid_argument);
}

TEST(ObservabilityWarnings, OneLinePerParameterWithStatusAndRemedy) {
  const RigConfig rig = sim::DefaultRig();
  Observability o;
  o.unobservable = {"imu0.Dw[0]", "gyro0.R_B_S[2]"};
  o.predicted_unobservable = {"imu0.Dw[0]", "cam0.t_B_S[2]"};
  o.weak = {"cam0.time_offset", "imu0.Dw[0]"};
  const auto lines = ObservabilityWarnings(rig, o);
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_EQ(lines[0].rfind("imu0.Dw[0]: unobservable (numeric, predicted by the motion), weak", 0),
            0u)
      << lines[0];
  EXPECT_NE(lines[0].find("rotate about imu0's x axis"), std::string::npos) << lines[0];
  EXPECT_NE(lines[0].find("remove `intrinsics` from imu0's estimate"), std::string::npos);
  EXPECT_EQ(lines[1].rfind("gyro0.R_B_S[2]: unobservable (numeric) - ", 0), 0u) << lines[1];
  EXPECT_NE(lines[1].find("remove `extrinsics` from gyro0's estimate"), std::string::npos);
  EXPECT_EQ(lines[2].rfind("cam0.t_B_S[2]: unobservable (predicted by the motion) - rotate about "
                           "axes other than imu0's z axis",
                           0),
            0u)
      << lines[2];
  EXPECT_EQ(lines[3].rfind("cam0.time_offset: weak - ", 0), 0u) << lines[3];
  EXPECT_NE(lines[3].find("remove `time_offset` from cam0's estimate"), std::string::npos);
  // The column of an upper-triangular entry: Dw[4] = d23 is in column z.
  EXPECT_NE(MotionSuggestion(rig, "imu1.Dw[4]").find("imu1's z axis"), std::string::npos);
  EXPECT_NE(MotionSuggestion(rig, "imu1.Tg[4]").find("imu1's y axis"), std::string::npos);
  // Gravity is listed by its key alone (its direction's tangent), and has its own remedy.
  EXPECT_NE(MotionSuggestion(rig, "gravity_W").find("gravity is seen"), std::string::npos);
}

}  // namespace
}  // namespace ctcal
