// The three ROS message types a recording's sensors publish (SPEC section 6), decoded from their
// serialized bytes without generated message code: ROS1's serialization (little-endian, packed,
// strings and arrays prefixed by a uint32 length) and ROS2's CDR (XCDR1 as rmw's Fast-CDR writes
// it: a 4-byte encapsulation header giving the byte order, each primitive aligned to its own size
// counted from the end of that header, strings with their terminating NUL in the length).
//
//   sensor_msgs/Imu              header, orientation (4 f64), 9 f64, angular_velocity (3 f64),
//                                9 f64, linear_acceleration (3 f64), 9 f64
//   sensor_msgs/Image            header, u32 height, u32 width, string encoding, u8 is_bigendian,
//                                u32 step, u8[] data
//   sensor_msgs/CompressedImage  header, string format, u8[] data
//   std_msgs/Header              ROS1: u32 seq, u32 sec, u32 nsec, string frame_id
//                                ROS2: i32 sec, u32 nanosec, string frame_id
//
// Every decoder throws std::runtime_error naming what is wrong (a message shorter than its
// fields, a length beyond the message); the caller adds the topic and the message's number.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace ctcal {

enum class RosWire { kRos1, kCdr };

struct RosImu {
  std::int64_t t_ns = 0;  // header stamp
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d linear_acceleration = Eigen::Vector3d::Zero();
};

// An Image or a CompressedImage, its pixels still as published (decoded by DecodeRosImage).
struct RosImage {
  std::int64_t t_ns = 0;
  bool compressed = false;
  std::string encoding;  // Image's encoding (mono8, ...), or CompressedImage's format (jpeg, ...)
  std::uint32_t width = 0, height = 0, step = 0;
  bool big_endian = false;
  std::vector<std::uint8_t> data;
};

RosImu DecodeRosImu(const std::uint8_t* bytes, std::size_t size, RosWire wire);
RosImage DecodeRosImage(const std::uint8_t* bytes, std::size_t size, RosWire wire, bool compressed);

// The pixels as the detector takes them (CV_8U or CV_16U, grey, BGR or BGRA): mono8, mono16 (and
// their 8UC1/16UC1 aliases), rgb8, bgr8, rgba8, bgra8; a CompressedImage whose format names jpeg
// or png, through DecodeImage (ctcal/targets/image_file.h: the format told by the bytes, not the
// name). Throws std::runtime_error for another encoding (naming it), a data block smaller than
// step x height, or bytes that are no valid PNG or JPEG.
cv::Mat RosImageToMat(const RosImage& image);

// Checks that `image` is one RosImageToMat takes (its encoding or format, its size against its
// data), without decoding a compressed one. Throws std::runtime_error saying why.
void CheckRosImage(const RosImage& image);

// The ROS1 serialization of the same messages (the simulator's bag writer): an IMU reading and a
// mono8 image, frame_id as given.
std::vector<std::uint8_t> EncodeRos1Imu(const RosImu& imu, const std::string& frame_id);
std::vector<std::uint8_t> EncodeRos1Mono8(std::int64_t t_ns, const cv::Mat& image,
                                          const std::string& frame_id);

}  // namespace ctcal
