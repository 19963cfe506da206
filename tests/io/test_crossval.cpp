// Cross-validation of results of one rig (sensors/crossval.h): z, the groups' chi-square tests,
// the model-error ratio and the K > 2 spread, on results whose differences are set by hand.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <boost/math/distributions/chi_squared.hpp>
#include <cmath>
#include <limits>

#include "ctcal/sensors/crossval.h"
#include "ctcal/sensors/rig_yaml.h"
#include "example_with_sigma.h"

namespace ctcal {
namespace {

using test::ExampleWithSigma;

const CrossValRow& Row(const CrossValidation& cv, const std::string& name) {
  for (const CrossValRow& r : cv.rows) {
    if (r.name == name)
      return r;
  }
  throw std::runtime_error("no row " + name);
}

const CrossValGroup& Group(const CrossValidation& cv, const std::string& name) {
  for (const CrossValGroup& g : cv.groups) {
    if (g.name == name)
      return g;
  }
  throw std::runtime_error("no group " + name);
}

TEST(CrossValidate, IdenticalResultsAgreeAndGravityIsLeftOut) {
  RigConfig a = ExampleWithSigma(0.01);
  a.gravity_W = Eigen::Vector3d(0.0, 0.0, -9.81);
  const CrossValidation cv = CrossValidate({a, a}, {"a", "b"});
  EXPECT_EQ(cv.summary.count, static_cast<int>(ScalarParameters(a, true).size()) - 3);
  EXPECT_EQ(cv.summary.with_z, cv.summary.count);
  EXPECT_EQ(cv.summary.within_3_sigma, cv.summary.count);
  EXPECT_EQ(*cv.summary.rms_z, 0.0);
  EXPECT_TRUE(cv.summary.passed);
  for (const CrossValGroup& g : cv.groups)
    EXPECT_EQ(g.model_ratio, 0.0) << g.name;
}

TEST(CrossValidate, PairZGroupTestsAndModelRatio) {
  const RigConfig a = ExampleWithSigma(1e-3);
  RigConfig b = a;
  SensorConfig& cam = *b.Find("cam0");
  cam.T_B_S(0, 3) += 3e-3;  // z = 3e-3 / sqrt(2) 1e-3
  // 2 mrad about B's z axis, left perturbation: z = 2e-3 / sqrt(2) 1e-3 on R_B_S[2].
  cam.T_B_S.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(2e-3, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
      Eigen::Matrix3d(cam.T_B_S.topLeftCorner<3, 3>());
  cam.intrinsics[0] += 1e-2;  // z = 10 / sqrt(2): the intrinsics group fails
  const CrossValidation cv = CrossValidate({a, b}, {"a", "b"});

  EXPECT_NEAR(*Row(cv, "cam0.t_B_S[0]").z, 3.0 / std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(Row(cv, "cam0.t_B_S[0]").difference, 3e-3, 1e-12);
  EXPECT_NEAR(*Row(cv, "cam0.R_B_S[2]").z, 2.0 / std::sqrt(2.0), 1e-6);
  EXPECT_NEAR(*Row(cv, "cam0.R_B_S[0]").z, 0.0, 1e-6);
  EXPECT_NEAR(*Row(cv, "cam0.intrinsics[0]").z, 10.0 / std::sqrt(2.0), 1e-6);
  EXPECT_EQ(Row(cv, "cam0.intrinsics[0]").group, "cam0.intrinsics");
  EXPECT_EQ(Row(cv, "cam0.distortion_coeffs[1]").group, "cam0.intrinsics");

  // 12 tested groups (imu0, imu1, gyro0 and cam0's): each at 1 % / 12. t_B_S: 3 dof, statistic
  // 4.5 below chi-square(3)'s quantile, itself above the 99 % one (11.345).
  int tested = 0;
  for (const CrossValGroup& g : cv.groups)
    tested += g.count > 0;
  EXPECT_EQ(tested, 12);
  const CrossValGroup& t = Group(cv, "cam0.t_B_S");
  EXPECT_EQ(t.dof, 3);
  EXPECT_NEAR(t.statistic, 4.5, 1e-9);
  EXPECT_GT(t.threshold, 11.3449);
  EXPECT_NEAR(boost::math::cdf(boost::math::chi_squared(3), t.threshold), 1.0 - 0.01 / 12, 1e-9);
  EXPECT_TRUE(t.passed);
  EXPECT_EQ(t.model_ratio, 0.0);
  // intrinsics: 4 projection + 4 radtan = 8 dof, statistic 50 beyond the quantile (the 99.99 %
  // one is 31.83): lambda = 50/8 - 1.
  const CrossValGroup& in = Group(cv, "cam0.intrinsics");
  EXPECT_EQ(in.dof, 8);
  EXPECT_GT(in.threshold, 20.0902);
  EXPECT_LT(in.threshold, 31.83);
  EXPECT_FALSE(in.passed);
  EXPECT_NEAR(in.model_ratio, 50.0 / 8.0 - 1.0, 1e-6);
  EXPECT_FALSE(cv.summary.passed);
  EXPECT_EQ(cv.summary.groups_failed, 1);
  EXPECT_EQ(*cv.summary.worst_name, "cam0.intrinsics[0]");
  EXPECT_EQ(cv.summary.within_3_sigma, cv.summary.with_z - 1);
  EXPECT_NEAR(*cv.summary.rms_z, std::sqrt((50.0 + 4.5 + 2.0) / cv.summary.with_z), 1e-6);

  const std::string json = CrossValidationJson(cv);
  EXPECT_NE(json.find("\"name\": \"cam0.intrinsics\""), std::string::npos);
  EXPECT_NE(json.find("\"passed\": false"), std::string::npos);
  // The rig's test: every group's statistic on all their dof; here it passes (one group fails).
  EXPECT_TRUE(cv.summary.rig_passed);
  EXPECT_NEAR(
      boost::math::cdf(boost::math::chi_squared(cv.summary.rig_dof), cv.summary.rig_threshold),
      0.99, 1e-9);
  EXPECT_NE(json.find("\"rig\": {\"dof\": " + std::to_string(cv.summary.rig_dof)),
            std::string::npos);
  const std::string text = FormatCrossValidation(cv);
  EXPECT_NE(text.find("cam0.intrinsics[0]"), std::string::npos);
  EXPECT_NE(text.find("FAIL"), std::string::npos);
}

TEST(CrossValidate, ThreeResultsUseTheSampleSpread) {
  const RigConfig a = ExampleWithSigma(1e-3);
  RigConfig b = a, c = a;
  b.Find("cam0")->T_B_S(1, 3) += 2e-3;
  c.Find("cam0")->T_B_S(1, 3) += 4e-3;
  const CrossValidation cv = CrossValidate({a, b, c}, {"a", "b", "c"});
  // Sample variance of {0, 2, 4} mm is 4 mm^2; mean sigma^2 1 mm^2: ratio 4, spread 2 mm.
  const CrossValRow& r = Row(cv, "cam0.t_B_S[1]");
  EXPECT_NEAR(*r.ratio, 4.0, 1e-9);
  EXPECT_NEAR(*r.z, 2.0, 1e-9);
  EXPECT_NEAR(r.difference, 2e-3, 1e-12);
  // 3 rows x (K - 1) = 6 dof, statistic 2 * 4 = 8 below even the 99 % quantile 16.81.
  const CrossValGroup& g = Group(cv, "cam0.t_B_S");
  EXPECT_EQ(g.dof, 6);
  EXPECT_NEAR(g.statistic, 8.0, 1e-9);
  EXPECT_TRUE(g.passed);
}

TEST(CrossValidate, NestedSubsetAgainstTheFullCalibration) {
  // F with sigma 1 mm, a subset of its data with sigma sqrt(2) mm: Var(x_1 - x_F) = 1 mm^2.
  const RigConfig full = ExampleWithSigma(1e-3);
  RigConfig sub = ExampleWithSigma(std::sqrt(2.0) * 1e-3);
  sub.Find("cam0")->T_B_S(0, 3) += 2e-3;  // z = 2
  // A parameter the left-out frames hardly inform: the subset's sigma is F's.
  sub.Find("cam0")->sigma.values["time_offset"] = {1e-3};
  const CrossValidation cv = CrossValidateNested(full, {sub}, {"subset 1"});
  EXPECT_TRUE(cv.nested);
  EXPECT_EQ(cv.num_results, 2);
  const CrossValRow& t = Row(cv, "cam0.t_B_S[0]");
  EXPECT_NEAR(*t.z, 2.0, 1e-9);
  EXPECT_NEAR(*t.ratio, 4.0, 1e-9);
  EXPECT_NEAR(t.subset_variance, 2e-6, 1e-15);
  EXPECT_NEAR(*Row(cv, "cam0.t_B_S[1]").z, 0.0, 1e-12);
  EXPECT_FALSE(Row(cv, "cam0.time_offset").ratio.has_value());
  EXPECT_EQ(Group(cv, "cam0.t_B_S").dof, 3);
  EXPECT_NEAR(Group(cv, "cam0.t_B_S").statistic, 4.0, 1e-9);
  EXPECT_EQ(Group(cv, "cam0.time_offset").count, 0);
}

TEST(CrossValidate, UndeterminedSigmaHasNoZ) {
  RigConfig a = ExampleWithSigma(1e-3);
  a.Find("cam0")->sigma.values["t_B_S"][2] = std::numeric_limits<double>::infinity();
  const CrossValidation cv = CrossValidate({a, ExampleWithSigma(1e-3)}, {"a", "b"});
  EXPECT_FALSE(Row(cv, "cam0.t_B_S[2]").z.has_value());
  EXPECT_EQ(Group(cv, "cam0.t_B_S").count, 2);
  EXPECT_EQ(cv.summary.with_z, cv.summary.count - 1);
}

TEST(CrossValidate, AnotherRigIsAnErrorNamingTheFile) {
  const RigConfig a = ExampleWithSigma(1e-3);
  RigConfig b = a;
  b.Find("cam0")->distortion_model = "none";  // no distortion_coeffs to compare
  b.Find("cam0")->distortion_coeffs.clear();
  try {
    CrossValidate({a, b}, {"A.yaml", "B.yaml"});
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("B.yaml"), std::string::npos) << e.what();
  }
  RigConfig c = a;
  c.base_imu = "imu1";
  EXPECT_THROW(CrossValidate({a, c}, {"A.yaml", "C.yaml"}), std::runtime_error);
}

}  // namespace
}  // namespace ctcal
