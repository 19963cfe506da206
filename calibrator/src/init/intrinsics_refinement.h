// The intrinsics initialisation's refinement (camera_init.cpp): a camera's parameters and the
// board's pose in each of its views, fitted to the board corners with a Cauchy loss by a
// Levenberg-Marquardt of our own that eliminates the poses (the Schur complement of a bundle
// adjustment whose only shared block is the camera).
//
// Why not Ceres: the problem is ~60 views x ~80 corners and ~370 columns whose only coupling is
// the camera's 4-9 parameters. Ceres spent ~80 % of each iteration in its generic machinery
// (block-sparse J^T J products, per-residual-block dispatch, validity checks) for a reduced
// system of at most 9 x 9; on one thread, which its reproducible bits need (camera_init.cpp),
// the Kalibr-style recording's one camera took ~0.24 s of the command's ~2 s, nothing else
// running beside it.
//
// It is Ceres' trust-region Levenberg-Marquardt with the settings the refinement used there, so
// that it stops where Ceres stopped (docs/calibrator.md, the initialisation):
//  - cost 1/2 sum rho(|r|^2), rho the Cauchy loss c^2 log(1 + s / c^2); with rho'' < 0 Ceres'
//    corrector scales a corner's residual and Jacobian by sqrt(rho'), so J^T J and J^T r carry
//    the weight rho'(s) = 1 / (1 + s / c^2);
//  - the step solves (J^T J + D / radius) delta = -J^T r, D = diag(J^T J) clamped to
//    [1e-6, 1e32]; a step is taken when the cost falls by more than 1e-3 of the linear model's
//    prediction, then radius /= max(1/3, 1 - (2 rho - 1)^3) (at most 1e16), else radius /= v,
//    v *= 2 (v back to 2 after a success); the first radius 1e4;
//  - the quaternion moves as Ceres' EigenQuaternionManifold: q <- [sin|d| d / |d|, cos|d|] q,
//    its tangent Jacobian the ambient one times that manifold's PlusJacobian; parameters beyond
//    their bounds are clamped to them, as Ceres' parameter blocks do;
//  - it stops when a step changes the cost by at most 1e-6 of it (the step not taken), the step
//    is at most 1e-8 of the parameters' norm, the gradient's largest entry is at most 1e-10, or
//    after max_iterations iterations (taken or not).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "ctcal/sensors/camera_model.h"

namespace ctcal {

struct ViewState {
  Eigen::Quaterniond q_C_W;
  Eigen::Vector3d t_C_W;
};

struct CornerRef {
  int view = 0;
  Eigen::Vector3d p_W;
  Eigen::Vector2d uv;
};

struct IntrinsicsRefinementOptions {
  double cauchy_px = 2.0;
  int max_iterations = 60;
  // Parameters from this index on are held at their values (the distortion in the refinement's
  // first stage); -1: all move.
  int first_held_param = -1;
};

struct IntrinsicsRefinementSummary {
  bool usable = false;  // false: the start could not be evaluated or no step could be solved
  int iterations = 0;   // taken or not, as Ceres counts them
  double initial_cost = 0.0;
  double final_cost = 0.0;
};

// Refines `params` (of a model with compile-time projections: not an mrcal lens) and `views`
// on `corners` (each naming its view); every corner must project at the start (the caller
// leaves out those that do not). `lower` / `upper` are the model's parameter bounds (infinite
// where there is none).
IntrinsicsRefinementSummary RefineIntrinsicsAndPoses(CameraModelType type, Eigen::VectorXd* params,
                                                     const Eigen::VectorXd& lower,
                                                     const Eigen::VectorXd& upper,
                                                     std::vector<ViewState>* views,
                                                     const std::vector<CornerRef>& corners,
                                                     const IntrinsicsRefinementOptions& options);

}  // namespace ctcal
