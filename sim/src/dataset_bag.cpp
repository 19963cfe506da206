#include "ctcal/sim/dataset_bag.h"

#include <algorithm>
#include <filesystem>
#include <stdexcept>
#include <tuple>
#include <vector>

#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/ros_messages.h"
#include "ctcal/targets/image_file.h"

namespace ctcal::sim {
namespace {

namespace fs = std::filesystem;

// One sensor's samples as read from the folder.
struct Stream {
  const SensorConfig* sensor = nullptr;
  std::string topic;
  std::vector<ImuSample> inertial;  // a gyro's with a zero accelerometer
  std::vector<ImageEntry> images;
  std::size_t size() const {
    return sensor->type == SensorType::kCamera ? images.size() : inertial.size();
  }
  std::int64_t t(std::size_t i) const {
    return sensor->type == SensorType::kCamera ? images[i].t_ns : inertial[i].t_ns;
  }
};

}  // namespace

std::string DefaultRosTopic(const SensorConfig& sensor) {
  return "/" + sensor.name + (sensor.type == SensorType::kCamera ? "/image_raw" : "");
}

void WriteDatasetBag(const std::string& dataset_dir, const RigConfig& rig,
                     const std::string& bag_path, RosBagCompression compression) {
  std::vector<Stream> streams;
  for (const SensorConfig& s : rig.sensors) {
    Stream stream;
    stream.sensor = &s;
    stream.topic = s.rostopic ? *s.rostopic : DefaultRosTopic(s);
    const std::string csv = (fs::path(dataset_dir) / s.name / "data.csv").string();
    if (s.type == SensorType::kImu) {
      stream.inertial = ReadImuCsv(csv);
    } else if (s.type == SensorType::kGyro) {
      for (const GyroSample& g : ReadGyroCsv(csv))
        stream.inertial.push_back({g.t_ns, g.w_m, Eigen::Vector3d::Zero()});
    } else {
      stream.images = ReadImageCsv(csv, true);
    }
    streams.push_back(std::move(stream));
  }
  // Every message by its time (then the rig's order): a reader takes the bag chunk by chunk.
  std::vector<std::tuple<std::int64_t, std::size_t, std::size_t>> order;
  for (std::size_t k = 0; k < streams.size(); ++k) {
    for (std::size_t i = 0; i < streams[k].size(); ++i)
      order.emplace_back(streams[k].t(i), k, i);
  }
  std::sort(order.begin(), order.end());

  Ros1BagWriter bag(bag_path, compression);
  for (const auto& [t, k, i] : order) {
    const Stream& stream = streams[k];
    const std::string frame = stream.sensor->name;
    if (stream.sensor->type != SensorType::kCamera) {
      const ImuSample& s = stream.inertial[i];
      RosImu imu;
      imu.t_ns = s.t_ns;
      imu.angular_velocity = s.w_m;
      imu.linear_acceleration = s.a_m;
      bag.Write(stream.topic, "sensor_msgs/Imu", t, EncodeRos1Imu(imu, frame));
      continue;
    }
    const std::string file =
        (fs::path(dataset_dir) / stream.sensor->name / "data" / stream.images[i].filename).string();
    const cv::Mat image = ReadImageFile(file);  // throws "cannot read image <file>: <why>"
    if (image.type() != CV_8UC1)
      throw std::runtime_error(file + ": not an 8-bit grey image (the bag's images are mono8)");
    bag.Write(stream.topic, "sensor_msgs/Image", t, EncodeRos1Mono8(t, image, frame));
  }
  bag.Close();
}

}  // namespace ctcal::sim
