// The ROS1 bag writer of the ROS1 module (ros1_module.h): librosbag_storage's writer takes a
// message type with ROS's traits; RawMessage is one whose bytes are already serialized, its type,
// md5sum and definition given per message (as librosbag's own MessageInstance does when it copies a
// message from bag to bag).
#include <rosbag/bag.h>

#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "ctcal/sensors/ros_bag.h"

namespace ctcal {
namespace {

struct RawMessage {
  const std::vector<std::uint8_t>* bytes = nullptr;
  const char* type = nullptr;
  const char* md5sum = nullptr;
  const char* definition = nullptr;
};

// The md5sums are ROS's own for these types (genmsg computes them from the definitions below and
// their dependencies; rosbag and Kalibr check them against their generated classes).
constexpr const char* kHeaderDefinition =
    "================================================================================\n"
    "MSG: std_msgs/Header\n"
    "uint32 seq\n"
    "time stamp\n"
    "string frame_id\n";
constexpr const char* kImuDefinition =
    "std_msgs/Header header\n"
    "geometry_msgs/Quaternion orientation\n"
    "float64[9] orientation_covariance\n"
    "geometry_msgs/Vector3 angular_velocity\n"
    "float64[9] angular_velocity_covariance\n"
    "geometry_msgs/Vector3 linear_acceleration\n"
    "float64[9] linear_acceleration_covariance\n";
constexpr const char* kImuDependencies =
    "================================================================================\n"
    "MSG: geometry_msgs/Quaternion\n"
    "float64 x\n"
    "float64 y\n"
    "float64 z\n"
    "float64 w\n"
    "================================================================================\n"
    "MSG: geometry_msgs/Vector3\n"
    "float64 x\n"
    "float64 y\n"
    "float64 z\n";
constexpr const char* kImageDefinition =
    "std_msgs/Header header\n"
    "uint32 height\n"
    "uint32 width\n"
    "string encoding\n"
    "uint8 is_bigendian\n"
    "uint32 step\n"
    "uint8[] data\n";

struct TypeInfo {
  const char* md5sum;
  std::string definition;
};

TypeInfo InfoOf(const std::string& type) {
  if (type == "sensor_msgs/Imu")
    return {"6a62c6daae103f4ff57a132d6f95cec2",
            std::string(kImuDefinition) + kHeaderDefinition + kImuDependencies};
  if (type == "sensor_msgs/Image")
    return {"060021388200f6f0f447d0fcd9c64743", std::string(kImageDefinition) + kHeaderDefinition};
  throw std::invalid_argument("Ros1BagWriter writes sensor_msgs/Imu and Image, not " + type);
}

}  // namespace
}  // namespace ctcal

namespace ros::message_traits {
template <>
struct MD5Sum<ctcal::RawMessage> {
  static const char* value(const ctcal::RawMessage& m) { return m.md5sum; }
};
template <>
struct DataType<ctcal::RawMessage> {
  static const char* value(const ctcal::RawMessage& m) { return m.type; }
};
template <>
struct Definition<ctcal::RawMessage> {
  static const char* value(const ctcal::RawMessage& m) { return m.definition; }
};
}  // namespace ros::message_traits

namespace ros::serialization {
template <>
struct Serializer<ctcal::RawMessage> {
  template <typename Stream>
  static void write(Stream& stream, const ctcal::RawMessage& m) {
    std::memcpy(stream.advance(static_cast<std::uint32_t>(m.bytes->size())), m.bytes->data(),
                m.bytes->size());
  }
  static std::uint32_t serializedLength(const ctcal::RawMessage& m) {
    return static_cast<std::uint32_t>(m.bytes->size());
  }
};
}  // namespace ros::serialization

namespace ctcal {
namespace {

class Ros1Writer {
 public:
  Ros1Writer(const std::string& path, RosBagCompression compression) : path_(path) {
    try {
      bag_.open(path, rosbag::bagmode::Write);
      bag_.setCompression(compression == RosBagCompression::kBz2 ? rosbag::compression::BZ2
                          : compression == RosBagCompression::kLz4
                              ? rosbag::compression::LZ4
                              : rosbag::compression::Uncompressed);
    } catch (const std::exception& e) {
      throw std::runtime_error(path + ": " + e.what());
    }
    open_ = true;
  }

  void Write(const std::string& topic, const std::string& type, std::int64_t t_ns,
             const std::vector<std::uint8_t>& bytes) {
    auto it = types_.find(type);
    if (it == types_.end())
      it = types_.emplace(type, InfoOf(type)).first;
    RawMessage m{&bytes, it->first.c_str(), it->second.md5sum, it->second.definition.c_str()};
    ros::Time time;
    time.fromNSec(static_cast<std::uint64_t>(t_ns));
    try {
      bag_.write(topic, time, m);
    } catch (const std::exception& e) {
      throw std::runtime_error(path_ + ": topic '" + topic + "': " + e.what());
    }
  }

  void Close() {
    if (!open_)
      return;
    open_ = false;
    try {
      bag_.close();
    } catch (const std::exception& e) {
      throw std::runtime_error(path_ + ": " + e.what());
    }
  }

 private:
  std::string path_;
  rosbag::Bag bag_;
  std::map<std::string, TypeInfo> types_;
  bool open_ = false;
};

}  // namespace
}  // namespace ctcal

// The module's writer entry points (ros1_module.h); the handle is a Ros1Writer.
extern "C" void* ctcal_ros1_writer_open(const std::string& path, int compression) {
  return new ctcal::Ros1Writer(path, static_cast<ctcal::RosBagCompression>(compression));
}

extern "C" void ctcal_ros1_writer_write(void* writer, const std::string& topic,
                                        const std::string& type, std::int64_t t_ns,
                                        const std::vector<std::uint8_t>& bytes) {
  static_cast<ctcal::Ros1Writer*>(writer)->Write(topic, type, t_ns, bytes);
}

extern "C" void ctcal_ros1_writer_close(void* writer) {
  static_cast<ctcal::Ros1Writer*>(writer)->Close();
}

extern "C" void ctcal_ros1_writer_free(void* writer) {
  delete static_cast<ctcal::Ros1Writer*>(writer);
}
