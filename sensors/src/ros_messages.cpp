#include "ctcal/sensors/ros_messages.h"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "ctcal/targets/image_file.h"

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "the ROS decoders read little-endian fields by copying them");

namespace ctcal {
namespace {

template <typename T>
T ByteSwapped(T value) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &value, sizeof(T));
  std::reverse(b, b + sizeof(T));
  std::memcpy(&value, b, sizeof(T));
  return value;
}

// Reads the fields of one message in order, bounds-checked; for CDR also the alignment and the
// byte order of the encapsulation header.
class WireReader {
 public:
  WireReader(const std::uint8_t* bytes, std::size_t size, RosWire wire)
      : p_(bytes), size_(size), cdr_(wire == RosWire::kCdr) {
    if (!cdr_)
      return;
    // Encapsulation: 2 bytes representation id (0x0000 CDR_BE, 0x0001 CDR_LE; 0x0002/0x0003 are
    // parameter lists, which rmw never writes for these plain structs), 2 bytes options.
    if (size_ < 4)
      throw std::runtime_error("CDR message of " + std::to_string(size_) +
                               " bytes has no encapsulation header");
    if (p_[0] != 0 || p_[1] > 1) {
      throw std::runtime_error("CDR encapsulation " + std::to_string(p_[0]) + "," +
                               std::to_string(p_[1]) + " is not plain CDR (0,0 or 0,1)");
    }
    big_endian_ = p_[1] == 0;
    pos_ = origin_ = 4;
  }

  template <typename T>
  T Primitive(const char* what) {
    if (cdr_) {
      // XCDR1: a primitive starts at a multiple of its size from the end of the header.
      const std::size_t misalign = (pos_ - origin_) % sizeof(T);
      if (misalign)
        Skip(sizeof(T) - misalign, what);
    }
    Need(sizeof(T), what);
    T value;
    std::memcpy(&value, p_ + pos_, sizeof(T));
    pos_ += sizeof(T);
    return big_endian_ ? ByteSwapped(value) : value;
  }
  double F64(const char* what) { return Primitive<double>(what); }
  std::uint32_t U32(const char* what) { return Primitive<std::uint32_t>(what); }

  std::string String(const char* what) {
    const std::uint32_t n = U32(what);
    Need(n, what);
    std::string s(reinterpret_cast<const char*>(p_ + pos_), n);
    pos_ += n;
    // CDR counts the terminating NUL.
    if (cdr_ && !s.empty() && s.back() == '\0')
      s.pop_back();
    return s;
  }
  std::vector<std::uint8_t> Bytes(const char* what) {
    const std::uint32_t n = U32(what);
    Need(n, what);
    std::vector<std::uint8_t> v(p_ + pos_, p_ + pos_ + n);
    pos_ += n;
    return v;
  }

  // std_msgs/Header: the stamp in nanoseconds (ROS1 has a seq first and an unsigned second).
  std::int64_t HeaderStamp() {
    if (!cdr_)
      U32("header.seq");
    const std::int64_t sec = cdr_ ? Primitive<std::int32_t>("header.stamp.sec")
                                  : static_cast<std::int64_t>(U32("header.stamp.sec"));
    const std::uint32_t nsec = U32("header.stamp.nanosec");
    if (nsec >= 1000000000u)
      throw std::runtime_error("header stamp has " + std::to_string(nsec) +
                               " nanoseconds (not below 1e9)");
    String("header.frame_id");
    return sec * 1000000000LL + nsec;
  }

 private:
  void Need(std::size_t n, const char* what) const {
    if (n > size_ - pos_) {
      throw std::runtime_error(std::string("message ends in ") + what + " (" +
                               std::to_string(size_) + " bytes, " + std::to_string(pos_ + n) +
                               " needed)");
    }
  }
  void Skip(std::size_t n, const char* what) {
    Need(n, what);
    pos_ += n;
  }

  const std::uint8_t* p_;
  std::size_t size_;
  bool cdr_;
  bool big_endian_ = false;
  std::size_t pos_ = 0;
  std::size_t origin_ = 0;
};

Eigen::Vector3d Vector3(WireReader& r, const char* what) {
  Eigen::Vector3d v;
  for (int k = 0; k < 3; ++k)
    v(k) = r.F64(what);
  return v;
}

void SkipF64(WireReader& r, int n, const char* what) {
  for (int k = 0; k < n; ++k)
    r.F64(what);
}

std::string Lower(std::string s) {
  for (char& c : s)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// ROS1 serialization of the fields ctcal writes.
class Ros1Writer {
 public:
  template <typename T>
  void Primitive(T value) {
    const auto* b = reinterpret_cast<const std::uint8_t*>(&value);
    out_.insert(out_.end(), b, b + sizeof(T));
  }
  void String(const std::string& s) {
    Primitive(static_cast<std::uint32_t>(s.size()));
    out_.insert(out_.end(), s.begin(), s.end());
  }
  void Header(std::int64_t t_ns, const std::string& frame_id) {
    if (t_ns < 0 || t_ns / 1000000000LL > std::numeric_limits<std::uint32_t>::max())
      throw std::runtime_error("stamp " + std::to_string(t_ns) + " ns is not a ROS1 time");
    Primitive<std::uint32_t>(0);  // seq
    Primitive(static_cast<std::uint32_t>(t_ns / 1000000000LL));
    Primitive(static_cast<std::uint32_t>(t_ns % 1000000000LL));
    String(frame_id);
  }
  std::vector<std::uint8_t>& bytes() { return out_; }

 private:
  std::vector<std::uint8_t> out_;
};

}  // namespace

RosImu DecodeRosImu(const std::uint8_t* bytes, std::size_t size, RosWire wire) {
  WireReader r(bytes, size, wire);
  RosImu imu;
  imu.t_ns = r.HeaderStamp();
  SkipF64(r, 4 + 9, "orientation");
  imu.angular_velocity = Vector3(r, "angular_velocity");
  SkipF64(r, 9, "angular_velocity_covariance");
  imu.linear_acceleration = Vector3(r, "linear_acceleration");
  SkipF64(r, 9, "linear_acceleration_covariance");
  return imu;
}

RosImage DecodeRosImage(const std::uint8_t* bytes, std::size_t size, RosWire wire,
                        bool compressed) {
  WireReader r(bytes, size, wire);
  RosImage image;
  image.compressed = compressed;
  image.t_ns = r.HeaderStamp();
  if (compressed) {
    image.encoding = r.String("format");
  } else {
    image.height = r.U32("height");
    image.width = r.U32("width");
    image.encoding = r.String("encoding");
    image.big_endian = r.Primitive<std::uint8_t>("is_bigendian") != 0;
    image.step = r.U32("step");
  }
  image.data = r.Bytes("data");
  return image;
}

namespace {

// The OpenCV type of an uncompressed encoding and the conversion to BGR(A) order (-1: none);
// type -1 when ctcal does not read the encoding.
std::pair<int, int> MatTypeOf(const std::string& e) {
  if (e == "mono8" || e == "8UC1")
    return {CV_8UC1, -1};
  if (e == "mono16" || e == "16UC1")
    return {CV_16UC1, -1};
  if (e == "bgr8" || e == "8UC3")
    return {CV_8UC3, -1};
  if (e == "rgb8")
    return {CV_8UC3, cv::COLOR_RGB2BGR};
  if (e == "bgra8" || e == "8UC4")
    return {CV_8UC4, -1};
  if (e == "rgba8")
    return {CV_8UC4, cv::COLOR_RGBA2BGRA};
  return {-1, -1};
}

}  // namespace

void CheckRosImage(const RosImage& image) {
  if (image.compressed) {
    const std::string format = Lower(image.encoding);
    if (format.find("compresseddepth") != std::string::npos ||
        (format.find("jpeg") == std::string::npos && format.find("jpg") == std::string::npos &&
         format.find("png") == std::string::npos)) {
      throw std::runtime_error("CompressedImage format '" + image.encoding +
                               "' is not supported (jpeg or png)");
    }
    if (image.data.empty())
      throw std::runtime_error("CompressedImage without data");
    return;
  }
  const int type = MatTypeOf(image.encoding).first;
  if (type < 0) {
    throw std::runtime_error("image encoding '" + image.encoding +
                             "' is not supported (mono8, mono16, rgb8, bgr8, rgba8, bgra8)");
  }
  if (image.width == 0 || image.height == 0 || image.width > 1u << 16 || image.height > 1u << 16)
    throw std::runtime_error("image of " + std::to_string(image.width) + "x" +
                             std::to_string(image.height) + " pixels");
  const std::uint64_t row = std::uint64_t(image.width) * CV_ELEM_SIZE(type);
  // OpenCV addresses rows in whole channels: a 16-bit image's step must be even.
  if (image.step % CV_ELEM_SIZE1(type)) {
    throw std::runtime_error("image step " + std::to_string(image.step) +
                             " is not a multiple of its " + std::to_string(CV_ELEM_SIZE1(type)) +
                             "-byte channels");
  }
  if (image.step < row || std::uint64_t(image.step) * image.height > image.data.size()) {
    throw std::runtime_error("image data of " + std::to_string(image.data.size()) +
                             " bytes is smaller than step " + std::to_string(image.step) + " x " +
                             std::to_string(image.height) + " rows of " + std::to_string(row) +
                             " bytes");
  }
}

cv::Mat RosImageToMat(const RosImage& image) {
  CheckRosImage(image);
  if (image.compressed) {
    // Throws "the <format> image of N bytes cannot be decoded: <why>".
    return DecodeImage(
        image.data.data(), image.data.size(),
        "the " + image.encoding + " image of " + std::to_string(image.data.size()) + " bytes");
  }
  const auto [type, code] = MatTypeOf(image.encoding);
  const cv::Mat view(static_cast<int>(image.height), static_cast<int>(image.width), type,
                     const_cast<std::uint8_t*>(image.data.data()), image.step);
  cv::Mat out;
  if (code >= 0)
    cv::cvtColor(view, out, code);
  else
    out = view.clone();
  if (type == CV_16UC1 && image.big_endian) {
    for (int y = 0; y < out.rows; ++y) {
      auto* p = out.ptr<std::uint16_t>(y);
      for (int x = 0; x < out.cols; ++x)
        p[x] = ByteSwapped(p[x]);
    }
  }
  return out;
}

std::vector<std::uint8_t> EncodeRos1Imu(const RosImu& imu, const std::string& frame_id) {
  Ros1Writer w;
  w.Header(imu.t_ns, frame_id);
  // Orientation unknown: the identity quaternion with covariance[0] = -1, as the message's own
  // comment asks of a sensor that does not estimate it.
  for (double q : {0.0, 0.0, 0.0, 1.0})
    w.Primitive(q);
  for (int k = 0; k < 9; ++k)
    w.Primitive(k == 0 ? -1.0 : 0.0);
  for (const Eigen::Vector3d* v : {&imu.angular_velocity, &imu.linear_acceleration}) {
    for (int k = 0; k < 3; ++k)
      w.Primitive((*v)(k));
    for (int k = 0; k < 9; ++k)
      w.Primitive(0.0);  // covariance unknown
  }
  return std::move(w.bytes());
}

std::vector<std::uint8_t> EncodeRos1Mono8(std::int64_t t_ns, const cv::Mat& image,
                                          const std::string& frame_id) {
  if (image.type() != CV_8UC1)
    throw std::runtime_error("a mono8 image must be CV_8UC1");
  Ros1Writer w;
  w.Header(t_ns, frame_id);
  w.Primitive(static_cast<std::uint32_t>(image.rows));
  w.Primitive(static_cast<std::uint32_t>(image.cols));
  w.String("mono8");
  w.Primitive<std::uint8_t>(0);
  w.Primitive(static_cast<std::uint32_t>(image.cols));
  w.Primitive(static_cast<std::uint32_t>(image.rows * image.cols));
  std::vector<std::uint8_t>& out = w.bytes();
  for (int y = 0; y < image.rows; ++y)
    out.insert(out.end(), image.ptr<std::uint8_t>(y), image.ptr<std::uint8_t>(y) + image.cols);
  return std::move(out);
}

}  // namespace ctcal
