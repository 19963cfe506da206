// The simulator's default rig: the MVIS report's simulation (its Table 4) with every inertial
// sensor given non-trivial intrinsics, extrinsics and time offsets, as ground truth.
//
//   imu0   base IMU, 250 Hz, imu2 with full g-sensitivity, estimate [intrinsics]
//   imu1   auxiliary IMU, 300 Hz, imu2 full g-sensitivity, rotated 90 deg about z_B, 7 cm away
//   gyro0  auxiliary gyroscope, 200 Hz, upper D_w, rotated 90 deg about x_B
//   cam0   pinhole-radtan 752x480 (EuRoC-like), 20 Hz, looking down along -z_B
//   cam1   pinhole-equidistant 512x512 (TUM-VI-like), 20 Hz, looking down, turned 90 deg
//   target 6x6 AprilGrid, tagSize 0.088 m, tagSpacing 0.3
// Noise of every inertial sensor: gyro 1.6968e-04 rad/s/sqrt(Hz) white, 1.9393e-05 rad/s^2/
// sqrt(Hz) walk; accel 2.0e-3 m/s^2/sqrt(Hz) white, 3.0e-3 m/s^3/sqrt(Hz) walk; 1 px per corner
// coordinate. Non-base sensors estimate [intrinsics, extrinsics, time_offset].
#pragma once

#include "ctcal/sensors/rig.h"

namespace ctcal::sim {

// Camera frame rate of the simulation (a rig file has no camera rate).
inline constexpr double kDefaultCameraRateHz = 20.0;
inline constexpr double kDefaultDurationS = 60.0;

RigConfig DefaultRig();

}  // namespace ctcal::sim
