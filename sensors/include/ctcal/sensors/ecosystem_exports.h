// A result written for the VIO systems users run it in, beside the Kalibr files (issue 22,
// docs/files.md "Exports"): basalt's calibration.json and OpenVINS's kalibr_imucam_chain.yaml +
// kalibr_imu_chain.yaml. Each maps our models to the program's exactly where the program has the
// model; where it cannot hold part of the result (a camera model it lacks, auxiliary IMUs, a
// quantity it does not model) the file is not written or the part is left out, and a note says so.
//
// basalt (basalt-headers' Calibration, cereal JSON under "value0"): its IMU frame i is the one in
// which its accelerometer matrix (I + S_a) is lower-triangular, i = R_i_I I with
//   R_I_a D_a = R_I_i L   (L lower-triangular, positive diagonal: a QL decomposition),
// so a_i = L a_m - b: calib_accel_bias = [b (0), L - I: (0,0),(1,0),(2,0),(1,1),(2,1),(2,2)];
// w_i = R_i_I R_I_w D_w w_m - b: calib_gyro_bias = [b (0), (R_i_I R_I_w D_w - I) column-major].
// T_imu_cam = T_i_C = R_i_I T_B_C as px,py,pz,qx,qy,qz,qw. T_g has no basalt counterpart (left
// out, noted when non-zero). Cameras: pinhole -> "pinhole"; pinhole-radtan -> "pinhole-radtan8"
// (k1, k2, p1 = r1, p2 = r2, k3..k6 = 0, rpmax where the radial polynomial turns over, 0: none);
// pinhole-equidistant -> "kb4"; omni without distortion -> "ucm" (fx / (1 + xi), fy / (1 + xi),
// cx, cy, alpha = xi / (1 + xi)); ds -> "ds"; eucm -> "eucm". cam_time_offset_ns = the first
// camera's time_offset (t_imu = t_cam + offset; basalt has one offset for all cameras). Noise:
// *_noise_std = the noise densities, *_bias_std = the random walks (continuous-time, basalt
// multiplies by sqrt(rate)). vignette: [].
//
// OpenVINS (ov_msckf's VioManagerOptions / StateOptions): its IMU model is SPEC section 3's
//   w_m = T_w R_IMUtoGYRO w_I + T_g a_I + b_g,   a_m = T_a R_IMUtoACC a_I + b_a
// in the same frame I, so T_imu_cam = T_B_C and Tg = T_g. Its "rpng" model keeps the upper
// triangle of D_w = T_w^-1 and D_a = T_a^-1, so each of R_I_w D_w and R_I_a D_a is written as
// R U (QR, U upper-triangular, positive diagonal): R_IMUtoGYRO = R^T, Tw = U^-1 (the same for
// the accelerometer). Exact for every model: imu2's D_w is already U (R = I). Model none is
// "calibrated". Cameras: pinhole radtan / equidistant / none (radtan with zeros). Only imu0 (the
// base) and cam0's timeshift_cam_imu are read by OpenVINS.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ctcal/sensors/rig.h"

namespace ctcal {

// The files' texts; std::nullopt with *why when the rig cannot be written in that format.
// `notes` (may be null) receives one line per part left out.
std::optional<std::string> EmitBasaltCalibration(const RigConfig& rig, std::string* why,
                                                 std::vector<std::string>* notes = nullptr);
std::optional<std::string> EmitOpenVinsImucamChain(const RigConfig& rig, std::string* why,
                                                   std::vector<std::string>* notes = nullptr);
std::optional<std::string> EmitOpenVinsImuChain(const RigConfig& rig, std::string* why,
                                                std::vector<std::string>* notes = nullptr);

// Writes calibration.json, kalibr_imucam_chain.yaml, kalibr_imu_chain.yaml and each camera's
// mrcal <camera>.cameramodel (mrcal_model.h) into `dir` where the rig allows; returns the paths
// written; `notes` gets why a file was not written and what was left out. Throws std::runtime_error
// when a file cannot be written.
std::vector<std::string> SaveEcosystemExports(const RigConfig& rig, const std::string& dir,
                                              std::vector<std::string>* notes);

}  // namespace ctcal
