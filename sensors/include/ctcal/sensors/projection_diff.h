// The projection difference of two camera models (mrcal's `projection_diff` method, without its
// uncertainty weighting): how far apart two lens fits put the image of the same ray, after the
// camera frame rotation that best aligns them. Models of any family can be compared (an omni fit
// against a Mei fit with different xi, a radtan fit against a splined one), which parameter-by-
// parameter comparison cannot do.
//
// Method. For the centres q of an nx x ny grid of cells over the image:
//   v_a = unproject_a(q),  v_b = unproject_b(q)   (unit rays; a point without a ray in either
//                                                   model is left out)
// The two fits may describe the camera frame rotated slightly differently (a principal point
// shift trades against a rotation), so the rotation R_b_a between the frames is fitted first:
//   R_b_a = argmax sum over the fit region of v_b . (R v_a)
// (Wahba's problem, solved by SVD as Kabsch; it is mrcal's fit for points at infinity, where a
// translation between the frames has no effect). Then per grid point
//   diff(q) = | project_b(R_b_a v_a(q)) - q |   px,
// the pixel at which model b sees the ray that model a sees at q. The fit region and the
// statistics (mean, max) are the observed part of the image: the cells holding at least one of
// the given observed pixels (the corners the lens was fitted to), or the whole image when none
// are given. Outside the observed part a fit extrapolates and a difference means little; the map
// still shows it.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "ctcal/sensors/camera_model.h"

namespace ctcal {

struct ProjectionDiffOptions {
  int cells_x = 60;  // grid across the image; the rows follow the aspect ratio
  // Pixels where the lens was observed; empty: the whole image is the observed part.
  std::vector<Eigen::Vector2d> observed;
  bool fit_rotation = true;  // false: R_b_a = identity (compare in the given frames)
};

struct ProjectionDiff {
  int width = 0, height = 0;  // the image, px
  Eigen::Matrix3d R_b_a = Eigen::Matrix3d::Identity();
  double rotation_deg = 0.0;  // the angle of R_b_a
  // diff(q) per grid cell (row 0 at the top); NaN where a model has no ray or pixel.
  Eigen::MatrixXd diff_px;
  // 1 where the cell is in the observed part (fit and statistics), else 0.
  Eigen::MatrixXi observed;
  int points = 0;  // observed cells with a difference
  double mean_px = 0.0, rms_px = 0.0, max_px = 0.0;
};

// Throws std::invalid_argument when the resolutions differ, or when fewer than 3 observed grid
// points have a ray in both models (no rotation can be fitted).
ProjectionDiff DiffProjections(const CameraModel& a, const CameraModel& b,
                               const ProjectionDiffOptions& options = {});

}  // namespace ctcal
