// What the two bag fuzz targets share: a rig reading /imu0, /gyro0 and /cam0/image_raw, and the
// whole path of `calibrate --data X.bag` up to detection (every image decoded as a worker would).
#pragma once

#include <stdexcept>

#include "ctcal/sensors/bag_dataset.h"
#include "ctcal/sensors/rig.h"

namespace ctcal::fuzz {

inline RigConfig BagRig() {
  RigConfig rig;
  rig.base_imu = "imu0";
  SensorConfig imu, gyro, cam;
  imu.name = "imu0";
  imu.type = SensorType::kImu;
  imu.rostopic = "/imu0";
  gyro.name = "gyro0";
  gyro.type = SensorType::kGyro;
  gyro.rostopic = "/gyro0";
  cam.name = "cam0";
  cam.type = SensorType::kCamera;
  cam.rostopic = "/cam0/image_raw";
  rig.sensors = {imu, gyro, cam};
  return rig;
}

inline void LoadBag(const std::string& path) {
  static const RigConfig rig = BagRig();
  try {
    LoadBagDataset(path, rig, [](BagImage&& image) {
      try {
        RosImageToMat(image.image);
      } catch (const std::runtime_error&) {
        // An image that does not decode is counted as unreadable by the detection stage.
      }
    });
  } catch (const std::runtime_error&) {
  }
}

// One message's bytes through every decoder (both wires): a message or std::runtime_error.
inline void DecodeMessage(const std::uint8_t* data, std::size_t size, RosWire wire) {
  try {
    DecodeRosImu(data, size, wire);
  } catch (const std::runtime_error&) {
  }
  for (bool compressed : {false, true}) {
    try {
      RosImageToMat(DecodeRosImage(data, size, wire, compressed));
    } catch (const std::runtime_error&) {
    }
  }
}

}  // namespace ctcal::fuzz
