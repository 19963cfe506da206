#include "ctcal/sensors/bag_dataset.h"

#include <cmath>
#include <stdexcept>

#include "ctcal/sensors/number_format.h"
#include "ctcal/sensors/ros_bag.h"
#include "dataset_gaps.h"

namespace ctcal {
namespace {

const char* kImuType = "sensor_msgs/Imu";
const char* kImageType = "sensor_msgs/Image";
const char* kCompressedType = "sensor_msgs/CompressedImage";

std::string TopicList(const std::vector<RosBagTopic>& topics) {
  std::string list;
  for (const RosBagTopic& t : topics)
    list += (list.empty() ? "" : ", ") + t.name + " (" + t.type + ")";
  return list.empty() ? "none" : list;
}

// What is read from one topic: its sensor, and for the stamps' and readings' checks the last
// stamp and the message count.
struct TopicState {
  const SensorConfig* sensor = nullptr;
  SensorData* data = nullptr;
  bool compressed = false;
  std::size_t total = 0;
  std::size_t count = 0;
  std::int64_t last_t = 0;
  std::vector<std::int64_t> stamps;  // cameras only (the inertial samples keep their own)
};

// A reading beyond any IMU's range, or not finite: the CSV readers' rule (InertialRange).
void CheckReading(const Eigen::Vector3d& v, double range, const char* what, const char* unit) {
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(v[k]))
      throw std::runtime_error(std::string(what) + " is not finite");
    if (std::abs(v[k]) > range) {
      throw std::runtime_error(std::string(what) + " " + FormatDouble(v[k]) + " " + unit +
                               " is beyond any IMU's range (" + FormatDouble(range) + " " + unit +
                               " per axis)");
    }
  }
}

}  // namespace

bool IsRosBag(const std::string& path) {
  return RosBagKindOf(path) != RosBagKind::kNone;
}

std::map<std::string, SensorData> LoadBagDataset(const std::string& path, const RigConfig& rig,
                                                 const BagImageSink& sink, Warnings* warnings) {
  const std::unique_ptr<RosBagReader> bag = OpenRosBag(path);
  const std::vector<RosBagTopic> topics = bag->Topics();
  std::map<std::string, SensorData> out;
  std::map<std::string, TopicState> states;
  for (const SensorConfig& s : rig.sensors) {
    const std::string who = path + ": sensor '" + s.name + "'";
    if (!s.rostopic) {
      throw std::runtime_error(
          who + " of the rig has no rostopic: (the bag's topics: " + TopicList(topics) + ")");
    }
    const std::string& name = *s.rostopic;
    const std::string where = path + ": topic '" + name + "' (sensor " + s.name + ")";
    const RosBagTopic* topic = nullptr;
    for (const RosBagTopic& t : topics)
      topic = t.name == name ? &t : topic;
    if (!topic) {
      throw std::runtime_error(where + " is not in the bag (its topics: " + TopicList(topics) +
                               ")");
    }
    const bool camera = s.type == SensorType::kCamera;
    const bool image = topic->type == kImageType || topic->type == kCompressedType;
    if (camera ? !image : topic->type != kImuType) {
      throw std::runtime_error(
          where + " carries " + topic->type + ", not " +
          (camera ? std::string(kImageType) + " or " + kCompressedType : std::string(kImuType)));
    }
    if (topic->messages == 0)
      throw std::runtime_error(where + " has no messages");
    if (states.count(name))
      throw std::runtime_error(where + " is also sensor " + states[name].sensor->name + "'s topic");
    TopicState& state = states[name];
    state.sensor = &s;
    state.data = &out[s.name];
    state.compressed = topic->type == kCompressedType;
    state.total = topic->messages;
  }

  const InertialRange range;
  std::set<std::string> wanted;
  for (const auto& [name, state] : states)
    wanted.insert(name);
  bag->Read(wanted, [&](const RosBagMessage& m) {
    TopicState& state = states.at(*m.topic);
    const std::string where =
        path + ": topic '" + *m.topic + "' message " + std::to_string(state.count);
    std::int64_t t = 0;
    BagImage image;
    try {
      const SensorConfig& s = *state.sensor;
      if (s.type == SensorType::kCamera) {
        image.image = DecodeRosImage(m.data, m.size, m.wire, state.compressed);
        CheckRosImage(image.image);
        t = image.image.t_ns;
      } else {
        const RosImu imu = DecodeRosImu(m.data, m.size, m.wire);
        t = imu.t_ns;
        CheckReading(imu.angular_velocity, range.max_rate, "angular_velocity", "rad/s");
        if (s.type == SensorType::kImu) {
          CheckReading(imu.linear_acceleration, range.max_specific_force, "linear_acceleration",
                       "m/s^2");
          state.data->imu.push_back({t, imu.angular_velocity, imu.linear_acceleration});
        } else {
          state.data->gyro.push_back({t, imu.angular_velocity});
        }
      }
      if (state.count > 0 && t <= state.last_t) {
        throw std::runtime_error("header stamp " + std::to_string(t) + " ns " +
                                 (t == state.last_t ? std::string("repeats the previous message's")
                                                    : "is before the previous message's " +
                                                          std::to_string(state.last_t) + " ns") +
                                 ": stamps must increase");
      }
    } catch (const std::runtime_error& e) {
      throw std::runtime_error(where + ": " + e.what());
    }
    state.last_t = t;
    if (state.sensor->type == SensorType::kCamera) {
      state.stamps.push_back(t);
      image.camera = state.sensor;
      image.where = where;
      image.index = state.count;
      image.total = state.total;
      sink(std::move(image));
    }
    ++state.count;
  });
  for (auto& [name, state] : states) {
    const std::string where = path + ": topic '" + name + "'";
    if (state.sensor->type == SensorType::kImu) {
      std::vector<std::int64_t> t;
      for (const ImuSample& s : state.data->imu)
        t.push_back(s.t_ns);
      WarnGaps(where, t, warnings);
    } else if (state.sensor->type == SensorType::kGyro) {
      std::vector<std::int64_t> t;
      for (const GyroSample& s : state.data->gyro)
        t.push_back(s.t_ns);
      WarnGaps(where, t, warnings);
    } else {
      WarnGaps(where, state.stamps, warnings);
    }
  }
  return out;
}

}  // namespace ctcal
