// End to end: the discrete calibrator (discrete_calibrator.h) on a short simulated recording of
// the default rig (full scenario, table4 guesses). Its keyframes follow the camera frame times of
// the time offsets; a guess far off must not leave the corners on the pose-based A.2
// interpolation, nor move the estimates.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>

#include "../estimate_agreement.h"
#include "../simulated_recording.h"
#include "ctcal/calibrator/discrete_calibrator.h"
#include "ctcal/sensors/compare.h"

namespace ctcal {
namespace {

// The calibrators select the data inside the trajectory the guessed camera offsets imply
// (spline_internal::Prepare), so a guess 15 ms off would also change which corners and inertial
// samples near the recording's ends enter. To compare like with like, the cameras here see the
// board for 0.15 s before the inertial sensors start and after they stop, and not at all within
// 0.5 s of either end: the trajectory is then the inertial sensors' span and the same corners
// lie inside it at either guess.
void TrimEnds(SimulatedRecording* r) {
  const std::int64_t begin = r->data.at("imu0").imu.front().t_ns;
  const std::int64_t end = r->data.at("imu0").imu.back().t_ns;
  const auto at = [](std::int64_t t, double s) {
    return t + static_cast<std::int64_t>(std::llround(s * 1e9));
  };
  for (auto& [name, d] : r->data) {
    const auto outside = [&](std::int64_t t) { return t < at(begin, 0.3) || t > at(end, -0.3); };
    const auto gap = [&](std::int64_t t) {
      return (t > at(begin, 0.15) && t < at(begin, 0.5)) ||
             (t > at(end, -0.5) && t < at(end, -0.15));
    };
    const auto drop = [](auto* v, auto when) {
      v->erase(std::remove_if(v->begin(), v->end(), [&](const auto& x) { return when(x.t_ns); }),
               v->end());
    };
    drop(&d.imu, outside);
    drop(&d.gyro, outside);
    drop(&d.corners, gap);
  }
}

// Both cameras' time-offset guesses 15 ms from the truth (beyond A.1's 10 ms window; within the
// coarse initialisation's 5-sigma gate of their 8 ms priors, so the guesses are kept): the
// keyframes, placed at the guesses' frame times, are re-chosen after the robust stage, every
// corner of the final problem is read through A.1, and the estimates equal those from the true
// offsets (all four at the truth there, so that both problems end with the same keyframes but
// for the robust stage's offset error) to a tenth of their sigma. Without re-choosing, the same
// guesses leave every corner of at least one camera on A.2 (a camera's frames then lie 15 ms
// from their own keyframes, and the other camera's keyframes can be within the window for at
// most one of the two): session 3's seed 303, every Da +0.6 %.
TEST(DiscreteCalibrator, KeyframesFollowCameraOffsetsGuessedFifteenMillisecondsOff) {
  SimulatedRecording r = SimulateTable4(sim::Scenario::kFull, 3.6, 47);
  TrimEnds(&r);
  RigConfig from_truth = r.guess;
  for (const char* sensor : {"imu1", "gyro0", "cam0", "cam1"})
    from_truth.Find(sensor)->time_offset = r.truth.Find(sensor)->time_offset;
  RigConfig off = from_truth;
  for (const char* cam : {"cam0", "cam1"})
    off.Find(cam)->time_offset += 0.015;
  DiscreteCalibratorOptions options;
  options.threads = 2;
  // Both fully converged: each run's stop criterion alone allows 0.1 sigma (tested below).
  options.stop_cost_change = 0.0;
  const auto quiet = [](const std::string&) {};
  const DiscreteCalibrationResult ref = CalibrateDiscrete(from_truth, r.data, options, quiet);
  const DiscreteCalibrationResult moved = CalibrateDiscrete(off, r.data, options, quiet);

  EXPECT_GE(moved.keyframe_rechoices, 1);
  EXPECT_EQ(moved.num_geodesic_corners, 0);
  EXPECT_GT(moved.num_kinematic_corners, 0);
  EXPECT_EQ(ref.keyframe_rechoices, 0);
  EXPECT_EQ(ref.num_geodesic_corners, 0);
  const Agreement agree = ExpectAgreement(ref.result, moved.result, 0.1);
  EXPECT_GE(agree.compared, 95);
  // And both near the truth (the 3 s recording's sigmas).
  const Comparison vs_truth = CompareRigs(r.truth, moved.result);
  ASSERT_TRUE(vs_truth.summary.worst_error_over_sigma.has_value());
  EXPECT_LT(std::abs(*vs_truth.summary.worst_error_over_sigma), 4.0)
      << *vs_truth.summary.worst_name;

  DiscreteCalibratorOptions fixed = options;
  fixed.rechoose_keyframes_fraction = 1e9;
  const DiscreteCalibrationResult stuck = CalibrateDiscrete(off, r.data, fixed, quiet);
  EXPECT_EQ(stuck.keyframe_rechoices, 0);
  EXPECT_GT(4 * stuck.num_geodesic_corners,
            stuck.num_kinematic_corners + stuck.num_geodesic_corners);
  std::printf(
      "camera offset guesses +15 ms: %d re-choice(s), A.1/A.2 corners %d/%d (without "
      "re-choosing %d/%d); worst |moved - from truth| %.3f sigma over %d scalars\n",
      moved.keyframe_rechoices, moved.num_kinematic_corners, moved.num_geodesic_corners,
      stuck.num_kinematic_corners, stuck.num_geodesic_corners, agree.worst, agree.compared);
}

// A keyframe rate above the base IMU's sample rate is one CalibrationInputError naming the
// option: 1e300 Hz added 1e-300 s to the keyframe time forever, until the process was killed for
// its memory.
TEST(DiscreteCalibrator, KeyframeRateAboveTheImuRateIsNamed) {
  const SimulatedRecording r = SimulateTable4(sim::Scenario::kFull, 3.0, 5);
  for (const double rate : {1e300, 1e4}) {
    DiscreteCalibratorOptions options;
    options.threads = 2;
    options.keyframe_rate_hz = rate;
    std::string what;
    try {
      CalibrateDiscrete(r.guess, r.data, options, [](const std::string&) {});
    } catch (const CalibrationInputError& e) {
      what = e.what();
    }
    EXPECT_NE(what.find("--keyframe-rate"), std::string::npos) << rate << ": " << what;
    EXPECT_NE(what.find("sample rate (250."), std::string::npos) << rate << ": " << what;
  }
}

}  // namespace
}  // namespace ctcal

namespace ctcal {
namespace {

// The stop criterion of the plain solves (DiscreteCalibratorOptions::stop_cost_change, as the
// spline's) bounds every estimate's distance to the fully converged one by sqrt(2 * 0.005) = 0.1
// of its sigma; the run without it (Ceres' relative tolerances of 1e-10 only) is the reference.
TEST(DiscreteCalibrator, StopCriterionStaysWithinATenthSigmaOfTheConvergedEstimate) {
  const SimulatedRecording r = SimulateTable4(sim::Scenario::kFull, 3.0, 48);
  DiscreteCalibratorOptions options;
  options.threads = 2;
  DiscreteCalibratorOptions converged = options;
  converged.stop_cost_change = 0.0;
  const auto quiet = [](const std::string&) {};
  const DiscreteCalibrationResult fast = CalibrateDiscrete(r.guess, r.data, options, quiet);
  const DiscreteCalibrationResult ref = CalibrateDiscrete(r.guess, r.data, converged, quiet);
  EXPECT_LE(fast.iterations, ref.iterations);
  const Agreement a = ExpectAgreement(ref.result, fast.result, 0.1);
  EXPECT_GE(a.compared, 95);
  std::printf("stop criterion: %d vs %d iterations, worst |fast - converged| %.4f sigma\n",
              fast.iterations, ref.iterations, a.worst);
}

}  // namespace
}  // namespace ctcal
