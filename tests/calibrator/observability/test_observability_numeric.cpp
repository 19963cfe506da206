// The numeric observability rules (numeric_observability.h) on hand-made information matrices,
// where the answer is known exactly: a sum-only pair is one null direction, a parameter 100x
// less informed than the reference is weak, and parameter kinds map to the reference table.
#include <gtest/gtest.h>

#include <cmath>

#include "ctcal/calibrator/marginal_covariance.h"
#include "ctcal/calibrator/observability/numeric_observability.h"
#include "ctcal/sim/default_rig.h"

namespace ctcal {
namespace {

// Information of three default-rig parameters (units: 1e-3, 1e-3, 1 ms) from whitened
// measurements z = J x: rows of J in the parameters' own units.
MarginalInformation InformationOf(const Eigen::MatrixXd& J) {
  MarginalInformation info;
  info.names = {"imu0.Dw[0]", "imu0.Dw[1]", "cam0.time_offset"};
  info.unit = Eigen::Vector3d(1e-3, 1e-3, 1e-3);
  info.information = J.transpose() * J;
  return info;
}

TEST(ObservabilityNumeric, SumOnlyPairIsOneNullDirection) {
  // Dw[0] and Dw[1] are only seen as their sum (a column times a constant reading); the time
  // offset is seen on its own.
  Eigen::MatrixXd J(2, 3);
  J << 1e4, 1e4, 0.0,  //
      0.0, 0.0, 1e5;
  const MarginalInformation info = InformationOf(J);
  const CalibrationCovariance cov = InvertInformation(info);
  const RigConfig rig = sim::DefaultRig();
  const Observability o = NumericObservability(info, cov, rig, 10.0);
  EXPECT_EQ(o.unobservable, (std::vector<std::string>{"imu0.Dw[0]", "imu0.Dw[1]"}));
  ASSERT_EQ(o.directions.size(), 1u);
  EXPECT_LT(o.directions[0].eigenvalue, 1e-9);  // relative to the largest
  ASSERT_EQ(o.directions[0].parameters.size(), 2u);
  // The null direction is (1, -1) / sqrt(2): equal and opposite loadings.
  EXPECT_NEAR(std::abs(o.directions[0].parameters[0].loading), std::sqrt(0.5), 1e-9);
  EXPECT_NEAR(o.directions[0].parameters[0].loading, -o.directions[0].parameters[1].loading, 1e-9);
  EXPECT_TRUE(o.weak.empty());
}

TEST(ObservabilityNumeric, WeakIsTenTimesTheReferenceOverTheSameDuration) {
  const RigConfig rig = sim::DefaultRig();
  const double T = 16.0;
  const double ref = *ReferenceSigma(rig, "cam0.time_offset", T);
  EXPECT_DOUBLE_EQ(ref, *ReferenceSigma(rig, "cam0.time_offset", 1.0) / 4.0);
  // Dw[0], Dw[1] well determined; the time offset at 9x and then 11x its reference sigma.
  for (const double factor : {9.0, 11.0}) {
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(3, 3);
    J(0, 0) = J(1, 1) = 1e6;
    J(2, 2) = 1.0 / (factor * ref);
    const MarginalInformation info = InformationOf(J);
    const Observability o = NumericObservability(info, InvertInformation(info), rig, T);
    EXPECT_TRUE(o.unobservable.empty());
    EXPECT_EQ(o.weak.size(), factor > kWeakFactor ? 1u : 0u) << factor;
  }
}

TEST(ObservabilityNumeric, ParameterKindsOfTheDefaultRig) {
  const RigConfig rig = sim::DefaultRig();
  EXPECT_EQ(ParameterKind(rig, "imu0.Dw[3]"), "imu.Dw");
  EXPECT_EQ(ParameterKind(rig, "imu0.R_I_a[1]"), "imu.R_I");
  EXPECT_EQ(ParameterKind(rig, "gyro0.R_B_S[2]"), "gyro.R_B_S");
  EXPECT_EQ(ParameterKind(rig, "cam0.intrinsics[1]"), "camera.focal");
  EXPECT_EQ(ParameterKind(rig, "cam0.intrinsics[3]"), "camera.principal");
  EXPECT_EQ(ParameterKind(rig, "cam1.distortion_coeffs[2]"), "camera.equidistant.distortion[2]");
  EXPECT_EQ(ParameterKind(rig, "gravity_W.direction[1]"), "gravity_W.direction");
  EXPECT_EQ(ParameterKind(rig, "cam9.t_B_S[0]"), "");
  // Every kind of the default rig has a reference, the fisheye's k1..k4 included; kinds the
  // default rig does not estimate have none.
  EXPECT_TRUE(ReferenceSigma(rig, "cam1.distortion_coeffs[0]", 1.0).has_value());
  EXPECT_TRUE(ReferenceSigma(rig, "cam1.distortion_coeffs[3]", 1.0).has_value());
  EXPECT_FALSE(ReferenceSigma(rig, "cam0.line_delay", 1.0).has_value());
}

}  // namespace
}  // namespace ctcal
