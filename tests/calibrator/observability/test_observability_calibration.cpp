// The observability report of whole calibrations (numeric_observability.h wired into
// CalibrateSpline) on short simulated recordings of the default rig with table4 guesses: each
// degenerate scenario must finish, name at least the parameters issue 9 lists (and the complete
// sets docs/observability.md derives) as unobservable with sigma .inf, keep the excited ones
// finite, and agree with the motion's prediction; the fully excited `full` recording must report
// nothing unobservable and sigmas matching the reference table that defines `weak`.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <set>
#include <string>

#include "../simulated_recording.h"
#include "ctcal/calibrator/discrete_calibrator.h"
#include "ctcal/calibrator/observability/motion_primitives.h"
#include "ctcal/calibrator/observability/numeric_observability.h"
#include "ctcal/calibrator/spline_calibrator.h"
#include "ctcal/sensors/parameter_names.h"
#include "ctcal/sim/dataset_writer.h"
#include "ctcal/sim/default_rig.h"
#include "ctcal/sim/perturb.h"
#include "ctcal/sim/scenario.h"
#include "ctcal/sim/simulator.h"

namespace ctcal {
namespace {

struct Calibration {
  RigConfig truth;
  SplineCalibrationResult out;
  double duration_s = 0.0;  // the trajectory's, as the calibrator scales the reference
};

enum class Method { kSpline, kDiscrete };

// Simulated (in memory) and calibrated once per scenario, method and process.
const Calibration& Calibrated(const std::string& scenario, double duration, std::uint64_t seed,
                              Method method = Method::kSpline) {
  static std::map<std::string, Calibration> cache;
  const std::string key = scenario + (method == Method::kDiscrete ? "/discrete" : "/spline");
  const auto it = cache.find(key);
  if (it != cache.end())
    return it->second;
  const SimulatedRecording rec = SimulateTable4(sim::ParseScenario(scenario), duration, seed);
  SplineCalibratorOptions calib;
  calib.threads = 2;
  Calibration r;
  r.truth = rec.truth;
  const auto quiet = [](const std::string&) {};
  if (method == Method::kDiscrete) {
    DiscreteCalibratorOptions discrete;
    discrete.threads = 2;
    r.out = CalibrateDiscrete(rec.guess, rec.data, discrete, quiet);
  } else {
    r.out = CalibrateSpline(rec.guess, rec.data, calib, quiet);
  }
  // The initial trajectory spline's span for both methods (the one the calibrators scale by).
  r.duration_s = (r.out.num_knots - calib.order + 1) * r.out.knot_spacing_s;
  return cache.emplace(key, std::move(r)).first->second;
}

const Observability& Obs(const Calibration& r) {
  EXPECT_TRUE(r.out.result.observability.has_value());
  return *r.out.result.observability;
}

bool Contains(const std::vector<std::string>& list, const std::string& name) {
  return std::find(list.begin(), list.end(), name) != list.end();
}

std::string Describe(const Observability& o) {
  std::string s = "numeric:";
  for (const std::string& n : o.unobservable)
    s += " " + n;
  s += "\npredicted:";
  for (const std::string& n : o.predicted_unobservable)
    s += " " + n;
  s += "\nweak:";
  for (const std::string& n : o.weak)
    s += " " + n;
  return s;
}

// The result's sigma of a parameter (nullopt: none written).
std::optional<double> SigmaOf(const Calibration& r, const std::string& name) {
  const auto p = FindParameter(r.out.result, name);
  EXPECT_TRUE(p.has_value()) << name;
  return p ? ParameterSigma(r.out.result, *p) : std::nullopt;
}

void ExpectUnobservable(const Calibration& r, const std::vector<std::string>& names) {
  for (const std::string& n : names) {
    EXPECT_TRUE(Contains(Obs(r).unobservable, n)) << n << " should be unobservable";
    const auto s = SigmaOf(r, n);
    EXPECT_TRUE(s && std::isinf(*s)) << n << " sigma should be .inf";
  }
}

// An exact symmetry of the true motion that the estimate breaks by the noise the trajectory
// spline fits (docs/observability.md, "Null or weak"): it may stay above the null rule's 1e-9,
// but its data-only sigma must be far beyond the fully excited rig's.
void ExpectUnobservableOrWeak(const Calibration& r, const std::vector<std::string>& names) {
  for (const std::string& n : names)
    EXPECT_TRUE(Contains(Obs(r).unobservable, n) || Contains(Obs(r).weak, n))
        << n << " should be unobservable or weak";
}

void ExpectObservable(const Calibration& r, const std::vector<std::string>& names) {
  for (const std::string& n : names) {
    EXPECT_FALSE(Contains(Obs(r).unobservable, n)) << n << " should be observable";
    const auto s = SigmaOf(r, n);
    EXPECT_TRUE(s && std::isfinite(*s) && *s > 0.0) << n << " sigma should be finite";
  }
}

// Every name of `prefix`'s keys (e.g. "imu0.Dw" -> imu0.Dw[0..5]) in the rig.
std::vector<std::string> All(const RigConfig& rig, const std::string& sensor_key) {
  std::vector<std::string> out;
  for (const ScalarParameter& p : ScalarParameters(rig, true))
    if (p.name.rfind(sensor_key + "[", 0) == 0 || p.name == sensor_key)
      out.push_back(p.name);
  return out;
}

std::vector<std::string> Join(std::initializer_list<std::vector<std::string>> lists) {
  std::vector<std::string> out;
  for (const auto& l : lists)
    out.insert(out.end(), l.begin(), l.end());
  return out;
}

// The predicted set must be within the numeric one: the tables' rules are exact consequences
// of the measurement model, so the information must be null or weak there (it may have more
// null directions: gauges and trades the tables do not list).
void ExpectPredictedIsNumeric(const Calibration& r) {
  for (const std::string& n : Obs(r).predicted_unobservable)
    EXPECT_TRUE(Contains(Obs(r).unobservable, n) || Contains(Obs(r).weak, n))
        << n << " predicted but numerically well determined";
  std::printf("%s\n", Describe(Obs(r)).c_str());
}

// "Finishes with sigmas that say so": a result with a solver summary, and every parameter it
// reports unobservable carries sigma .inf; every weak one a finite sigma beyond kWeakFactor x
// the fully excited rig's.
void ExpectFinishedWithHonestSigmas(const Calibration& r) {
  EXPECT_TRUE(r.out.result.solver.has_value());
  // Gravity is listed by its key (its direction's tangent); its sigma is sigma_gravity_W.
  const auto sigma = [&](const std::string& n) -> std::optional<double> {
    if (n != "gravity_W")
      return SigmaOf(r, n);
    if (!r.out.result.sigma_gravity_W)
      return std::nullopt;
    return r.out.result.sigma_gravity_W->maxCoeff();
  };
  for (const std::string& n : Obs(r).unobservable) {
    const auto s = sigma(n);
    EXPECT_TRUE(s && std::isinf(*s)) << n << " is unobservable but has a finite sigma";
  }
  for (const std::string& n : Obs(r).weak) {
    const auto s = sigma(n);
    EXPECT_TRUE(s && std::isfinite(*s)) << n;
  }
}

// Each unobservable (numeric or predicted) or weak parameter has exactly one warning that names
// it, says which, and suggests a motion specific to its kind (not the generic fallback) or to stop
// estimating it.
void ExpectOneWarningPerParameter(const Calibration& r) {
  std::set<std::string> names(Obs(r).unobservable.begin(), Obs(r).unobservable.end());
  names.insert(Obs(r).predicted_unobservable.begin(), Obs(r).predicted_unobservable.end());
  names.insert(Obs(r).weak.begin(), Obs(r).weak.end());
  for (const std::string& n : names) {
    int count = 0;
    for (const std::string& w : r.out.warnings) {
      if (w.rfind("warning: " + n + ": ", 0) != 0)
        continue;
      ++count;
      const bool weak_only =
          std::find(Obs(r).weak.begin(), Obs(r).weak.end(), n) != Obs(r).weak.end() &&
          w.find("unobservable") == std::string::npos;
      EXPECT_TRUE(weak_only || w.find(": unobservable (") != std::string::npos) << w;
      EXPECT_EQ(w.find("excite the motion on every axis"), std::string::npos) << w;
      if (n != "gravity_W") {
        EXPECT_NE(w.find(", or remove `"), std::string::npos) << w;
      }
    }
    EXPECT_EQ(count, 1) << n;
  }
}

// What every degenerate recording's report must be besides its own sets (issue 9): the predicted
// nulls within the numeric ones, sigmas that say so, and one warning per parameter.
void ExpectHonestReport(const Calibration& r) {
  ExpectPredictedIsNumeric(r);
  ExpectFinishedWithHonestSigmas(r);
  ExpectOneWarningPerParameter(r);
}

TEST(ObservabilityCalibration, YawLeavesTheVerticalUndetermined) {
  const Calibration& r = Calibrated("yaw", 6.0, 21);
  const RigConfig& rig = r.out.result;
  SCOPED_TRACE(Describe(Obs(r)));
  // Issue 9's minimum set: the structural nulls (a column of D_w times a constant is a bias; a
  // camera's lever arm along z trades with the trajectory's position) ...
  ExpectUnobservable(r, {"imu0.Dw[0]", "imu0.Dw[1]", "imu0.Dw[2]", "cam0.t_B_S[2]", "cam1.t_B_S[2]",
                         "imu1.Dw[0]", "imu1.Dw[1]", "imu1.Dw[2]"});
  // ... and the symmetries the spline's fitted gyroscope noise breaks slightly (weak
  // numerically), which the detected one-axis rotation makes unobservable: the aux IMU's lever
  // arm along z and the aux gyroscope's rotation about z (MergePredictedWeakIntoUnobservable).
  ExpectUnobservable(r, {"imu1.t_B_S[2]", "gyro0.R_B_S[2]"});
  // The base frame's rotation about z, a gauge shared by R_I_a[2] and every R_B_S[2] that the
  // tables do not list: numerically weak at least.
  ExpectUnobservableOrWeak(r, {"imu0.R_I_a[2]", "imu1.R_B_S[2]", "cam0.R_B_S[2]", "cam1.R_B_S[2]"});
  ExpectObservable(r, Join({{"imu0.Dw[5]", "imu1.Dw[5]", "imu0.Da[0]", "imu0.Da[2]",
                             "imu1.time_offset", "cam0.time_offset", "cam1.time_offset",
                             "gyro0.time_offset", "cam0.intrinsics[2]", "cam0.intrinsics[3]"},
                            All(rig, "imu0.Tg")}));
  ExpectHonestReport(r);
  // Each null direction names what it moves; the gauge about z moves the rotations about z.
  ASSERT_FALSE(Obs(r).directions.empty());
  for (const ObservabilityDirection& d : Obs(r).directions) {
    EXPECT_LT(d.eigenvalue, 1e-9);
    EXPECT_FALSE(d.parameters.empty());
  }
}

TEST(ObservabilityCalibration, NoRotationLeavesLeverArmsAndGyroscopesUndetermined) {
  const Calibration& r = Calibrated("no-rotation", 6.0, 22);
  const RigConfig& rig = r.out.result;
  SCOPED_TRACE(Describe(Obs(r)));
  // Structural: no rotation excites no gyroscope; a camera's lever arm trades with the
  // trajectory's position.
  ExpectUnobservable(r, Join({All(rig, "cam0.t_B_S"), All(rig, "cam1.t_B_S"), All(rig, "imu0.Dw"),
                              All(rig, "imu1.Dw"), All(rig, "gyro0.Dw")}));
  // Broken only by the fitted noise: the aux IMU's lever arm (no w x r), the aux gyroscope's
  // rotation and clock (it reads only its bias).
  // (weak numerically; unobservable with the detected no-rotation primitive).
  ExpectUnobservable(
      r, Join({All(rig, "imu1.t_B_S"), All(rig, "gyro0.R_B_S"), {"gyro0.time_offset"}}));
  ExpectObservable(r, Join({All(rig, "imu0.Da"),
                            All(rig, "cam0.intrinsics"),
                            {"imu1.time_offset", "cam0.time_offset", "cam1.time_offset"}}));
  ExpectHonestReport(r);
}

TEST(ObservabilityCalibration, ConstantSpecificForceAlongXLeavesItsColumnsUndetermined) {
  const Calibration& r = Calibrated("const-accel-x", 6.0, 23);
  const RigConfig& rig = r.out.result;
  SCOPED_TRACE(Describe(Obs(r)));
  ExpectUnobservable(r, {"imu0.Da[0]"});
  // T_g's column x multiplies a_I,x = 0 of the true motion; the estimate's specific force along
  // x is the fitted noise (weak numerically; unobservable with the detected primitive).
  ExpectUnobservable(r, {"imu0.Tg[0]", "imu0.Tg[3]", "imu0.Tg[6]"});
  // Rotation on every axis: every gyroscope parameter and every lever arm is determined.
  ExpectObservable(r, Join({All(rig, "imu0.Dw"),
                            All(rig, "imu1.Dw"),
                            All(rig, "gyro0.Dw"),
                            All(rig, "imu1.t_B_S"),
                            All(rig, "cam0.t_B_S"),
                            {"imu0.Da[2]", "imu0.Da[5]", "imu1.Da[0]", "imu0.Tg[1]"}}));
  ExpectHonestReport(r);
}

TEST(ObservabilityCalibration, PlanarAddsTheZColumnsOfTheAccelerometers) {
  const Calibration& r = Calibrated("planar", 6.0, 25);
  const RigConfig& rig = r.out.result;
  SCOPED_TRACE(Describe(Obs(r)));
  // The yaw set (one-axis rotation about z_B) ...
  ExpectUnobservable(
      r, {"imu0.Dw[0]", "imu0.Dw[1]", "imu0.Dw[2]", "imu1.Dw[0]", "imu1.Dw[1]", "imu1.Dw[2]",
          "cam0.t_B_S[2]", "cam1.t_B_S[2]", "imu1.t_B_S[2]", "gyro0.R_B_S[2]"});
  // ... and, the specific force along z being g throughout (constant height), the z columns of
  // D_a and T_g of both IMUs, absorbed by the biases (docs/observability.md, `planar`).
  ExpectUnobservable(r, {"imu0.Da[3]", "imu0.Da[4]", "imu0.Da[5]", "imu0.Tg[2]", "imu0.Tg[5]",
                         "imu0.Tg[8]", "imu1.Da[3]", "imu1.Da[4]", "imu1.Da[5]"});
  ExpectUnobservableOrWeak(r, {"imu0.R_I_a[2]", "imu1.R_B_S[2]", "cam0.R_B_S[2]"});
  // Excited: the rate about z (D_w's column z), the horizontal specific force (D_a's columns x,
  // y), and the clocks through the varying rate and horizontal acceleration.
  ExpectObservable(
      r, {"imu0.Dw[5]", "imu1.Dw[5]", "imu0.Da[0]", "imu0.Da[2]", "imu1.Da[0]", "imu1.time_offset",
          "cam0.time_offset", "cam1.time_offset", "gyro0.time_offset"});
  // The motion analysis finds the plane: planar about the base's z.
  bool planar = false;
  for (const MotionPrimitive& m : Obs(r).motion)
    planar = planar || (m.sensor == rig.base_imu && m.primitive == kPlanar && m.axis.z() > 0.99);
  EXPECT_TRUE(planar);
  ExpectHonestReport(r);
}

TEST(ObservabilityCalibration, StaticLeavesEveryInertialParameterUndetermined) {
  const Calibration& r = Calibrated("static", 4.0, 26);
  const RigConfig& rig = r.out.result;
  SCOPED_TRACE(Describe(Obs(r)));
  // No rotation and a constant specific force on every axis: every D_w, D_a and T_g, every lever
  // arm, and the auxiliary gyroscope's rotation and clock (docs/observability.md, `static`).
  ExpectUnobservable(r, Join({All(rig, "imu0.Dw"),
                              All(rig, "imu0.Da"),
                              All(rig, "imu0.Tg"),
                              All(rig, "imu1.Dw"),
                              All(rig, "imu1.Da"),
                              All(rig, "imu1.t_B_S"),
                              All(rig, "cam0.t_B_S"),
                              All(rig, "cam1.t_B_S"),
                              All(rig, "gyro0.R_B_S"),
                              {"gyro0.time_offset"}}));
  // Nothing moves, so no clock is seen by anything.
  ExpectUnobservableOrWeak(r, {"imu1.time_offset", "cam0.time_offset", "cam1.time_offset"});
  // What a still rig still determines: the cameras' projection (many corners over the image of
  // one view).
  ExpectObservable(r, {"cam0.intrinsics[2]", "cam0.intrinsics[3]"});
  ExpectHonestReport(r);
}

// The discrete (keyframe) calibrator reports the same observability on degenerate motion: the
// trajectory states it marginalises are keyframes instead of spline knots, the data the same.
TEST(ObservabilityCalibration, DiscreteYawLeavesTheVerticalUndetermined) {
  const Calibration& r = Calibrated("yaw", 3.0, 27, Method::kDiscrete);
  SCOPED_TRACE(Describe(Obs(r)));
  ExpectUnobservable(r, {"imu0.Dw[0]", "imu0.Dw[1]", "imu0.Dw[2]", "cam0.t_B_S[2]", "cam1.t_B_S[2]",
                         "imu1.t_B_S[2]", "gyro0.R_B_S[2]"});
  ExpectObservable(
      r, {"imu0.Dw[5]", "imu0.Da[0]", "imu1.time_offset", "cam0.time_offset", "gyro0.time_offset"});
  EXPECT_FALSE(Obs(r).motion.empty());
  ExpectHonestReport(r);
}

TEST(ObservabilityCalibration, FullIsObservableAndMatchesTheReference) {
  const Calibration& r = Calibrated("full", 8.0, 24);
  const RigConfig& rig = r.out.result;
  SCOPED_TRACE(Describe(Obs(r)));
  std::printf("%s\n", Describe(Obs(r)).c_str());
  // Nothing unobservable: `full` sweeps the board out to cam1's outer field, where the fisheye's
  // theta^5..theta^9 terms differ (docs/observability.md, `full`).
  EXPECT_TRUE(Obs(r).unobservable.empty());
  EXPECT_TRUE(Obs(r).directions.empty());
  EXPECT_TRUE(Obs(r).predicted_unobservable.empty());
  EXPECT_TRUE(Obs(r).weak.empty());
  // The measured table (data-only sigma * sqrt(T), largest per kind; printed for updating the
  // stored one): no parameter above its kind's reference by more than the rounding.
  std::map<std::string, double> measured;
  for (std::size_t i = 0; i < r.out.covariance_names.size(); ++i) {
    const std::string& n = r.out.covariance_names[i];
    const double s = r.out.data_sigma(static_cast<Eigen::Index>(i));
    const std::string kind = ParameterKind(rig, n);
    measured[kind] = std::max(measured[kind], s * std::sqrt(r.duration_s));
    const auto ref = ReferenceSigma(rig, n, r.duration_s);
    if (!ref)
      continue;
    EXPECT_LT(s, 1.05 * *ref) << n << " (" << kind << ")";
    EXPECT_GT(s, 0.0) << n;
  }
  for (const auto& [kind, v] : measured)
    std::printf("    {\"%s\", %.3g},\n", kind.c_str(), v);
}

}  // namespace
}  // namespace ctcal
