// Coarse-guess initialisation of the cameras (issue 7, stages 1 and 2):
//  - intrinsics from the board views when the guess is poor (focal off by some %, no distortion),
//  - board poses per frame by robust PnP on any camera model,
//  - the relative pose of two cameras from the views they share.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <utility>
#include <vector>

#include "ctcal/calibrator/init/init_log.h"
#include "ctcal/calibrator/spline_init.h"
#include "ctcal/sensors/camera_model.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/targets/board.h"

namespace ctcal {

struct IntrinsicsInitOptions {
  int min_corners = 12;     // a frame with fewer corners is not used
  int max_views = 60;       // frames used, spread evenly over the recording (cost bound)
  int min_views = 3;        // fewer: InitError
  double cauchy_px = 2.0;   // robust loss scale of the refinement, px
  double outlier_px = 3.0;  // corners whose error exceeds max(outlier_px, 5 robust sigma) drop
  bool estimate_distortion = true;  // false: only the projection parameters move
  double max_focal_ratio = 1.5;     // a refined focal length this far from the guess: InitError
  int max_iterations = 60;
};

struct IntrinsicsInitResult {
  explicit IntrinsicsInitResult(CameraModel model) : camera(std::move(model)) {}
  CameraModel camera;  // the improved model
  int views = 0;       // frames in the refinement
  int corners = 0;     // corners kept
  int outliers = 0;    // corners dropped as outliers
  // Corners the model could not project at a refinement's start values (behind the camera,
  // beyond a fisheye's field or the model's domain): left out of that refinement, which rejects
  // any step that makes a corner unprojectable and so cannot start at one; the most over the
  // refinements.
  int unprojectable = 0;
  double focal_scale = 1.0;   // closed-form (Zhang) focal factor applied before the refinement
  double rms_px_guess = 0.0;  // RMS reprojection error with the guess (its own PnP poses)
  double rms_px = 0.0;        // RMS reprojection error of the kept corners after refinement
  std::string summary;        // one line, also logged
};

// Stage 1. From the guessed model (right type and resolution; focal within ~20 %, any distortion
// guess):
//  a. closed-form focal factor: each frame's corners are unprojected with the guess to its
//     normalised plane, where they are a homography of the board scaled by k = f_true / f_guess
//     about the principal point; Zhang's two constraints per view (r1 . r2 = 0, |r1| = |r2|) with
//     K = diag(k, k, 1) are linear in 1/k^2 and solved over all views;
//  b. board poses by robust PnP with the rescaled model (stage 2);
//  c. refinement of all intrinsics and the board poses with the model's projection and its
//     analytic Jacobians and a Cauchy loss (a Levenberg-Marquardt that eliminates the poses,
//     calibrator/src/init/intrinsics_refinement.h): projection parameters first (distortion held),
//     then everything, then once more without the outlier corners. Each refinement leaves out the
//     corners that the model cannot project at its start values (counted in `unprojectable`).
// Throws InitError (stage "camera intrinsics") with fewer than min_views usable frames, when
// the refinement does not converge to a valid model, or when it moves a focal length beyond
// max_focal_ratio of the guess (views that do not determine it, e.g. all fronto-parallel).
IntrinsicsInitResult InitCameraIntrinsics(const std::string& camera_name, const CameraModel& guess,
                                          const Board& board,
                                          const std::vector<CornerObservation>& corners,
                                          const IntrinsicsInitOptions& options = {},
                                          const InitLog& log = LogInitToStderr);

struct BoardPosesResult {
  std::vector<BoardView> views;  // T_C_W per usable frame, in time order
  int frames = 0;                // frames with corners
  double median_rms_ray = 0.0;   // median over views of the inliers' normalised-plane RMS
  std::string summary;
};

// Stage 2a. Board pose of every frame with >= min_corners corners, for any camera model: corners
// unprojected to rays, PnP on the normalised plane with RANSAC (IPPE on minimal sets), refined on
// the inliers (EstimateBoardViews, frames on `threads` threads). Throws InitError (stage "board
// poses") naming the camera when fewer than min_views frames give a pose (e.g. a camera without
// views).
BoardPosesResult InitBoardPoses(const std::string& camera_name, const CameraModel& camera,
                                const Board& board, const std::vector<CornerObservation>& corners,
                                int min_corners = 12, int min_views = 3,
                                const InitLog& log = LogInitToStderr, int threads = 1);

struct RelativePoseResult {
  Eigen::Isometry3d T_Ci_Cj = Eigen::Isometry3d::Identity();  // p_Ci = T_Ci_Cj p_Cj
  int pairs = 0;                      // views of Ci with a Cj pose interpolated at the same time
  int inliers = 0;                    // pairs inside the robust gates
  double rotation_spread_deg = 0.0;   // median angle of the pairs' rotations to the estimate
  double translation_spread_m = 0.0;  // median distance of the pairs' translations
  std::string summary;
};

// Stage 2b. T_Ci_Cj from the frames both cameras see: each view of Ci at base time
// t + time_offset_i is paired with Cj's pose interpolated (slerp / lerp) between its two views
// bracketing that base time (at most 1.5 of Cj's frame periods apart), giving one sample
// T_Ci_W * T_Cj_W^-1. The estimate is a robust average: rotation by the geodesic mean on SO(3)
// started at the sample with the smallest median distance to the others and iterated on the
// samples within 3 median deviations; translation by the mean of the inliers started at the
// component-wise median. Throws InitError (stage "camera relative pose") naming both cameras
// with fewer than 3 pairs.
RelativePoseResult InitCameraRelativePose(const std::string& camera_i,
                                          const std::vector<BoardView>& views_i,
                                          double time_offset_i, const std::string& camera_j,
                                          const std::vector<BoardView>& views_j,
                                          double time_offset_j,
                                          const InitLog& log = LogInitToStderr);

}  // namespace ctcal
