// Initialisation of the continuous-time calibration from a close guess: board poses per camera
// frame and base poses from them. The spline and gravity fit to those poses and the base IMU is
// private to the calibrator (src/spline_trajectory_fit.h). A coarse-guess initialisation (time
// offsets by cross-correlation, hand-eye) slots in before these functions.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "ctcal/sensors/camera_model.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/targets/board.h"

namespace ctcal {

struct BoardView {
  std::int64_t t_ns = 0;       // the image stamp (camera clock)
  Eigen::Isometry3d T_C_W;     // board (= world) in the camera
  int corners = 0;             // corners of the frame
  int inliers = 0;             // PnP inliers
  double rms_ray_error = 0.0;  // RMS of the inliers' normalised-plane error
};

// Board pose of every frame with at least `min_corners` corners whose rays the guessed camera
// model can unproject: each corner's ray (any camera model) goes on the normalised plane z = 1,
// then PnP with identity K (IPPE, refined) and a refinement after a robust outlier gate. Frames
// whose pose fails (too few inliers, board behind the camera) are skipped. Frames are solved on
// up to `threads` threads; the result does not depend on their number.
std::vector<BoardView> EstimateBoardViews(const CameraModel& camera, const Board& board,
                                          const std::vector<CornerObservation>& corners,
                                          int min_corners, int threads = 1);

// A pose of the base frame at a base-clock time.
struct TimedPose {
  std::int64_t t_ns = 0;
  Eigen::Quaterniond q_W_B = Eigen::Quaterniond::Identity();
  Eigen::Vector3d p_W_B = Eigen::Vector3d::Zero();
};

// T_W_B = T_W_C T_B_C^-1 at t = stamp + time_offset (the camera clock mapped to the base clock).
std::vector<TimedPose> BasePosesFromViews(const std::vector<BoardView>& views,
                                          const Eigen::Isometry3d& T_B_C, double time_offset);

}  // namespace ctcal
