// ROS1 bags through librosbag_storage: it walks the bag's index and chunks (decompressing bz2 and
// lz4 chunks); ctcal takes each message's serialized bytes and decodes them itself
// (ros_messages.cpp), so no generated message code or ROS runtime is needed.
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <cstdint>
#include <fstream>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "ctcal/sensors/ros_bag.h"

namespace ctcal {
namespace {

// A ROS1 bag (format 2.0) is "#ROSBAG V2.0\n" and then records, each a little-endian uint32
// header length, the header, a uint32 data length and the data. librosbag_storage allocates what
// a record's header length says before reading it, so a damaged length (the fuzzer's 7.8 KB bag
// whose connection record claims a 2.3 GB header) costs gigabytes before any error. The top-level
// records (bag header, chunks, the index's connection and chunk-info records) are walked here
// first, seeking over the data, and any length beyond the file's end is refused by name; a cut
// file is refused the same way. Chunk contents are left to the library (its chunk reader
// bounds them by the chunk's size).
void CheckRecordLengths(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in)
    return;  // the library's own open names the file
  const std::uint64_t size = static_cast<std::uint64_t>(in.tellg());
  const std::string magic = "#ROSBAG V2.0\n";
  std::string head(magic.size(), '\0');
  in.seekg(0);
  if (!in.read(&head[0], static_cast<std::streamsize>(head.size())) || head != magic)
    return;  // not a 2.0 bag: the library's open says what it is
  std::uint64_t pos = magic.size();
  const auto read_u32 = [&](std::uint32_t* v) {
    unsigned char b[4];
    in.seekg(static_cast<std::streamoff>(pos));
    if (!in.read(reinterpret_cast<char*>(b), 4))
      return false;
    *v = static_cast<std::uint32_t>(b[0]) | static_cast<std::uint32_t>(b[1]) << 8 |
         static_cast<std::uint32_t>(b[2]) << 16 | static_cast<std::uint32_t>(b[3]) << 24;
    pos += 4;
    return true;
  };
  const auto damaged = [&](const std::string& what, std::uint64_t at, std::uint64_t length) {
    return std::runtime_error(path + ": the record at byte " + std::to_string(at) + " declares " +
                              what + " of " + std::to_string(length) + " bytes, past the file's " +
                              "end (" + std::to_string(size) + " bytes): a damaged or cut bag");
  };
  // Where the library will seek to: the bag header's index_pos and each chunk info's chunk_pos
  // must be the start of a record, or it reads a length from the middle of one.
  std::set<std::uint64_t> starts;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> targets;  // (record at, position)
  std::string header;
  while (pos < size) {
    const std::uint64_t at = pos;
    starts.insert(at);
    std::uint32_t header_len = 0, data_len = 0;
    if (size - pos < 4 || !read_u32(&header_len))
      throw damaged("a header length field", at, 4);
    if (header_len > size - pos)
      throw damaged("a header", at, header_len);
    header.resize(header_len);
    if (!in.read(&header[0], static_cast<std::streamsize>(header_len)))
      throw damaged("a header", at, header_len);
    pos += header_len;
    // Each header field: a little-endian uint32 length, then `name=value`. The library's
    // ros::Header::parse trusts the lengths and copies that many bytes (fuzzing: a chunk header
    // field declaring 2399 bytes in a shorter header read past its buffer): checked here. The
    // fields index_pos and chunk_pos (uint64) are where the library will seek to.
    for (std::size_t i = 0; i < header.size();) {
      const auto* b = reinterpret_cast<const unsigned char*>(header.data() + i);
      const std::uint64_t len = header.size() - i < 4 ? header.size()
                                                      : b[0] | b[1] << 8 | b[2] << 16 |
                                                            static_cast<std::uint64_t>(b[3]) << 24;
      if (header.size() - i < 4 || len > header.size() - i - 4)
        throw std::runtime_error(path + ": the record at byte " + std::to_string(at) +
                                 " has a header field of " + std::to_string(len) +
                                 " bytes past its header's end (" + std::to_string(header_len) +
                                 " bytes): a damaged bag");
      const std::string field = header.substr(i + 4, static_cast<std::size_t>(len));
      i += 4 + static_cast<std::size_t>(len);
      for (const std::string name : {"index_pos=", "chunk_pos="}) {
        if (field.size() == name.size() + 8 && field.compare(0, name.size(), name) == 0) {
          std::uint64_t target = 0;
          for (int k = 7; k >= 0; --k)
            target = target << 8 | static_cast<unsigned char>(field[name.size() + k]);
          targets.emplace_back(at, target);
        }
      }
    }
    if (size - pos < 4 || !read_u32(&data_len))
      throw damaged("a data length field", at, 4);
    if (data_len > size - pos)
      throw damaged("data", at, data_len);
    pos += data_len;
  }
  for (const auto& [at, target] : targets) {
    if (target != 0 && !starts.count(target))
      throw std::runtime_error(path + ": the record at byte " + std::to_string(at) +
                               " points to byte " + std::to_string(target) +
                               ", which starts no record: a damaged bag");
  }
}

class Ros1BagReader : public RosBagReader {
 public:
  explicit Ros1BagReader(const std::string& path) : path_(path) {
    CheckRecordLengths(path);
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

}  // namespace ctcal

// The module's reader entry point (ros1_module.h).
extern "C" ctcal::RosBagReader* ctcal_ros1_open_bag(const std::string& path) {
  return new ctcal::Ros1BagReader(path);
}
