// The vocabulary of SPEC sections 3, 4 and 7 shared by the models, the rig files and the CLI.
// Parsing throws std::invalid_argument with the offending word, so callers can prefix the file
// and sensor name.
#pragma once

#include <string>

namespace ctcal {

enum class SensorType { kImu, kGyro, kCamera };

// Inertial intrinsic model of an IMU (SPEC section 3 table).
enum class ImuModel { kNone, kImu1, kImu2, kImu3, kImu4 };

// Gyroscope-only sensor: D_w identity, upper-triangular (6) or full (9).
enum class GyroModel { kNone, kUpper, kFull };

// Gravity sensitivity T_g of a gyroscope: absent, upper-triangular (6), full (9).
enum class GSensitivity { kNone, kUpper, kFull };

SensorType ParseSensorType(const std::string& s);
ImuModel ParseImuModel(const std::string& s);
GyroModel ParseGyroModel(const std::string& s);
GSensitivity ParseGSensitivity(const std::string& s);

std::string ToString(SensorType t);
std::string ToString(ImuModel m);
std::string ToString(GyroModel m);
std::string ToString(GSensitivity g);

// Which frame the model calls the inertial frame I (SPEC section 1): the accelerometer frame for
// imu1/imu3 (the estimated rotation is R_I_w, or none), the gyroscope frame otherwise.
inline bool InertialFrameIsAccelerometer(ImuModel m) {
  return m == ImuModel::kImu1 || m == ImuModel::kImu3;
}

// Name of the rotation key the model estimates in rig files: "R_I_w" (imu1), "R_I_a" (imu2), or
// "" (none, imu3, imu4).
std::string RotationKey(ImuModel m);

}  // namespace ctcal
