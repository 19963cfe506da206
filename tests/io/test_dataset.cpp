// Dataset files of SPEC sections 6-7: exact write -> read round trips, validation, and the
// folder loader (a camera with corners needs no images).
#include <gtest/gtest.h>

#include <unistd.h>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig_yaml.h"
#include "io_test_util.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;

std::string TempDir(const std::string& name) {
  const fs::path dir =
      fs::path(::testing::TempDir()) / ("ctcal_dataset_" + std::to_string(getpid()) + "_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

void WriteText(const std::string& path, const std::string& text) {
  fs::create_directories(fs::path(path).parent_path());
  std::ofstream(path) << text;
}

using test::RandomDouble;

Eigen::Vector3d RandomVec(std::mt19937_64& rng) {
  return Eigen::Vector3d(RandomDouble(rng), RandomDouble(rng), RandomDouble(rng));
}

bool Same(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::memcmp(a.data(), b.data(), sizeof(double) * 3) == 0;
}

TEST(Dataset, ImuAndGyroRoundTripsAreBitExact) {
  std::mt19937_64 rng(1);
  std::vector<ImuSample> imu;
  std::vector<GyroSample> gyro;
  std::int64_t t = -5;  // any int64, negative included
  for (int i = 0; i < 500; ++i) {
    t += 1 + static_cast<std::int64_t>(rng() % 5000000);
    imu.push_back({t, RandomVec(rng), RandomVec(rng)});
    gyro.push_back({t, RandomVec(rng)});
  }
  const std::string dir = TempDir("inertial");
  WriteImuCsv(dir + "/imu0/data.csv", imu);
  WriteGyroCsv(dir + "/gyro0/data.csv", gyro);
  Warnings warnings;
  const std::vector<ImuSample> imu2 = ReadImuCsv(dir + "/imu0/data.csv", &warnings);
  const std::vector<GyroSample> gyro2 = ReadGyroCsv(dir + "/gyro0/data.csv", &warnings);
  ASSERT_EQ(imu2.size(), imu.size());
  ASSERT_EQ(gyro2.size(), gyro.size());
  for (std::size_t i = 0; i < imu.size(); ++i) {
    EXPECT_EQ(imu2[i].t_ns, imu[i].t_ns);
    EXPECT_TRUE(Same(imu2[i].w_m, imu[i].w_m) && Same(imu2[i].a_m, imu[i].a_m)) << i;
    EXPECT_EQ(gyro2[i].t_ns, gyro[i].t_ns);
    EXPECT_TRUE(Same(gyro2[i].w_m, gyro[i].w_m)) << i;
  }
}

TEST(Dataset, CornersImagesTruthAndBiasesRoundTrip) {
  std::mt19937_64 rng(2);
  const std::string dir = TempDir("cam");
  std::vector<ImageEntry> images;
  std::vector<CornerObservation> corners, corners_sigma;
  std::vector<GroundTruthState> truth;
  std::vector<BiasSample> imu_bias, gyro_bias;
  for (int f = 0; f < 20; ++f) {
    const std::int64_t t = 1403709385487836928 + f * 50000000LL;
    images.push_back({t, std::to_string(t) + ".png"});
    for (int id = f; id < 144; id += 7) {
      corners.push_back({t, id, RandomDouble(rng), RandomDouble(rng), std::nullopt});
      corners_sigma.push_back({t, id, 100.5 + id, 200.25, 0.5 + id * 1e-3});
    }
    GroundTruthState s;
    s.t_ns = t;
    s.p_W_B = RandomVec(rng);
    s.q_W_B = Eigen::Quaterniond(0.5, -0.5, 0.5, 0.5);
    s.v_W = RandomVec(rng);
    s.b_g = RandomVec(rng);
    s.b_a = RandomVec(rng);
    truth.push_back(s);
    imu_bias.push_back({t, RandomVec(rng), RandomVec(rng)});
    gyro_bias.push_back({t, RandomVec(rng), std::nullopt});
  }
  WriteImageCsv(dir + "/cam0/data.csv", images);
  WriteCornersCsv(dir + "/cam0/corners.csv", corners);
  WriteCornersCsv(dir + "/cam1/corners.csv", corners_sigma);
  WriteGroundTruthCsv(dir + "/groundtruth/data.csv", truth);
  WriteBiasesCsv(dir + "/imu0/biases.csv", imu_bias);
  WriteBiasesCsv(dir + "/gyro0/biases.csv", gyro_bias);

  const std::vector<ImageEntry> images2 = ReadImageCsv(dir + "/cam0/data.csv", false);
  ASSERT_EQ(images2.size(), images.size());
  for (std::size_t i = 0; i < images.size(); ++i) {
    EXPECT_EQ(images2[i].t_ns, images[i].t_ns);
    EXPECT_EQ(images2[i].filename, images[i].filename);
  }
  std::set<std::int64_t> stamps;
  for (const ImageEntry& e : images)
    stamps.insert(e.t_ns);
  for (const auto* set : {&corners, &corners_sigma}) {
    const std::string path = dir + (set == &corners ? "/cam0" : "/cam1") + "/corners.csv";
    const std::vector<CornerObservation> back = ReadCornersCsv(path, 144, &stamps);
    ASSERT_EQ(back.size(), set->size());
    for (std::size_t i = 0; i < back.size(); ++i) {
      const CornerObservation& a = (*set)[i];
      EXPECT_EQ(back[i].t_ns, a.t_ns);
      EXPECT_EQ(back[i].corner_id, a.corner_id);
      EXPECT_EQ(std::memcmp(&back[i].u, &a.u, sizeof(double)), 0);
      EXPECT_EQ(std::memcmp(&back[i].v, &a.v, sizeof(double)), 0);
      EXPECT_EQ(back[i].sigma, a.sigma);
    }
  }
  const std::vector<GroundTruthState> truth2 = ReadGroundTruthCsv(dir + "/groundtruth/data.csv");
  ASSERT_EQ(truth2.size(), truth.size());
  for (std::size_t i = 0; i < truth.size(); ++i) {
    EXPECT_EQ(truth2[i].t_ns, truth[i].t_ns);
    EXPECT_TRUE(Same(truth2[i].p_W_B, truth[i].p_W_B) && Same(truth2[i].v_W, truth[i].v_W) &&
                Same(truth2[i].b_g, truth[i].b_g) && Same(truth2[i].b_a, truth[i].b_a));
    EXPECT_EQ(truth2[i].q_W_B.coeffs(), truth[i].q_W_B.coeffs());
  }
  const std::vector<BiasSample> ib = ReadBiasesCsv(dir + "/imu0/biases.csv", true);
  const std::vector<BiasSample> gb = ReadBiasesCsv(dir + "/gyro0/biases.csv", false);
  ASSERT_EQ(ib.size(), imu_bias.size());
  for (std::size_t i = 0; i < ib.size(); ++i) {
    EXPECT_TRUE(Same(ib[i].b_g, imu_bias[i].b_g) && Same(*ib[i].b_a, *imu_bias[i].b_a));
    EXPECT_TRUE(Same(gb[i].b_g, gyro_bias[i].b_g));
    EXPECT_FALSE(gb[i].b_a.has_value());
  }
  // A gyro's biases read as an imu's: wrong column count, named with the line.
  try {
    ReadBiasesCsv(dir + "/gyro0/biases.csv", true);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("biases.csv:1: header has 4 columns, expected 7"),
              std::string::npos)
        << e.what();
  }
}

TEST(Dataset, GapsAreAWarningWithTheirCount) {
  std::vector<ImuSample> imu;
  std::int64_t t = 0;
  for (int i = 0; i < 100; ++i) {
    t += (i == 30 || i == 60) ? 20000000 : 5000000;  // two 20 ms gaps in 5 ms sampling
    imu.push_back({t, Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, 9.81)});
  }
  const std::string dir = TempDir("gaps");
  WriteImuCsv(dir + "/imu0/data.csv", imu);
  Warnings warnings;
  EXPECT_EQ(ReadImuCsv(dir + "/imu0/data.csv", &warnings).size(), 100u);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("2 gap(s)"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("median 0.005 s"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("longest 0.02 s"), std::string::npos) << warnings[0];
  // Regular sampling: no warning.
  imu.resize(20);
  for (std::size_t i = 0; i < imu.size(); ++i)
    imu[i].t_ns = static_cast<std::int64_t>(i) * 5000000;
  WriteImuCsv(dir + "/imu0/data.csv", imu);
  warnings.clear();
  ReadImuCsv(dir + "/imu0/data.csv", &warnings);
  EXPECT_TRUE(warnings.empty());
}

TEST(Dataset, ReadsFilesWithoutHeaderAndWithWindowsLineEnds) {
  const std::string dir = TempDir("plain");
  WriteText(dir + "/imu0/data.csv", "100,1,2,3,4,5,6\r\n200,1, 2 ,3,4,5,6e-3\r\n");
  const std::vector<ImuSample> s = ReadImuCsv(dir + "/imu0/data.csv");
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s[1].t_ns, 200);
  EXPECT_EQ(s[1].a_m.z(), 6e-3);
  // EuRoC's own header names differ from ours; only the column count matters.
  WriteText(dir + "/imu1/data.csv",
            "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
            "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n"
            "1403636579758555392,-0.099134701513277898,0.14730578886832138,0.02722713633111154,"
            "8.1476917083333333,-0.37592158333333331,-2.4026292499999999\n");
  EXPECT_EQ(ReadImuCsv(dir + "/imu1/data.csv").front().w_m.x(), -0.099134701513277898);
}

// A "CSV UTF-8" file of a Windows program starts with a byte order mark: the header after it is
// still the header (it used to be read as a row, "timestamp '#timestamp [ns]' is not an integer"
// with the mark invisible), and a file without a header reads its first row.
TEST(Dataset, ByteOrderMarkBeforeTheFirstLineIsSkipped) {
  const std::string dir = TempDir("bom");
  WriteText(dir + "/imu0/data.csv",
            "\xEF\xBB\xBF#timestamp [ns],w_x,w_y,w_z [rad/s],a_x,a_y,a_z [m/s^2]\r\n"
            "100,1,2,3,4,5,6\r\n");
  const std::vector<ImuSample> s = ReadImuCsv(dir + "/imu0/data.csv");
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0].a_m.z(), 6.0);
  WriteText(dir + "/imu1/data.csv",
            "\xEF\xBB\xBF"
            "100,1,2,3,4,5,6\n200,1,2,3,4,5,7\n");
  const std::vector<ImuSample> t = ReadImuCsv(dir + "/imu1/data.csv");
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0].t_ns, 100);
  EXPECT_EQ(t[1].a_m.z(), 7.0);
}

// A blank line ends a file only at its end (tests/data/bad/imu_empty_line.csv: one in the
// middle stays an error at its own line).
TEST(Dataset, BlankLinesAtTheEndAreTheEndOfTheFile) {
  const std::string dir = TempDir("blank");
  WriteText(dir + "/gyro0/data.csv",
            "#timestamp [ns],w_x,w_y,w_z [rad/s]\n100,1,2,3\n200,4,5,6\n\n \r\n");
  const std::vector<GyroSample> s = ReadGyroCsv(dir + "/gyro0/data.csv");
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s[1].w_m.z(), 6.0);
  WriteText(dir + "/gyro1/data.csv", "100,1,2,3\n\n\n200,4,5,6\n");
  try {
    ReadGyroCsv(dir + "/gyro1/data.csv");
    FAIL() << "a blank line between rows accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("gyro1/data.csv:2: empty line"), std::string::npos)
        << e.what();
  }
}

TEST(Dataset, LoaderTakesCornersWithoutImagesAndChecksImagesOtherwise) {
  const std::string dir = TempDir("loader");
  const RigConfig rig = ParseRigString(R"(
base_imu: cam0
target: {target_type: aprilgrid, tagCols: 2, tagRows: 2, tagSize: 0.1, tagSpacing: 0.3}
sensors:
  cam0: {type: camera, camera_model: pinhole, intrinsics: [400, 400, 320, 240], resolution: [640, 480]}
  cam1: {type: camera, camera_model: pinhole, intrinsics: [400, 400, 320, 240], resolution: [640, 480],
         T_B_S: [[1,0,0,0.1],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}
)",
                                       "rig");
  // cam0: corners only. cam1: images only, one of them missing.
  WriteCornersCsv(dir + "/cam0/corners.csv", {{10, 0, 1.0, 2.0, {}}, {10, 15, 3.0, 4.0, {}}});
  WriteImageCsv(dir + "/cam1/data.csv", {{10, "10.png"}, {20, "20.png"}});
  WriteText(dir + "/cam1/data/10.png", "not really a png");
  try {
    LoadDataset(dir, rig);
    FAIL() << "a missing image was accepted";
  } catch (const std::runtime_error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("cam1/data.csv:3: image file"), std::string::npos) << msg;
    EXPECT_NE(msg.find("20.png does not exist (1 of 2 images missing)"), std::string::npos) << msg;
  }
  WriteText(dir + "/cam1/data/20.png", "not really a png");
  const auto data = LoadDataset(dir, rig);
  EXPECT_TRUE(data.at("cam0").has_corners);
  EXPECT_EQ(data.at("cam0").corners.size(), 2u);
  EXPECT_TRUE(data.at("cam0").images.empty());
  EXPECT_FALSE(data.at("cam1").has_corners);
  EXPECT_EQ(data.at("cam1").images.size(), 2u);
  // With a data.csv beside corners.csv, corner frames must be listed in it (images not needed).
  WriteImageCsv(dir + "/cam0/data.csv", {{20, "20.png"}});
  try {
    LoadDataset(dir, rig);
    FAIL() << "corners of an unlisted frame were accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cam0/corners.csv:2: frame 10 is not in the camera's "
                                         "data.csv"),
              std::string::npos)
        << e.what();
  }
  // Corner ids beyond the 2x2 grid (16 points).
  WriteImageCsv(dir + "/cam0/data.csv", {{10, "10.png"}});
  WriteCornersCsv(dir + "/cam0/corners.csv", {{10, 16, 1.0, 2.0, {}}});
  EXPECT_THROW(LoadDataset(dir, rig), std::runtime_error);
  WriteCornersCsv(dir + "/cam0/corners.csv", {{10, 15, 1.0, 2.0, {}}});
  fs::remove_all(dir + "/cam1");
  try {
    LoadDataset(dir, rig);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("sensor 'cam1' of the rig has no data"), std::string::npos)
        << e.what();
  }
}

TEST(Dataset, WritersRefuseWhatReadersWouldReject) {
  const std::string dir = TempDir("refuse");
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  EXPECT_THROW(WriteImuCsv(dir + "/a.csv", {{1, Eigen::Vector3d(NAN, 0, 0), zero}}),
               std::runtime_error);
  EXPECT_THROW(WriteGyroCsv(dir + "/b.csv", {{2, zero}, {2, zero}}), std::runtime_error);
  EXPECT_THROW(WriteCornersCsv(dir + "/c.csv", {{1, 0, 1, 1, 0.5}, {1, 1, 1, 1, std::nullopt}}),
               std::runtime_error);
}

TEST(Dataset, ReadsTheRealEurocCornerFiles) {
  const std::string dir = std::string(CTCAL_SHARED_DATA_DIR) + "/euroc_cam_april";
  if (!fs::is_directory(dir))
    GTEST_SKIP() << dir << " is absent (shared real data)";
  Warnings warnings;
  const RigConfig rig = LoadRig(dir + "/reference.yaml", &warnings);
  const auto data = LoadDataset(dir, rig, &warnings);
  for (const char* cam : {"cam0", "cam1"}) {
    const SensorData& d = data.at(cam);
    EXPECT_TRUE(d.has_corners);
    EXPECT_GT(d.corners.size(), 30u * 20u) << cam;
    std::set<std::int64_t> frames;
    for (const CornerObservation& c : d.corners)
      frames.insert(c.t_ns);
    EXPECT_EQ(frames.size(), 30u) << cam;
  }
}

}  // namespace
}  // namespace ctcal
