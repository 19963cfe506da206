#include "ctcal/sensors/model_names.h"

#include <stdexcept>

namespace ctcal {

SensorType ParseSensorType(const std::string& s) {
  if (s == "imu")
    return SensorType::kImu;
  if (s == "gyro")
    return SensorType::kGyro;
  if (s == "camera")
    return SensorType::kCamera;
  throw std::invalid_argument("unknown sensor type '" + s + "' (expected imu, gyro or camera)");
}

ImuModel ParseImuModel(const std::string& s) {
  if (s == "none")
    return ImuModel::kNone;
  if (s == "imu1")
    return ImuModel::kImu1;
  if (s == "imu2")
    return ImuModel::kImu2;
  if (s == "imu3")
    return ImuModel::kImu3;
  if (s == "imu4")
    return ImuModel::kImu4;
  throw std::invalid_argument("unknown IMU model '" + s +
                              "' (expected none, imu1, imu2, imu3 or imu4)");
}

GyroModel ParseGyroModel(const std::string& s) {
  if (s == "none")
    return GyroModel::kNone;
  if (s == "upper")
    return GyroModel::kUpper;
  if (s == "full")
    return GyroModel::kFull;
  throw std::invalid_argument("unknown gyroscope model '" + s + "' (expected none, upper or full)");
}

GSensitivity ParseGSensitivity(const std::string& s) {
  if (s == "none")
    return GSensitivity::kNone;
  if (s == "upper")
    return GSensitivity::kUpper;
  if (s == "full")
    return GSensitivity::kFull;
  throw std::invalid_argument("unknown g_sensitivity '" + s + "' (expected none, upper or full)");
}

std::string ToString(SensorType t) {
  switch (t) {
    case SensorType::kImu:
      return "imu";
    case SensorType::kGyro:
      return "gyro";
    case SensorType::kCamera:
      return "camera";
  }
  return "?";
}

std::string ToString(ImuModel m) {
  switch (m) {
    case ImuModel::kNone:
      return "none";
    case ImuModel::kImu1:
      return "imu1";
    case ImuModel::kImu2:
      return "imu2";
    case ImuModel::kImu3:
      return "imu3";
    case ImuModel::kImu4:
      return "imu4";
  }
  return "?";
}

std::string ToString(GyroModel m) {
  switch (m) {
    case GyroModel::kNone:
      return "none";
    case GyroModel::kUpper:
      return "upper";
    case GyroModel::kFull:
      return "full";
  }
  return "?";
}

std::string ToString(GSensitivity g) {
  switch (g) {
    case GSensitivity::kNone:
      return "none";
    case GSensitivity::kUpper:
      return "upper";
    case GSensitivity::kFull:
      return "full";
  }
  return "?";
}

std::string RotationKey(ImuModel m) {
  if (m == ImuModel::kImu1)
    return "R_I_w";
  if (m == ImuModel::kImu2)
    return "R_I_a";
  return "";
}

}  // namespace ctcal
