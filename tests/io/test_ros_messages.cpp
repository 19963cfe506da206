// The ROS message decoders (ros_messages.h) against bytes laid out by hand: ROS1's packed
// little-endian fields, CDR's alignment from the end of the encapsulation header in both byte
// orders, every image encoding ctcal reads, and a clear error for every truncation.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "ctcal/sensors/ros_messages.h"

namespace ctcal {
namespace {

using ::testing::HasSubstr;

// A CDR writer for the tests, independent of the decoder: each field aligned to its size
// counted from the end of the 4-byte header, in the byte order asked for.
class CdrBytes {
 public:
  explicit CdrBytes(bool big_endian) : big_(big_endian) {
    bytes_ = {0, static_cast<std::uint8_t>(big_endian ? 0 : 1), 0, 0};
  }
  template <typename T>
  CdrBytes& Put(T v) {
    while ((bytes_.size() - 4) % sizeof(T))
      bytes_.push_back(0xAA);  // padding is never read: make it visible if it were
    std::uint8_t b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    for (std::size_t i = 0; i < sizeof(T); ++i)
      bytes_.push_back(b[big_ ? sizeof(T) - 1 - i : i]);
    return *this;
  }
  CdrBytes& String(const std::string& s) {
    Put(static_cast<std::uint32_t>(s.size() + 1));
    bytes_.insert(bytes_.end(), s.begin(), s.end());
    bytes_.push_back(0);
    return *this;
  }
  CdrBytes& Octets(const std::vector<std::uint8_t>& v) {
    Put(static_cast<std::uint32_t>(v.size()));
    bytes_.insert(bytes_.end(), v.begin(), v.end());
    return *this;
  }
  const std::vector<std::uint8_t>& bytes() const { return bytes_; }

 private:
  bool big_;
  std::vector<std::uint8_t> bytes_;
};

// sensor_msgs/msg/Imu with a frame_id of 2 characters: 3 bytes with the NUL, so the orientation's
// first double needs one byte of padding (offset 15 -> 16).
std::vector<std::uint8_t> CdrImu(bool big_endian, std::int32_t sec, std::uint32_t nsec,
                                 const Eigen::Vector3d& w, const Eigen::Vector3d& a) {
  CdrBytes c(big_endian);
  c.Put(sec).Put(nsec).String("ab");
  for (int k = 0; k < 13; ++k)
    c.Put(k == 3 ? 1.0 : 0.0);
  for (int k = 0; k < 3; ++k)
    c.Put(w(k));
  for (int k = 0; k < 9; ++k)
    c.Put(0.5);
  for (int k = 0; k < 3; ++k)
    c.Put(a(k));
  for (int k = 0; k < 9; ++k)
    c.Put(0.25);
  return c.bytes();
}

TEST(RosMessages, Ros1ImuRoundTripsExactly) {
  RosImu imu;
  imu.t_ns = 1403636579758555392;
  imu.angular_velocity = {-0.0991, 0.1315, 1e-300};
  imu.linear_acceleration = {8.1, -0.1, -9.81};
  const std::vector<std::uint8_t> bytes = EncodeRos1Imu(imu, "imu4");
  // seq, stamp, "imu4", 3 x (3 + 9 doubles) + 4 doubles of orientation.
  ASSERT_EQ(bytes.size(), 4u + 8 + 4 + 4 + 8 * (4 + 9 + 3 + 9 + 3 + 9));
  const RosImu back = DecodeRosImu(bytes.data(), bytes.size(), RosWire::kRos1);
  EXPECT_EQ(back.t_ns, imu.t_ns);
  EXPECT_EQ(back.angular_velocity, imu.angular_velocity);
  EXPECT_EQ(back.linear_acceleration, imu.linear_acceleration);
  // Every truncation is one clear error naming the field it ends in.
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    try {
      DecodeRosImu(bytes.data(), n, RosWire::kRos1);
      ADD_FAILURE() << "a message of " << n << " bytes decoded";
    } catch (const std::runtime_error& e) {
      EXPECT_THAT(e.what(), HasSubstr("message ends in")) << n;
    }
  }
}

TEST(RosMessages, CdrImuInBothByteOrdersWithAlignment) {
  const Eigen::Vector3d w(0.25, -1.5, 3e-7), a(9.81, -0.125, 1e5);
  for (bool big : {false, true}) {
    const std::vector<std::uint8_t> bytes = CdrImu(big, -2, 999999999, w, a);
    const RosImu imu = DecodeRosImu(bytes.data(), bytes.size(), RosWire::kCdr);
    EXPECT_EQ(imu.t_ns, -2 * 1000000000LL + 999999999) << big;  // ROS2's signed seconds
    EXPECT_EQ(imu.angular_velocity, w) << big;
    EXPECT_EQ(imu.linear_acceleration, a) << big;
    for (std::size_t n = 0; n < bytes.size(); ++n)
      EXPECT_THROW(DecodeRosImu(bytes.data(), n, RosWire::kCdr), std::runtime_error) << n;
  }
  std::vector<std::uint8_t> parameter_list = CdrImu(false, 1, 2, w, a);
  parameter_list[1] = 3;  // PL_CDR_LE: not what rmw writes for a plain message
  try {
    DecodeRosImu(parameter_list.data(), parameter_list.size(), RosWire::kCdr);
    ADD_FAILURE();
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("is not plain CDR"));
  }
}

TEST(RosMessages, StampNanosecondsBeyondASecondAreRefused) {
  const std::vector<std::uint8_t> bytes =
      CdrImu(false, 1, 1000000000u, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  EXPECT_THROW(DecodeRosImu(bytes.data(), bytes.size(), RosWire::kCdr), std::runtime_error);
}

// A grey ramp with structure in both directions, and its pixels in `encoding`'s layout.
cv::Mat Ramp() {
  cv::Mat g(7, 11, CV_8UC1);
  for (int y = 0; y < g.rows; ++y)
    for (int x = 0; x < g.cols; ++x)
      g.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(23 * x + 5 * y * y);
  return g;
}

RosImage AsRosImage(const cv::Mat& grey, const std::string& encoding, int pad) {
  cv::Mat px;
  bool big = false;
  if (encoding == "mono8") {
    px = grey;
  } else if (encoding == "mono16") {
    grey.convertTo(px, CV_16UC1, 257.0);
    big = true;  // stored big-endian below
  } else if (encoding == "rgb8" || encoding == "bgr8") {
    cv::cvtColor(grey, px, cv::COLOR_GRAY2BGR);
    px.at<cv::Vec3b>(0, 0) = encoding == "rgb8" ? cv::Vec3b(30, 20, 10) : cv::Vec3b(10, 20, 30);
  } else {
    cv::cvtColor(grey, px, cv::COLOR_GRAY2BGRA);
    px.at<cv::Vec4b>(0, 0) =
        encoding == "rgba8" ? cv::Vec4b(30, 20, 10, 255) : cv::Vec4b(10, 20, 30, 255);
  }
  RosImage r;
  r.encoding = encoding;
  r.width = static_cast<std::uint32_t>(px.cols);
  r.height = static_cast<std::uint32_t>(px.rows);
  r.step = static_cast<std::uint32_t>(px.cols * px.elemSize() + pad);
  r.big_endian = big;
  r.data.assign(std::size_t(r.step) * r.height, 0);
  for (int y = 0; y < px.rows; ++y) {
    std::memcpy(r.data.data() + std::size_t(y) * r.step, px.ptr(y), px.cols * px.elemSize());
    if (big) {
      for (int x = 0; x < px.cols; ++x)
        std::swap(r.data[y * r.step + 2 * x], r.data[y * r.step + 2 * x + 1]);
    }
  }
  return r;
}

TEST(RosMessages, EveryEncodingDecodesToTheSamePixels) {
  const cv::Mat grey = Ramp();
  for (const char* e : {"mono8", "mono16", "rgb8", "bgr8", "rgba8", "bgra8"}) {
    for (int pad : {0, 4}) {  // a step longer than the row
      const cv::Mat m = RosImageToMat(AsRosImage(grey, e, pad));
      ASSERT_EQ(m.size(), grey.size()) << e;
      cv::Mat back;
      if (m.depth() == CV_16U) {
        EXPECT_EQ(m.at<std::uint16_t>(1, 2), grey.at<std::uint8_t>(1, 2) * 257) << e;
        m.convertTo(back, CV_8U, 1.0 / 257.0);
      } else if (m.channels() == 1) {
        back = m;
      } else {
        // Colour comes out in OpenCV's BGR(A) order, whatever the message's order.
        const cv::Vec3b bgr = m.channels() == 3
                                  ? m.at<cv::Vec3b>(0, 0)
                                  : cv::Vec3b(m.at<cv::Vec4b>(0, 0)[0], m.at<cv::Vec4b>(0, 0)[1],
                                              m.at<cv::Vec4b>(0, 0)[2]);
        EXPECT_EQ(bgr, cv::Vec3b(10, 20, 30)) << e;
        cv::Mat rest = m.clone();
        cv::cvtColor(rest, back, m.channels() == 3 ? cv::COLOR_BGR2GRAY : cv::COLOR_BGRA2GRAY);
        back.at<std::uint8_t>(0, 0) = grey.at<std::uint8_t>(0, 0);
      }
      EXPECT_EQ(cv::norm(back, grey, cv::NORM_INF), 0.0) << e << " pad " << pad;
    }
  }
}

TEST(RosMessages, CompressedPngAndJpeg) {
  const cv::Mat grey = Ramp();
  for (const char* format : {"png", "jpeg", "mono8; jpeg compressed mono8"}) {
    RosImage r;
    r.compressed = true;
    r.encoding = format;
    const bool png = std::string(format) == "png";
    cv::imencode(png ? ".png" : ".jpg", grey, r.data, {cv::IMWRITE_JPEG_QUALITY, 100});
    const cv::Mat m = RosImageToMat(r);
    ASSERT_EQ(m.size(), grey.size()) << format;
    EXPECT_LE(cv::norm(m, grey, cv::NORM_INF), png ? 0.0 : 8.0) << format;
  }
}

TEST(RosMessages, UnsupportedOrShortImagesAreClearErrors) {
  RosImage bayer = AsRosImage(Ramp(), "mono8", 0);
  bayer.encoding = "bayer_rggb8";
  EXPECT_THROW(
      {
        try {
          RosImageToMat(bayer);
        } catch (const std::runtime_error& e) {
          EXPECT_THAT(e.what(), HasSubstr("encoding 'bayer_rggb8' is not supported"));
          throw;
        }
      },
      std::runtime_error);
  // A 16-bit image's rows must start on whole pixels (OpenCV would throw its own exception).
  EXPECT_THROW(CheckRosImage(AsRosImage(Ramp(), "mono16", 3)), std::runtime_error);
  EXPECT_NO_THROW(CheckRosImage(AsRosImage(Ramp(), "rgb8", 3)));
  RosImage shortened = AsRosImage(Ramp(), "rgb8", 0);
  shortened.data.pop_back();
  EXPECT_THROW(CheckRosImage(shortened), std::runtime_error);
  RosImage depth;
  depth.compressed = true;
  depth.encoding = "16UC1; compressedDepth png";
  depth.data = {1, 2, 3};
  EXPECT_THROW(CheckRosImage(depth), std::runtime_error);
  RosImage garbage;
  garbage.compressed = true;
  garbage.encoding = "jpeg";
  garbage.data = {0xFF, 0xD8, 0x00, 0x01};
  EXPECT_NO_THROW(CheckRosImage(garbage));  // the format is one ctcal reads, the bytes are not:
  // the decoder's error, whatever the format field says
  const auto error_of = [&](std::vector<std::uint8_t> bytes) -> std::string {
    garbage.data = std::move(bytes);
    try {
      RosImageToMat(garbage);
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_EQ(error_of({0xFF, 0xD8, 0x00, 0x01}),
            "the jpeg image of 4 bytes cannot be decoded: neither PNG nor JPEG (it starts with ff "
            "d8 00 01); ctcal reads PNG and JPEG images");
  EXPECT_THAT(error_of({0xFF, 0xD8, 0xFF, 0xE0}),  // a JPEG's first bytes
              HasSubstr("cannot be decoded: corrupt or truncated JPEG ("));
  EXPECT_THAT(error_of({'B', 'M', 0, 1}),
              HasSubstr("cannot be decoded: a BMP image; ctcal reads PNG and JPEG images"));
}

TEST(RosMessages, Ros1ImageMessageRoundTrips) {
  const cv::Mat grey = Ramp();
  const std::vector<std::uint8_t> bytes = EncodeRos1Mono8(1234567890123, grey, "cam0");
  const RosImage r = DecodeRosImage(bytes.data(), bytes.size(), RosWire::kRos1, false);
  EXPECT_EQ(r.t_ns, 1234567890123);
  EXPECT_EQ(r.encoding, "mono8");
  EXPECT_EQ(cv::norm(RosImageToMat(r), grey, cv::NORM_INF), 0.0);
  // CDR big-endian: a CompressedImage whose frame_id (5 bytes with its NUL) leaves the format's
  // length 3 bytes of padding.
  CdrBytes c(true);
  c.Put<std::int32_t>(5).Put<std::uint32_t>(7).String("cam0").String("png");
  std::vector<std::uint8_t> png;
  cv::imencode(".png", grey, png);
  c.Octets(png);
  const RosImage p = DecodeRosImage(c.bytes().data(), c.bytes().size(), RosWire::kCdr, true);
  EXPECT_EQ(p.t_ns, 5000000007);
  EXPECT_EQ(p.data, png);
}

}  // namespace
}  // namespace ctcal
