// A rig's data read from a ROS bag (SPEC section 6): each sensor's `rostopic:` names its topic,
// sensor_msgs/Imu for imu and gyro sensors (a gyro reads angular_velocity), sensor_msgs/Image or
// sensor_msgs/CompressedImage for cameras; a message's time is its header stamp.
//
// The inertial samples are kept (SensorData::imu / gyro, checked as the CSV readers check them:
// finite, within InertialRange, stamps increasing). Camera images are not kept: each goes to a
// sink as it is read, so that a long recording's images are never all in memory.
#pragma once

#include <cstddef>
#include <functional>
#include <map>
#include <string>

#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig.h"
#include "ctcal/sensors/ros_messages.h"

namespace ctcal {

// One camera message: `where` names it for errors ("<bag>: topic '<t>' message <n>"); `index`
// counts the camera's messages from 0 and `total` is their number in the bag.
struct BagImage {
  const SensorConfig* camera = nullptr;
  RosImage image;
  std::string where;
  std::size_t index = 0;
  std::size_t total = 0;
};
using BagImageSink = std::function<void(BagImage&& image)>;

// True when `path` is a ROS1 or ROS2 bag rather than a dataset folder (ros_bag.h's RosBagKindOf).
bool IsRosBag(const std::string& path);

// Reads every sensor of `rig` from the bag at `path`. Throws std::runtime_error naming the bag and
// the sensor, topic or message: a sensor without `rostopic`, a topic not in the bag or without
// messages, a topic of another message type, a message that does not decode, an image encoding
// ctcal does not read (checked before the sink sees it), a stamp that does not increase, a
// non-finite or out-of-range inertial reading. Errors the sink throws propagate unchanged.
// Camera entries of the result are empty (has_corners false): the sink's owner fills them.
std::map<std::string, SensorData> LoadBagDataset(const std::string& path, const RigConfig& rig,
                                                 const BagImageSink& sink,
                                                 Warnings* warnings = nullptr);

}  // namespace ctcal
