// ROS1 bags through librosbag_storage: it walks the bag's index and chunks (decompressing bz2 and
// lz4 chunks); ctcal takes each message's serialized bytes and decodes them itself
// (ros_messages.cpp), so no generated message code or ROS runtime is needed.
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <map>
#include <stdexcept>

#include "ctcal/sensors/ros_bag.h"

namespace ctcal {
namespace {

class Ros1BagReader : public RosBagReader {
 public:
  explicit Ros1BagReader(const std::string& path) : path_(path) {
    try {
      bag_.open(path, rosbag::bagmode::Read);
      rosbag::View all(bag_);
      for (const rosbag::ConnectionInfo* c : all.getConnections()) {
        auto [it, fresh] = types_.emplace(c->topic, c->datatype);
        if (!fresh && it->second != c->datatype)
          it->second += "|" + c->datatype;  // one topic, two types: no reader accepts it
      }
    } catch (const std::exception& e) {
      throw std::runtime_error(path + ": " + Why(e));
    }
  }

  const std::string& path() const override { return path_; }

  std::vector<RosBagTopic> Topics() const override {
    std::vector<RosBagTopic> topics;
    try {
      for (const auto& [name, type] : types_) {
        rosbag::View view(bag_, rosbag::TopicQuery(name));
        topics.push_back({name, type, view.size()});
      }
    } catch (const std::exception& e) {
      throw std::runtime_error(path_ + ": " + Why(e));
    }
    return topics;
  }

  void Read(const std::set<std::string>& topics,
            const std::function<void(const RosBagMessage&)>& on_message) override {
    const std::vector<std::string> wanted(topics.begin(), topics.end());
    std::vector<std::uint8_t> buffer;
    std::string topic;
    try {
      rosbag::View view(bag_, rosbag::TopicQuery(wanted));
      for (const rosbag::MessageInstance& m : view) {
        topic = m.getTopic();
        buffer.resize(m.size());
        ros::serialization::OStream stream(buffer.data(),
                                           static_cast<std::uint32_t>(buffer.size()));
        m.write(stream);
        const auto type = types_.find(topic);
        RosBagMessage message;
        message.topic = &topic;
        message.type = &type->second;
        message.data = buffer.data();
        message.size = buffer.size();
        message.wire = RosWire::kRos1;
        on_message(message);
      }
    } catch (const rosbag::BagException& e) {
      throw std::runtime_error(path_ + ": " +
                               (topic.empty() ? "" : "after topic '" + topic + "': ") + Why(e));
    } catch (const ros::Exception& e) {
      // The serialization stream's overrun: a message record shorter than its length field.
      throw std::runtime_error(path_ + ": topic '" + topic + "': " + Why(e));
    }
  }

 private:
  static std::string Why(const std::exception& e) {
    const std::string what = e.what();
    if (what.find("unindexed") != std::string::npos)
      return what + " (the recording was cut short: `rosbag reindex` rebuilds its index)";
    if (what.find("Error reading from file") != std::string::npos)
      return what + " (the bag ends early: truncated while recording or copying?)";
    return what;
  }

  std::string path_;
  mutable rosbag::Bag bag_;
  std::map<std::string, std::string> types_;
};

}  // namespace

std::unique_ptr<RosBagReader> OpenRos1Bag(const std::string& path) {
  return std::make_unique<Ros1BagReader>(path);
}

}  // namespace ctcal
