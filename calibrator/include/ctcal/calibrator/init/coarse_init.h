// The coarse-guess initialisation of a visual-inertial rig: the stages of camera_init.h,
// time_offset_init.h and inertial_init.h run in order on the recording and turn the rig file's
// guesses (a drawing: focal off by some %, no distortion, rotations off by degrees, time offsets
// unknown up to +-100 ms) into a start inside the basin of the continuous-time problem
// (docs/initialisation.md). Called once by CalibrateSpline before the trajectory is built.
#pragma once

#include <Eigen/Core>
#include <map>
#include <string>
#include <vector>

#include "ctcal/calibrator/calibration_state.h"
#include "ctcal/calibrator/init/camera_init.h"
#include "ctcal/calibrator/init/inertial_init.h"
#include "ctcal/calibrator/init/init_log.h"
#include "ctcal/calibrator/init/time_offset_init.h"
#include "ctcal/sensors/dataset.h"

namespace ctcal {

// When a stage's finding replaces the rig file's value. Only estimated quantities are ever
// replaced; fixed ones (not in the sensor's `estimate:`) stay as given.
enum class GuessPolicy {
  // No stage runs: the rig's guesses go to the full problem as they are (a close guess).
  kOff,
  // Every estimated quantity a stage finds replaces the guess (Kalibr's way).
  kAlways,
  // A guess without a prior_sigma is a drawing and is replaced. A guess with one states its own
  // accuracy: it is replaced only when the data disagree with it beyond `prior_gate` of its prior
  // sigmas in some component (camera intrinsics: beyond `guess_rms_ratio` in reprojection RMS),
  // logged as a warning: the prior is wrong. The prior stays centred on the guess. A stage that
  // cannot
  // determine a prior'd quantity (e.g. a motion about one axis only) keeps its guess with a
  // warning instead of failing, which is what SPEC's priors are for.
  kBeyondPrior,
};

struct CoarseInitOptions {
  GuessPolicy policy = GuessPolicy::kBeyondPrior;
  double prior_gate = 5.0;  // prior sigmas, see kBeyondPrior
  // Camera intrinsics with a prior are judged in the image instead (weakly determined distortion
  // terms differ from a good guess by many prior sigmas): kept while the guess's reprojection RMS
  // is within this factor of the refined model's.
  double guess_rms_ratio = 1.25;
  // Half-width of the time-offset search around each sensor's guess, s. Issue 7 asks for offsets
  // up to +-100 ms from a zero guess; a peak must lie strictly inside the window.
  double max_offset_s = 0.15;
  // Offset accuracy assumed after the time-offset stage (its measured error is < 1 ms): with it
  // the calibrator sizes the margin of samples it keeps away from the trajectory's ends.
  double offset_accuracy_s = 2e-3;
  int min_corners = 12;  // corners a frame needs for a board pose in the stages
  int min_views = 10;    // board views a camera needs (as SplineCalibratorOptions::min_views)
  // The board views are solved once, for every frame with >= views_min_corners corners (the
  // calibrator's own threshold, SplineCalibratorOptions::min_corners_per_view), and handed over
  // (CoarseInitResult::board_views); the stages use those with >= min_corners PnP inliers, which
  // are exactly the views a min_corners run would give.
  int views_min_corners = 8;
  int threads = 1;  // PnP per frame, correlation per lag
  IntrinsicsInitOptions intrinsics;
  HandEyeOptions hand_eye;
  LeverArmOptions lever_arm;
  GravityOptions gravity;
};

struct CoarseInitResult {
  bool ran = false;  // false with GuessPolicy::kOff
  // Initial gyro bias of every inertial sensor (rad/s, raw units, its own frame): the base's from
  // the hand-eye bias term against the first camera (a camera rate has no bias), every other
  // one's from its own term c = b_B - R_B_S b_S. Seeds the bias splines (SeedBiasSplines).
  std::map<std::string, Eigen::Vector3d> gyro_bias;
  // How far each sensor's time offset may still move in the full problem, s: the stage's
  // accuracy where the offset was found here, else 3 prior sigmas, else the search range.
  std::map<std::string, double> offset_uncertainty_s;
  // Board views of every camera, solved at the camera's final intrinsics `params` for frames with
  // >= min_corners corners: the calibrator takes them instead of solving every PnP again when its
  // camera and threshold are the same.
  struct CameraViews {
    Eigen::VectorXd params;
    int min_corners = 0;
    std::vector<BoardView> views;
  };
  std::map<std::string, CameraViews> board_views;
  std::vector<std::string> replaced;  // "<sensor>.<key>" of every value taken from the data
  std::vector<std::string> warnings;  // also logged
  double seconds = 0.0;

  // offset_uncertainty_s of the sensor; 0 when it is not listed (the base, a fixed offset).
  double OffsetUncertainty(const std::string& sensor) const;
};

// Runs the stages on `data` and writes their findings into `state` (per GuessPolicy):
//   1. per camera: intrinsics from the board views (InitCameraIntrinsics), then board poses;
//   2. per non-base sensor: time offset by rate correlation, searched around its guess;
//   3. per non-base sensor: R_B_S by hand-eye; the base's gyro bias from the first camera;
//      cameras after the first take R_B_C and t_B_C through their pose relative to it (shared
//      views), so that all cameras agree on the base trajectory they imply;
//   4. per auxiliary IMU: the lever arm t_B_S from the accelerometers;
//   5. gravity from the base accelerometer under the first camera's views.
// A camera's own t_B_C (the first camera's) is kept from the guess. IMU intrinsics are kept
// (the full problem estimates them from identity). Every finding is logged; a stage that fails
// throws CalibrationInputError (spline_calibrator.h) whose message is InitError's: "initialisation
// stage '<stage>', sensor '<sensor>': <reason>".
CoarseInitResult InitializeFromData(CalibrationState* state,
                                    const std::map<std::string, SensorData>& data,
                                    const CoarseInitOptions& options, const InitLog& log);

// Fills each inertial sensor's gyro bias spline (already sized) with its initial bias.
void SeedBiasSplines(const CoarseInitResult& init, CalibrationState* state);

}  // namespace ctcal
