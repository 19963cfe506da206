// mrcal interoperability: read and write mrcal's `.cameramodel` files for every lens model mrcal
// has.
//
//   ctcal (SPEC section 4)   mrcal                 parameters (same order, same values)
//   pinhole + radtan          LENSMODEL_OPENCV4     fx, fy, cx, cy, k1, k2, p1, p2
//   pinhole + none            LENSMODEL_PINHOLE     fx, fy, cx, cy
//   mrcal + <lensmodel>       <lensmodel>           mrcal's intrinsics (mrcal_lens.h)
// A file of OPENCV4 or PINHOLE reads as ctcal's own model; any other mrcal lens model (OPENCV5/8/
// 12, CAHVOR(E), LONLAT/LATLON, STEREOGRAPHIC, SPLINED_STEREOGRAPHIC) as a camera of
// camera_model mrcal. Writing: the two shared models and every mrcal camera; Kalibr's
// equidistant, omni, ds and eucm have no mrcal lens model and are a clear error.
//
// Pixel convention: mrcal, like OpenCV and Kalibr, puts pixel (0,0) at the centre of the top-left
// pixel (mrcal.sample_imager() spans 0 .. W-1, its OpenCV models are OpenCV's formulas and
// mrcal-from-kalibr copies Kalibr's intrinsics unchanged), which is SPEC's convention: the
// intrinsics are copied without any 0.5 px shift.
//
// The file is a Python literal: a dict with 'lensmodel' (string), 'intrinsics' (list), 'extrinsics'
// (rt_cam_ref: Rodrigues rotation then translation, p_cam = R(r) p_ref + t) and 'imagersize'
// ([width, height]); mrcal's C reader requires all four, and so do we. Other keys mrcal writes
// ('valid_intrinsics_region', 'optimization_inputs', 'icam_intrinsics', ...) are parsed and
// ignored, as mrcal's C reader does.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>

#include "ctcal/sensors/camera_model.h"

#include <vector>

namespace ctcal {

using MrcalRt = Eigen::Matrix<double, 6, 1>;

// A .cameramodel's content: the lens model and mrcal's extrinsics.
struct MrcalCameraModel {
  CameraModel camera;
  MrcalRt rt_cam_ref;
};

// ctcal type -> mrcal lens model name ("LENSMODEL_OPENCV4"); throws std::invalid_argument for a
// model mrcal does not share.
std::string MrcalLensModelName(CameraModelType type);
// mrcal lens model name -> ctcal type; throws std::invalid_argument for one ctcal does not share.
CameraModelType FromMrcalLensModelName(const std::string& lensmodel);

// The .cameramodel text / file of a camera (numbers written with 17 significant digits, so reading
// it back is exact). Throws std::invalid_argument for a model mrcal does not have, and
// std::runtime_error when the file cannot be written.
std::string EmitMrcalCameraModel(const CameraModel& camera,
                                 const MrcalRt& rt_cam_ref = MrcalRt::Zero());
void SaveMrcalCameraModel(const std::string& path, const CameraModel& camera,
                          const MrcalRt& rt_cam_ref = MrcalRt::Zero());

struct RigConfig;
// The exports of a result (docs/files.md "Exports"): DIR/<camera>.cameramodel for every camera
// whose model mrcal has, mrcal's reference frame being the first camera's (its extrinsics are
// identity; another's are rt of T_C_C0). Returns the paths written; `notes` gets one line per
// camera not written and why. Throws std::runtime_error when a file cannot be written.
std::vector<std::string> SaveMrcalCameraModels(const RigConfig& rig, const std::string& dir,
                                               std::vector<std::string>* notes);

// Parses a .cameramodel; every error is a std::runtime_error "<source>:<line>: <what>".
MrcalCameraModel ParseMrcalCameraModel(const std::string& text, const std::string& source);
MrcalCameraModel LoadMrcalCameraModel(const std::string& path);

// mrcal's rt (Rodrigues vector, translation) <-> T_cam_ref (p_cam = T_cam_ref * p_ref).
Eigen::Isometry3d TransformFromMrcalRt(const MrcalRt& rt_cam_ref);
MrcalRt MrcalRtFromTransform(const Eigen::Isometry3d& T_cam_ref);

}  // namespace ctcal
