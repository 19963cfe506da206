// The discrete-time calibrator (`ctcal calibrate --method discrete`): the MVIS report's
// interpolated formulation (sections 1-3, appendices A-B) on the same data, priors, stages and
// outputs as the spline method (spline_calibrator.h), for cross-checking it (docs/discrete.md).
//
// States: the base IMU's (q, p, v, b_g, b_a) at keyframes; per auxiliary IMU its velocity
// (--aux-velocity state) and biases per keyframe; per auxiliary gyroscope its bias per keyframe;
// the calibration blocks of CalibrationState; gravity. Residuals: base IMU preintegration between
// keyframes (re-integrated with the current intrinsics, eq. 37, when they are estimated;
// bias-linearised, eq. 36, otherwise), bias random walks, auxiliary IMU / gyroscope
// preintegration tied to the interpolated base pose (eq. 38-39, 44), corners reprojected from the
// interpolated base pose (A.1 near a keyframe, A.2 otherwise), the rig's priors.
//
// Keyframes: every camera's frame times on the base clock (the cameras run at independent phases,
// so a corner far from every keyframe would need A.2, whose error is millimetres at 20 Hz on
// aggressive motion), merged when closer than `merge_s` (or 1.5 IMU sample periods), with extra
// keyframes in gaps longer than `max_gap_s`; or a fixed rate.
#pragma once

#include <map>
#include <string>

#include "ctcal/calibrator/spline_calibrator.h"

namespace ctcal {

enum class AuxVelocityModel { kState, kRigid };

struct DiscreteCalibratorOptions {
  AuxVelocityModel aux_velocity = AuxVelocityModel::kState;
  double keyframe_rate_hz = 0.0;  // 0: the camera frame times
  // Camera frames closer than this share a keyframe (and always those closer than 1.5 sample
  // periods of an IMU, whose preintegration needs a sample inside every interval).
  double merge_s = 0.002;
  double max_gap_s = 0.1;  // longer gaps between keyframes get keyframes in between
  // A corner within this time of its nearest keyframe uses A.1, else A.2.
  double kinematic_window_s = 0.01;
  // The keyframes sit at the camera frame times of the time offsets they were chosen with, and
  // the auxiliary sensors' intervals start at those times less their offsets; once any time
  // offset has moved by more than this fraction of kinematic_window_s since then (checked after
  // the robust stage and after every later solve), the keyframes are re-chosen at the current
  // offsets and the solution is carried over to them. Without it a camera guess more than the
  // window off leaves its corners on A.2 (docs/discrete.md, "Keyframes").
  double rechoose_keyframes_fraction = 0.1;
  int threads = 0;
  int max_iterations = 50;
  double huber_threshold = 3.0;
  double outlier_probability = 0.999;
  int min_corners_per_view = 8;
  int min_views = 10;
  int max_rebuild_rounds = 3;
  // As SplineCalibratorOptions::stop_cost_change (0.005: every scalar within 0.1 sigma of the
  // fully converged estimate; 0: Ceres' relative tolerances alone).
  double stop_cost_change = 0.005;
  bool compute_covariance = true;
  // One compressed residual block per global-shutter frame (discrete/frame_corners.h); false:
  // one Jet block per corner (the reference the frame blocks are tested against).
  bool compress_frames = true;
};

// The spline result's fields (result rig, outliers, timings, warnings) plus the keyframe count;
// knot_spacing_s / num_knots are those of the initial trajectory spline.
struct DiscreteCalibrationResult : SplineCalibrationResult {
  int num_keyframes = 0;          // of the final problem
  int keyframe_rechoices = 0;     // how often the keyframes were re-chosen (rechoose_keyframes_*)
  int num_kinematic_corners = 0;  // corners of the final problem interpolated by A.1
  int num_geodesic_corners = 0;   // ... by A.2
};

// Throws CalibrationInputError naming the sensor for data it cannot use, CalibrationFailure for a
// diverging solve.
DiscreteCalibrationResult CalibrateDiscrete(const RigConfig& rig,
                                            const std::map<std::string, SensorData>& data,
                                            const DiscreteCalibratorOptions& options,
                                            const CalibrationLog& log);

}  // namespace ctcal
