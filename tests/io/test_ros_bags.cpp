// ROS bags against an independent writer and reader (scripts/ros_bags.py: Debian's python3-rosbag
// for ROS1, python's sqlite3 and its own CDR encoder for ROS2): a dataset folder written as a bag
// reads back through LoadBagDataset to the folder's exact samples and pixels, in every chunk
// compression and image encoding; ctcal's own bag reads identically in python3-rosbag; and every
// defect of the issue (truncated, unknown message type, topic missing, encoding not supported,
// stamps going back, another storage) is one error naming the topic or the message.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "ctcal/sensors/bag_dataset.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/ros_bag.h"
#include "ctcal/sim/dataset_bag.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

const std::string kScript = std::string(CTCAL_SOURCE_DIR) + "/scripts/ros_bags.py";

bool PythonRosbag() {
  static const bool ok =
      std::system("/usr/bin/python3 -c 'import rosbag, genpy, cv2' >/dev/null 2>&1") == 0;
  return ok;
}

#define REQUIRE_PYTHON_ROSBAG()                                                     \
  if (!PythonRosbag())                                                              \
  GTEST_SKIP() << "/usr/bin/python3 cannot import rosbag, genpy and cv2 (Debian's " \
                  "python3-rosbag, python3-opencv): the independent bag writer is missing"

void Python(const std::string& args) {
  const std::string cmd = "/usr/bin/python3 " + kScript + " " + args;
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
}

// A small dataset: imu0 (1 kHz), gyro0 (400 Hz) with random readings that need all 17 digits,
// cam0 with 6 grey images of 24x16 pixels at 20 Hz.
struct Folder {
  fs::path dir;
  std::vector<ImuSample> imu;
  std::vector<GyroSample> gyro;
  std::vector<ImageEntry> images;
  std::vector<cv::Mat> pixels;
};

const Folder& TestFolder() {
  static Folder f;
  if (!f.dir.empty())
    return f;
  f.dir = fs::path(::testing::TempDir()) / ("ctcal_bags_" + std::to_string(::getpid()));
  fs::remove_all(f.dir);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  const std::int64_t t0 = 1403636579758555392;
  for (int i = 0; i < 300; ++i)
    f.imu.push_back(
        {t0 + i * 1000000LL, {n(rng), n(rng), n(rng)}, {n(rng), n(rng), 9.81 + n(rng)}});
  for (int i = 0; i < 120; ++i)
    f.gyro.push_back({t0 + 300000 + i * 2500000LL, {n(rng), n(rng), n(rng)}});
  fs::create_directories(f.dir / "cam0" / "data");
  for (int i = 0; i < 6; ++i) {
    const std::int64_t t = t0 + 10000000 + i * 50000000LL;
    cv::Mat m(16, 24, CV_8UC1);
    cv::randu(m, 0, 256);
    const std::string name = std::to_string(t) + ".png";
    cv::imwrite((f.dir / "cam0" / "data" / name).string(), m);
    f.images.push_back({t, name});
    f.pixels.push_back(m);
  }
  WriteImuCsv((f.dir / "imu0" / "data.csv").string(), f.imu);
  WriteGyroCsv((f.dir / "gyro0" / "data.csv").string(), f.gyro);
  WriteImageCsv((f.dir / "cam0" / "data.csv").string(), f.images);
  return f;
}

RigConfig BagRig() {
  RigConfig rig;
  rig.base_imu = "imu0";
  for (const auto& [name, type, topic] :
       std::vector<std::tuple<std::string, SensorType, std::string>>{
           {"imu0", SensorType::kImu, "/imu0"},
           {"gyro0", SensorType::kGyro, "/gyro0"},
           {"cam0", SensorType::kCamera, "/cam0/image_raw"}}) {
    SensorConfig s;
    s.name = name;
    s.type = type;
    s.rostopic = topic;
    rig.sensors.push_back(s);
  }
  return rig;
}

// Reads a bag and checks it against the folder: samples exactly, images to `max_error` grey
// levels (0: lossless) once converted to grey.
void ExpectSameAsFolder(const std::string& bag, double max_error) {
  const Folder& f = TestFolder();
  std::vector<std::pair<std::int64_t, cv::Mat>> images;
  Warnings warnings;
  const auto data = LoadBagDataset(
      bag, BagRig(),
      [&](BagImage&& image) {
        EXPECT_EQ(image.index, images.size());
        EXPECT_EQ(image.total, f.images.size());
        images.emplace_back(image.image.t_ns, RosImageToMat(image.image));
      },
      &warnings);
  const SensorData& imu = data.at("imu0");
  ASSERT_EQ(imu.imu.size(), f.imu.size()) << bag;
  for (std::size_t i = 0; i < f.imu.size(); ++i) {
    EXPECT_EQ(imu.imu[i].t_ns, f.imu[i].t_ns);
    EXPECT_EQ(imu.imu[i].w_m, f.imu[i].w_m) << bag << " " << i;
    EXPECT_EQ(imu.imu[i].a_m, f.imu[i].a_m) << bag << " " << i;
  }
  const SensorData& gyro = data.at("gyro0");
  ASSERT_EQ(gyro.gyro.size(), f.gyro.size()) << bag;
  for (std::size_t i = 0; i < f.gyro.size(); ++i) {
    EXPECT_EQ(gyro.gyro[i].t_ns, f.gyro[i].t_ns);
    EXPECT_EQ(gyro.gyro[i].w_m, f.gyro[i].w_m);
  }
  EXPECT_FALSE(data.at("cam0").has_corners);
  ASSERT_EQ(images.size(), f.images.size()) << bag;
  for (std::size_t i = 0; i < images.size(); ++i) {
    EXPECT_EQ(images[i].first, f.images[i].t_ns);
    cv::Mat m = images[i].second;
    if (m.depth() == CV_16U)
      m.convertTo(m, CV_8U, 1.0 / 257.0);
    if (m.channels() == 3)
      cv::cvtColor(m, m, cv::COLOR_BGR2GRAY);
    if (m.channels() == 4)
      cv::cvtColor(m, m, cv::COLOR_BGRA2GRAY);
    ASSERT_EQ(m.size(), f.pixels[i].size()) << bag;
    EXPECT_LE(cv::norm(m, f.pixels[i], cv::NORM_INF), max_error) << bag << " image " << i;
  }
  EXPECT_TRUE(warnings.empty()) << warnings.front();
}

fs::path Out(const std::string& name) {
  return TestFolder().dir.string() + "_" + name;
}

TEST(RosBags, Ros1EveryCompression) {
  REQUIRE_PYTHON_ROSBAG();
  for (const char* c : {"none", "bz2", "lz4"}) {
    const std::string bag = Out(std::string(c) + ".bag").string();
    Python("ros1 " + TestFolder().dir.string() + " " + bag + " --compression " + c);
    ExpectSameAsFolder(bag, 0.0);
  }
}

TEST(RosBags, Ros1EveryImageEncoding) {
  REQUIRE_PYTHON_ROSBAG();
  for (const char* e : {"mono8", "mono16", "rgb8", "bgr8", "rgba8", "bgra8", "png", "jpeg"}) {
    const std::string bag = Out(std::string("enc_") + e + ".bag").string();
    Python("ros1 " + TestFolder().dir.string() + " " + bag + " --compression lz4 --encoding " + e);
    // Random pixels are JPEG's worst case; quality 98 keeps them within a few dozen levels.
    ExpectSameAsFolder(bag, std::string(e) == "jpeg" ? 64.0 : 0.0);
  }
}

TEST(RosBags, Ros2FolderAndDb3InBothByteOrders) {
  REQUIRE_PYTHON_ROSBAG();
  const std::string little = Out("ros2").string(), big = Out("ros2_be").string();
  Python("ros2 " + TestFolder().dir.string() + " " + little);
  Python("ros2 " + TestFolder().dir.string() + " " + big + " --big-endian --encoding mono16");
  ExpectSameAsFolder(little, 0.0);
  ExpectSameAsFolder(little + "/" + fs::path(little).filename().string() + "_0.db3", 0.0);
  ExpectSameAsFolder(big, 0.0);
  const std::string png = Out("ros2_png").string();
  Python("ros2 " + TestFolder().dir.string() + " " + png + " --encoding png");
  ExpectSameAsFolder(png, 0.0);
}

// ctcal's writer (simulate --bag) against python3-rosbag's reader: the same messages, stamps and
// values, and read back by ctcal to the folder's.
TEST(RosBags, CtcalBagReadsInPythonRosbag) {
  REQUIRE_PYTHON_ROSBAG();
  const std::string bag = Out("ctcal.bag").string();
  sim::WriteDatasetBag(TestFolder().dir.string(), BagRig(), bag, RosBagCompression::kLz4);
  ExpectSameAsFolder(bag, 0.0);
  const std::string dump = Out("ctcal.txt").string();
  Python("dump " + bag + " > " + dump);
  std::ifstream in(dump);
  std::map<std::string, int> count;
  std::string line;
  const Folder& f = TestFolder();
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string topic, type;
    std::int64_t t = 0;
    s >> topic >> type >> t;
    const int i = count[topic]++;
    if (topic == "/imu0") {
      ASSERT_EQ(type, "sensor_msgs/Imu");
      EXPECT_EQ(t, f.imu[i].t_ns);
      double v[6];
      for (double& x : v)
        s >> x;
      EXPECT_EQ(Eigen::Vector3d(v[0], v[1], v[2]), f.imu[i].w_m) << line;
      EXPECT_EQ(Eigen::Vector3d(v[3], v[4], v[5]), f.imu[i].a_m) << line;
    } else if (topic == "/cam0/image_raw") {
      ASSERT_EQ(type, "sensor_msgs/Image");
      EXPECT_EQ(t, f.images[i].t_ns);
      std::string encoding;
      int w = 0, h = 0, n = 0;
      s >> encoding >> w >> h >> n;
      EXPECT_EQ(encoding, "mono8");
      EXPECT_EQ(w * h, n);
    }
  }
  EXPECT_EQ(count["/imu0"], static_cast<int>(f.imu.size()));
  EXPECT_EQ(count["/gyro0"], static_cast<int>(f.gyro.size()));
  EXPECT_EQ(count["/cam0/image_raw"], static_cast<int>(f.images.size()));
}

// The error LoadBagDataset gives for `bag` read with `rig`.
std::string LoadError(const std::string& bag, const RigConfig& rig = BagRig()) {
  try {
    LoadBagDataset(bag, rig, [](BagImage&&) {});
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  ADD_FAILURE() << bag << " loaded";
  return "";
}

TEST(RosBags, DefectsNameTheTopicOrMessage) {
  REQUIRE_PYTHON_ROSBAG();
  const std::string dir = TestFolder().dir.string();
  for (const char* kind : {"ros1", "ros2"}) {
    const std::string ext = std::string(kind) == "ros1" ? ".bag" : "";
    const auto bad = [&](const std::string& what) {
      const std::string bag = Out(std::string(kind) + "_" + what + ext).string();
      Python(std::string(kind) + " " + dir + " " + bag + " --bad " + what);
      return bag;
    };
    EXPECT_THAT(LoadError(bad("unknown_type")),
                HasSubstr("topic '/gyro0' (sensor gyro0) carries geometry_msgs/Vector3Stamped, "
                          "not sensor_msgs/Imu"))
        << kind;
    EXPECT_THAT(LoadError(bad("encoding")),
                HasSubstr("topic '/cam0/image_raw' message 0: image encoding 'bayer_rggb8' is not "
                          "supported"))
        << kind;
    EXPECT_THAT(LoadError(bad("stamps_back")),
                HasSubstr("topic '/cam0/image_raw' message 1: header stamp"))
        << kind;
    RigConfig missing = BagRig();
    missing.sensors[0].rostopic = "/imu9";
    EXPECT_THAT(LoadError(bad("none"), missing),
                HasSubstr("topic '/imu9' (sensor imu0) is not in the bag (its topics: "
                          "/cam0/image_raw (sensor_msgs/Image), /gyro0 (sensor_msgs/Imu), /imu0 "
                          "(sensor_msgs/Imu))"))
        << kind;
    RigConfig unnamed = BagRig();
    unnamed.sensors[2].rostopic.reset();
    EXPECT_THAT(LoadError(bad("none"), unnamed),
                HasSubstr("sensor 'cam0' of the rig has no rostopic"));
  }
}

// A file cut short, as a recording stopped by a crash leaves it: the bag's path and why, never a
// crash or a silently shorter recording. A .db3 cut by 0.5 % loses only pages SQLite does not
// need to list every row (the timestamp index): its header's page count still tells the cut.
TEST(RosBags, TruncatedBagsAreOneError) {
  REQUIRE_PYTHON_ROSBAG();
  const std::string full = Out("full.bag").string();
  Python("ros1 " + TestFolder().dir.string() + " " + full + " --compression bz2");
  const std::string ros2 = Out("cut_ros2").string();
  Python("ros2 " + TestFolder().dir.string() + " " + ros2);
  // rosbag2 names the database after its folder: <folder>_0.db3.
  const std::string db3 = ros2 + "/" + fs::path(ros2).filename().string() + "_0.db3";
  for (const std::string& src : {full, db3}) {
    const std::uintmax_t size = fs::file_size(src);
    for (double fraction : {0.05, 0.5, 0.97, 0.995}) {
      const std::string cut = src + ".cut" + fs::path(src).extension().string();
      fs::copy_file(src, cut, fs::copy_options::overwrite_existing);
      fs::resize_file(cut, static_cast<std::uintmax_t>(fraction * static_cast<double>(size)));
      EXPECT_THAT(LoadError(cut), HasSubstr(cut + ": ")) << fraction;
    }
  }
}

// A bag kept from a fuzzing finding (tests/data/fuzz/NAME), written to Out(out) without the fuzz
// target's first byte (even: "a bag file"); empty when the kept input cannot be read.
std::string KeptFuzzBag(const std::string& name, const std::string& out) {
  const std::string input = std::string(CTCAL_SOURCE_DIR) + "/tests/data/fuzz/" + name;
  std::ifstream in(input, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.size() < 2)
    return "";
  const std::string bag = Out(out).string();
  std::ofstream(bag, std::ios::binary)
      .write(bytes.data() + 1, static_cast<std::streamsize>(bytes.size() - 1));
  return bag;
}

// The fuzzer's finding (docs/fuzzing.md): a 7.8 KB bag whose record after the bag header claims
// a 539 MB header (and whose index claims a 2.3 GB connection header). librosbag_storage would
// allocate what the length says; ctcal refuses the bag by the record's byte offset first.
TEST(RosBags, RecordLengthsPastTheFileEndAreRefusedBeforeAnyAllocation) {
  const std::string bag = KeptFuzzBag("ros1_bag_huge_connection_header.bag", "huge_header.bag");
  ASSERT_FALSE(bag.empty());
  const std::string error = LoadError(bag);
  EXPECT_THAT(error, HasSubstr(bag + ": the record at byte 4117 declares a header of 538976288"));
  EXPECT_THAT(error, HasSubstr("a damaged or cut bag"));
}

// Fuzzing finding (session 10, fuzz_ros1_bag): a chunk header whose field declares more bytes than
// its header holds made librosbag_storage's ros::Header::parse read past the buffer
// (AddressSanitizer heap-buffer-overflow in Bag::open -> readChunkHeader). Refused before
// Bag::open, naming the record.
TEST(RosBags, HeaderFieldsPastTheirHeaderAreRefusedBeforeTheLibraryParsesThem) {
  const std::string bag =
      KeptFuzzBag("ros1_bag_header_field_past_header.bag", "field_past_header.bag");
  ASSERT_FALSE(bag.empty());
  const std::string error = LoadError(bag);
  EXPECT_THAT(error, HasSubstr(bag + ": the record at byte "));
  EXPECT_THAT(error, HasSubstr("bytes past its header's end"));
  EXPECT_THAT(error, HasSubstr("a damaged bag"));
}

TEST(RosBags, Mcap2StorageIsRefusedByName) {
  REQUIRE_PYTHON_ROSBAG();
  const std::string bag = Out("mcap").string();
  Python("ros2 " + TestFolder().dir.string() + " " + bag + " --storage mcap");
  EXPECT_THAT(LoadError(bag), HasSubstr("storage 'mcap' is not supported"));
  std::ofstream(Out("x.mcap")) << "\x89MCAP0\r\n";
  EXPECT_THAT(LoadError(Out("x.mcap").string()), HasSubstr("storage 'mcap' is not supported"));
}

TEST(RosBags, KindOfPath) {
  EXPECT_EQ(RosBagKindOf("/nonexistent/x.bag"), RosBagKind::kRos1);
  EXPECT_EQ(RosBagKindOf("/nonexistent/x.db3"), RosBagKind::kRos2);
  EXPECT_EQ(RosBagKindOf(TestFolder().dir.string()), RosBagKind::kNone);  // a dataset folder
  EXPECT_THAT(LoadError("/nonexistent/x.bag"), HasSubstr("/nonexistent/x.bag: no such file"));
}

}  // namespace
}  // namespace ctcal
