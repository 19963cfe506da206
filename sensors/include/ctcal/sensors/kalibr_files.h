// Kalibr-compatible files written beside a result (SPEC section 7), and Kalibr's files read back
// as an initial guess.
//
// camchain-imucam.yaml (rig with IMUs) / camchain.yaml (camera-only rig): `cam0`, `cam1`, ... in
// rig order (a camera-only rig puts its base camera first), each with camera_model, intrinsics,
// distortion_model, distortion_coeffs, resolution, rostopic, cam_overlaps and
//   T_cam_imu         = inverse(T_B_C) (SPEC section 1, B our base frame; below),
//   timeshift_cam_imu = time_offset (t_imu = t_cam + shift, SPEC section 2),
//   T_cn_cnm1         = T_Cn_B * T_B_Cn-1 (cameras n > 0).
// imu.yaml: `imu0` (the base), `imu1`, ... with T_i_b, time_offset, Kalibr's noise keys,
// update_rate, rostopic and the model: `calibrated` for model none, else `scale-misalignment`
// with gyroscopes {M, A, C_gyro_i} and accelerometers {M} (kalibr_imu_model.h).
//
// Frames: SPEC fixes the transforms to our frames: T_cam_imu = inverse(T_B_C), T_i_b =
// inverse(T_B_S) (i = our frame I of that IMU, b = B). Kalibr's canonical frame of a
// scale-misaligned IMU keeps the accelerometer's x axis (lower-triangular M's), ours a triad's z
// axis; Kalibr's equations hold in any frame, so imu.yaml writes them in I: M_a and C_gyro_i
// absorb the rotation R_i_I between the two (M_a is then full), M_g and A are Kalibr's. Reading
// accepts either (any invertible M; kalibr_imu_model.h), so Kalibr's own files import too. With
// model `none` (Kalibr's `calibrated`) i = I. Gyroscope-only sensors have no Kalibr counterpart
// and are not written.
#pragma once

#include <string>
#include <vector>

#include "ctcal/sensors/rig.h"

namespace ctcal {

// `cam_overlaps[n]`: the Kalibr indices of the cameras whose views overlap camera n's; empty:
// every other camera (Kalibr computes it from shared target views, which a rig file lacks).
// An mrcal camera is written as its pinhole-radtan stand-in (kalibr_camera.h); `notes` (may be
// null) gets one line per fitted lens.
std::string EmitKalibrCamchain(const RigConfig& rig,
                               const std::vector<std::vector<int>>& cam_overlaps = {},
                               std::vector<std::string>* notes = nullptr);
std::string EmitKalibrImu(const RigConfig& rig);
// Writes camchain-imucam.yaml and imu.yaml (rig with IMUs) or camchain.yaml (camera-only) into
// `dir`; returns the paths written.
std::vector<std::string> SaveKalibrFiles(const RigConfig& rig, const std::string& dir,
                                         const std::vector<std::vector<int>>& cam_overlaps = {},
                                         std::vector<std::string>* notes = nullptr);

// The sensors of Kalibr files, as an initial guess. Cameras are named as in the file (cam0, ...);
// IMUs imu0 (Kalibr's reference), imu1, ... Kalibr's single-IMU input file (keys at the top
// level, no imu0:) is accepted too. Throws std::runtime_error "<file>:<line>: <where>: <what>".
struct KalibrImportOptions {
  // The model a `scale-misalignment` IMU is imported into (every Kalibr result fits imu2/full).
  ImuModel imu_model = ImuModel::kImu2;
  GSensitivity g_sensitivity = GSensitivity::kFull;
  // The model a `calibrated` IMU (Kalibr's default: an ideal IMU) is given: none keeps Kalibr's
  // assumption; another model starts at the identity with `g_sensitivity` and is estimated.
  ImuModel calibrated_imu_model = ImuModel::kNone;
  // Cameras estimate their projection and distortion too (a camchain is a guess to refine;
  // Kalibr's camera-IMU step keeps them fixed instead).
  bool estimate_camera_intrinsics = true;
};

// `ctcal import-kalibr` (SPEC section 8): a rig from Kalibr's camchain (empty: none) and one or
// more imu.yaml files (empty: a camera-only camchain.yaml, cam0 the base, T_B_S chaining
// T_cn_cnm1). The IMUs of all files are imu0, imu1, ... in order, the first the base; each
// block's T_i_b and time_offset (Kalibr's IMU-IMU results) are its guesses (identity and 0 when
// absent). A camera's T_B_S is inverse(T_b_B) * inverse(T_cam_imu), its time_offset
// timeshift_cam_imu; without T_cam_imu cam0 starts at the identity (a note in `warnings`), the
// others chained by T_cn_cnm1, and ctcal calibrate's coarse initialisation finds them. Every
// non-base sensor estimates its extrinsics and time offset. `rostopic` keys are kept.
RigConfig RigFromKalibr(const std::string& camchain_yaml, const std::vector<std::string>& imu_yamls,
                        const TargetConfig& target, const KalibrImportOptions& options,
                        std::vector<std::string>* warnings);

// The writer's inverse for one imu.yaml (empty: camera-only): Kalibr's own estimate sets
// (cameras keep their intrinsics; a calibrated IMU stays model none).
RigConfig RigFromKalibr(const std::string& camchain_yaml, const std::string& imu_yaml,
                        const TargetConfig& target, const KalibrImportOptions& options = {});

}  // namespace ctcal
