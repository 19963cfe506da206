// A camera as the files of Kalibr, OpenVINS and basalt can hold it. Their models are SPEC
// section 4's (pinhole radtan / equidistant / none, omni, ds, eucm); an mrcal lens (camera_model
// mrcal) has no counterpart there but one: mrcal's LENSMODEL_PINHOLE is pinhole-none and
// LENSMODEL_OPENCV4 (k1 k2 p1 p2) is pinhole-radtan, exactly, and so is an OPENCV5 / 8 / 12
// whose further coefficients are all zero. Every other mrcal lens is written as the pinhole-radtan
// camera that projects like it: fx fy cx cy k1 k2 p1 p2 fitted (Gauss-Newton) to the lens's own
// pixels over the image (a grid of pixels, unprojected by mrcal, whose rays are in front of the
// camera), with the fit's RMS and worst pixel error reported so that the user sees what the
// other program will get. The mrcal `.cameramodel` export keeps the lens itself.
#pragma once

#include <string>

#include "ctcal/sensors/rig.h"

namespace ctcal {

struct KalibrCamera {
  SensorConfig camera;  // camera_model, distortion_model, intrinsics, coefficients replaced
  bool exact = true;    // the same projection (false: a fit)
  double rms_px = 0.0;  // fit only: the pixel difference over the grid
  double max_px = 0.0;
  int points = 0;    // grid pixels fitted
  std::string lens;  // the mrcal lens it stands in for (empty: not an mrcal camera)
};

// `c` itself unless it is an mrcal camera. Throws std::runtime_error naming the camera when an
// mrcal lens leaves too few pixels to fit (fewer than 20 rays in front of it).
KalibrCamera AsKalibrCamera(const SensorConfig& c);

// One line for the log or the export notes: "<file>: <camera>'s mrcal <lens> written as its
// nearest pinhole-radtan (fit over the image: RMS a px, max b px)"; empty when exact.
std::string KalibrCameraNote(const std::string& file, const KalibrCamera& k);

}  // namespace ctcal
