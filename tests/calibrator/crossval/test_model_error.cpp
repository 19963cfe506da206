// The model-error term of the reported sigma (calibrator/cross_validation.h ApplyModelError) on
// subsets whose disagreement is set by hand, and SplitIntoSubsets' interleaved blocks.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "../../io/example_with_sigma.h"
#include "ctcal/calibrator/cross_validation.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal {
namespace {

using test::ExampleWithSigma;
const std::string& kExample = test::kExampleRig;

TEST(ModelError, InflatesOnlyTheFailedGroupByItsSubsetsVariance) {
  // Subsets with sigma 2 (the full calibration's 1 times ~sqrt(2) and more); the intrinsics
  // group: fx 20 apart -> z^2 = 400 / 8 = 50 on 8 dof: lambda = 50 / 8 - 1.
  const RigConfig a = ExampleWithSigma(2.0);
  RigConfig b = a;
  b.Find("cam0")->intrinsics[0] += 20.0;
  const CrossValidation cv = CrossValidate({a, b}, {"a", "b"});
  RigConfig full = ExampleWithSigma(1.0);
  const int inflated = ApplyModelError(cv, &full);
  EXPECT_EQ(inflated, 8);  // cam0's 4 projection and 4 distortion parameters
  const double lambda = 50.0 / 8.0 - 1.0;
  const SensorConfig& cam = *full.Find("cam0");
  for (const char* key : {"intrinsics", "distortion_coeffs"}) {
    for (double s : cam.sigma.values.at(key))
      EXPECT_NEAR(s, std::sqrt(1.0 + lambda * 4.0), 1e-9) << key;
    for (double s : cam.sigma_formal.values.at(key))
      EXPECT_EQ(s, 1.0) << key;
  }
  // The other groups of cam0 agree: their sigma is the formal one (kept in sigma_formal too).
  for (double s : cam.sigma.values.at("t_B_S"))
    EXPECT_EQ(s, 1.0);
  EXPECT_EQ(cam.sigma_formal.values.at("t_B_S"), cam.sigma.values.at("t_B_S"));
  // Sensors without inflation write no sigma_formal.
  for (const SensorConfig& s : full.sensors) {
    if (s.name != "cam0") {
      EXPECT_TRUE(s.sigma_formal.empty()) << s.name;
    }
  }
  // sigma_formal round-trips through the result file.
  const RigConfig back = ParseRigString(EmitRig(full));
  EXPECT_EQ(back.Find("cam0")->sigma_formal, cam.sigma_formal);
}

// Nested (a subset against the full calibration F): a parameter whose subset variance is below
// 1.2 times F's has no z of its own, yet it is in the failing group and gets the same model error
// mu = lambda s_k^2 (on EuRoC, cam1's k2 was such a parameter and the worst of the comparison).
TEST(ModelError, AParameterWithoutAZIsWidenedWithItsFailingGroup) {
  const RigConfig full = ExampleWithSigma(1.0);
  RigConfig subset = ExampleWithSigma(2.0);
  subset.Find("cam0")->intrinsics[0] += 20.0;
  subset.Find("cam0")->sigma.values.at("distortion_coeffs")[1] = 1.05;  // 1.1 x F's variance
  const CrossValidation cv = CrossValidateNested(full, {subset}, {"subset 1"});
  double lambda = 0.0;
  for (const CrossValGroup& g : cv.groups) {
    if (g.name == "cam0.intrinsics") {
      EXPECT_FALSE(g.passed);
      EXPECT_EQ(g.count, 7);  // the row without a z is not tested
      lambda = g.model_ratio;
    }
  }
  ASSERT_GT(lambda, 1.0);
  RigConfig reported = full;
  EXPECT_EQ(ApplyModelError(cv, &reported), 8);
  const std::vector<double>& d = reported.Find("cam0")->sigma.values.at("distortion_coeffs");
  EXPECT_NEAR(d[1], std::sqrt(1.0 + lambda * 1.05 * 1.05), 1e-9);
  EXPECT_NEAR(d[0], std::sqrt(1.0 + lambda * 4.0), 1e-9);
}

TEST(ModelError, SubsetsAreInterleavedBlocksOfCameraFrames) {
  std::vector<std::string> warnings;
  const RigConfig rig = LoadRig(kExample, &warnings);
  std::map<std::string, SensorData> data;
  // 20 s of 20 Hz frames with one corner each, and an IMU.
  for (const SensorConfig& s : rig.sensors) {
    SensorData& d = data[s.name];
    d.has_corners = s.type == SensorType::kCamera;
    for (int i = 0; i < 400; ++i) {
      const std::int64_t t = 1000000000LL + i * 50000000LL;
      if (s.type == SensorType::kCamera)
        d.corners.push_back({t, 0, 1.0, 2.0, std::nullopt});
      else
        d.imu.push_back({t, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()});
    }
  }
  CrossValidationOptions options;
  options.block_seconds = 4.0;
  const SubsetSplit split = SplitIntoSubsets(rig, data, options, 10);
  ASSERT_EQ(split.why_not, "");
  // K = 2: subset 1 alone is calibrated (subset 2 is the rest of the full calibration).
  ASSERT_EQ(split.subsets.size(), 1u);
  EXPECT_EQ(split.blocks, 5);
  const std::vector<CornerObservation>& c = split.subsets[0].at("cam0").corners;
  // Blocks 0, 2, 4: frames 0-79, 160-239, 320-399.
  EXPECT_EQ(c.size(), 240u);
  for (const CornerObservation& o : c)
    EXPECT_EQ(((o.t_ns - 1000000000LL) / 4000000000LL) % 2, 0);
  EXPECT_EQ(split.subsets[0].at("imu0").imu.size(), 400u);  // inertial data whole
  // K = 3 with 2 s blocks: subsets 1 and 2, every third block each.
  options.subsets = 3;
  options.block_seconds = 2.0;
  const SubsetSplit three = SplitIntoSubsets(rig, data, options, 10);
  ASSERT_EQ(three.subsets.size(), 2u);
  EXPECT_EQ(three.subsets[1].at("cam0").corners.size(), 120u);  // blocks 1, 4, 7 of 10
  // Too short for 2 blocks per subset: not split, with why.
  options.subsets = 2;
  options.block_seconds = 8.0;
  const SubsetSplit none = SplitIntoSubsets(rig, data, options, 10);
  EXPECT_TRUE(none.subsets.empty());
  EXPECT_NE(none.why_not.find("blocks"), std::string::npos) << none.why_not;
}

}  // namespace
}  // namespace ctcal
