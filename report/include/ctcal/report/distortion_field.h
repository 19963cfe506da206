// The distortion field of a camera for the report: for pixels on a grid over the image, how far
// the lens model moves each ray's image from where an ideal reference lens of the same camera
// would put it (arrows from the reference pixel to the model's pixel, and the magnitude).
//
// The reference, per SPEC section 4 model:
//  - pinhole with radtan / equidistant distortion: the same camera with its distortion
//    coefficients zeroed, i.e. the ideal pinhole (radtan) or the ideal equidistant lens
//    r = f theta (equidistant = Kannala-Brandt with k1..k4 = 0). This is the displacement the
//    coefficients cause, Kalibr's notion of "distortion".
//  - omni (with or without radtan), double sphere, EUCM: the projection itself is the lens
//    model, so there are no coefficients to zero. The reference is the ideal equidistant
//    (f-theta) lens with the model's paraxial focal length (the derivative of the projection at
//    the optical axis: fu / (1 + xi) for omni and double sphere, fu for EUCM) and principal
//    point. Equidistant rather than pinhole because a pinhole reference diverges towards 90 deg
//    and does not exist beyond, where these lenses still see.
//  - pinhole without distortion: the field is zero by definition; Compute returns no points.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "ctcal/sensors/rig.h"

namespace ctcal::report {

struct DistortionField {
  std::string reference;  // "ideal pinhole", "ideal equidistant (f-theta)", ...
  Eigen::Vector2d focal = Eigen::Vector2d::Zero();  // of the reference, px
  Eigen::Vector2d principal_point = Eigen::Vector2d::Zero();
  // Grid points where the model is valid: the reference pixel and the displacement
  // model - reference (px), in the same order.
  std::vector<Eigen::Vector2d> reference_uv, model_uv;
  // |displacement| on a cells_x x cells_y grid over the image (row 0 at the top); NaN where the
  // model does not unproject.
  Eigen::MatrixXd magnitude;
  double max_magnitude = 0.0;
};

// The field of a camera of `camera` (its result values) on an nx x ny grid of arrows and a
// heat_nx wide magnitude grid. Throws std::invalid_argument for an unknown or invalid model (the
// message names the sensor).
DistortionField ComputeDistortionField(const SensorConfig& camera, int nx = 16, int ny = 12,
                                       int heat_nx = 48);

}  // namespace ctcal::report
