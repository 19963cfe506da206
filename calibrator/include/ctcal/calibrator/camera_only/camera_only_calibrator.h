// Calibration of a rig without IMUs (SPEC section 7): camera intrinsics and camera-to-camera
// extrinsics, with one board pose per frame instead of a trajectory spline.
//
// Frames: B is the reference camera (`base_imu`), W the board. The unknowns are
//   T_W_B[k]  one per reference frame k (and one per frame seen only by another camera),
//   T_B_C     per non-reference camera (its `T_B_S`), when `extrinsics` is estimated,
//   theta_C   per camera (intrinsics + distortion_coeffs), when `intrinsics` is estimated.
// A corner j of camera C in the frame paired with pose k predicts
//   uv = pi_C(theta_C, T_B_C^-1 T_W_B[k]^-1 p_W_j),
// whitened by the corner's sigma (corners.csv) or the camera's pixel_sigma. Another camera's frame
// belongs to the reference frame with the nearest stamp within half a reference frame period;
// time offsets are not estimated and there is no gravity.
#pragma once

#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "ctcal/report/report_data.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig.h"

namespace ctcal {

struct CameraOnlyOptions {
  int min_corners = 12;  // a frame with fewer corners gets no PnP pose of its own
  int min_views = 3;     // a camera with fewer posed frames is an error
  // Intrinsics are re-initialised from the board views (InitCameraIntrinsics) when the guess
  // reprojects the PnP inliers worse than this (median over frames, px).
  double reinit_rms_px = 1.0;
  double huber_whitened = 2.0;  // Huber loss scale of the robust solve, in sigmas
  // After the robust solve, a corner whose whitened error norm exceeds this many robust sigmas of
  // its camera (median norm / 1.1774, the Rayleigh median) is an outlier; never below 3 sigma of
  // the stated noise (a clean camera keeps its corners).
  double outlier_robust_sigmas = 5.0;
  int max_iterations = 100;
  int num_threads = 2;  // 0: every core
  // One autodiff residual block per corner instead of one compressed block per camera frame
  // (board_frame_corners.h: the same cost, gradient and Gauss-Newton Hessian, ~5x less CPU): the
  // reference the frame blocks are tested against.
  bool per_corner_blocks = false;
  // Weak intrinsics (docs/camera_only.md): sigma(f) / f above this, ...
  double weak_focal_relative = 0.01;
  // ... or the board's normals in the camera spanning less than this (median angle of the views
  // to their mean normal, deg): nearly alike views do not separate focal length from distance.
  double weak_view_spread_deg = 10.0;
  // A camera whose frames are paired with the reference camera's more than this far apart
  // (stamp + given time_offset, s) is warned about: one board pose per pair assumes both cameras
  // exposed at once, which a moving rig with unsynchronised cameras violates.
  double max_pair_gap_s = 1e-3;
};

struct CameraOnlyCameraReport {
  int frames = 0;          // frames with corners
  int frames_used = 0;     // frames whose corners are in the problem
  int frames_dropped = 0;  // frames without a pose (too few corners, no pairing)
  int corners = 0;         // corners in the final solve
  int outliers = 0;        // corners removed after the robust solve
  double view_spread_deg = 0.0;
  bool intrinsics_reinitialised = false;
};

struct CameraOnlyResult {
  RigConfig rig;  // values, sigma, solver, residuals, observability: ready for SaveRig
  std::map<std::string, CameraOnlyCameraReport> cameras;
  std::vector<std::string> warnings;  // also written to the log
  int poses = 0;                      // board poses estimated
  report::ReportData report_data;     // corner rows and correlation (report_data_builder.h)
};

// Throws std::runtime_error (or InitError, naming the stage and camera) with one clear message:
// not a camera-only rig, a camera without corners.csv, a camera with fewer than min_views posed
// frames, a non-reference camera sharing no frame with the reference, a solve that fails.
CameraOnlyResult CalibrateCameraOnly(const RigConfig& rig,
                                     const std::map<std::string, SensorData>& data,
                                     const CameraOnlyOptions& options, std::ostream& log);

}  // namespace ctcal
