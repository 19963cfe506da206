// `ctcal simulate --bag`: a dataset folder (SPEC section 6) written again as one ROS1 bag, so that
// the same recording feeds ctcal and Kalibr side by side: every inertial sample a sensor_msgs/Imu
// (a gyro's linear_acceleration zero), every image a mono8 sensor_msgs/Image, stamped with the
// folder's nanoseconds (header stamp and record time), on each sensor's `rostopic`.
#pragma once

#include <string>

#include "ctcal/sensors/rig.h"
#include "ctcal/sensors/ros_bag.h"

namespace ctcal::sim {

// Kalibr's topic names, for a sensor without `rostopic`: /<name> (inertial), /<name>/image_raw.
std::string DefaultRosTopic(const SensorConfig& sensor);

// Reads DATA/<sensor>/data.csv (and each camera's images, which must be 8-bit grey) for every
// sensor of `rig` and writes them to `bag_path` in time order. Throws std::runtime_error naming
// the file that cannot be read or written.
void WriteDatasetBag(const std::string& dataset_dir, const RigConfig& rig,
                     const std::string& bag_path,
                     RosBagCompression compression = RosBagCompression::kNone);

}  // namespace ctcal::sim
