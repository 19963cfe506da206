// ROS recordings as containers of serialized messages (SPEC section 6): a ROS1 bag (`X.bag`,
// read through Debian's librosbag_storage, every chunk compression it has: none, bz2, lz4) and a
// ROS2 bag (its folder with metadata.yaml, or one `.db3`: the sqlite3 storage, read with
// libsqlite3). The messages come out as bytes with their topic and type; ros_messages.h decodes
// them. Every error is a std::runtime_error that starts with the bag's path.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "ctcal/sensors/ros_messages.h"

namespace ctcal {

enum class RosBagKind { kNone, kRos1, kRos2 };

// kRos1 for a file ending in .bag, kRos2 for a folder with metadata.yaml or a file ending in .db3
// or .mcap (refused by OpenRosBag, naming the storage), kNone otherwise.
RosBagKind RosBagKindOf(const std::string& path);

struct RosBagTopic {
  std::string name;
  std::string type;  // ROS1 spelling for both: sensor_msgs/Imu (ROS2's sensor_msgs/msg/Imu)
  std::size_t messages = 0;
};

struct RosBagMessage {
  const std::string* topic = nullptr;
  const std::string* type = nullptr;
  const std::uint8_t* data = nullptr;  // valid during the callback only
  std::size_t size = 0;
  RosWire wire = RosWire::kRos1;
};

class RosBagReader {
 public:
  virtual ~RosBagReader() = default;
  virtual const std::string& path() const = 0;
  // Every topic of the bag with its type and message count, by name.
  virtual std::vector<RosBagTopic> Topics() const = 0;
  // The messages of `topics`, in the bag's order (per topic, as recorded).
  virtual void Read(const std::set<std::string>& topics,
                    const std::function<void(const RosBagMessage&)>& on_message) = 0;
};

// Opens a bag of either kind (RosBagKindOf). Throws for a file that is not a bag of a kind it
// reads: "<path>: <why>" (not indexed, truncated, another storage such as mcap, ...).
std::unique_ptr<RosBagReader> OpenRosBag(const std::string& path);

// The readers behind OpenRosBag, for the fuzz targets and the tests.
std::unique_ptr<RosBagReader> OpenRos1Bag(const std::string& path);
std::unique_ptr<RosBagReader> OpenRos2Bag(const std::string& path);

// A ROS1 bag written through librosbag_storage, messages already serialized (ros_messages.h's
// encoders) with their type's md5sum and definition, so that ROS1's own tools (rosbag, Kalibr)
// deserialize them. Messages should come in time order (readers merge by time chunk by chunk).
enum class RosBagCompression { kNone, kBz2, kLz4 };

class Ros1BagWriter {
 public:
  // Throws "<path>: <why>" when the file cannot be created.
  Ros1BagWriter(const std::string& path, RosBagCompression compression);
  ~Ros1BagWriter();
  Ros1BagWriter(const Ros1BagWriter&) = delete;
  Ros1BagWriter& operator=(const Ros1BagWriter&) = delete;
  // `type`: "sensor_msgs/Imu" or "sensor_msgs/Image"; the record's time is `t_ns`.
  void Write(const std::string& topic, const std::string& type, std::int64_t t_ns,
             const std::vector<std::uint8_t>& bytes);
  // Writes the index; the destructor does it too, but cannot report a failure.
  void Close();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ctcal
