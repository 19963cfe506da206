// The malformed-input corpus of tests/data/bad/: one file per error, each rejected with one clear
// message that names the file, the line where the file has it, and the sensor / key / value.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/kalibr_files.h"
#include "ctcal/sensors/rig_yaml.h"
#include "ctcal/targets/target_config.h"

namespace ctcal {
namespace {

enum class Reader {
  kRig,
  kTarget,
  kImu,
  kGyro,
  kImages,
  kCorners,
  kGroundTruth,
  kKalibrImu,
  kKalibrCamchain
};

struct BadFile {
  const char* file;
  Reader reader;
  // Every fragment must be in the message; the first is "<file>[:<line>]:".
  std::vector<std::string> fragments;
};

std::ostream& operator<<(std::ostream& os, const BadFile& b) {
  return os << b.file;
}

const std::vector<BadFile>& Corpus() {
  static const std::vector<BadFile> corpus = {
      {"rig_unknown_key.yaml",
       Reader::kRig,
       {"rig_unknown_key.yaml:15:", "sensors.cam0", "unknown key 'focal'", "type camera"}},
      {"rig_misplaced_key.yaml",
       Reader::kRig,
       {"rig_misplaced_key.yaml:6:", "sensors.imu0", "unknown key 'intrinsics'", "type imu"}},
      {"rig_base_with_T_B_S.yaml",
       Reader::kRig,
       {"rig_base_with_T_B_S.yaml:9:", "sensors.imu0", "T_B_S is not allowed on the base"}},
      {"rig_missing_base.yaml",
       Reader::kRig,
       {"rig_missing_base.yaml:1:", "base_imu", "'imu9' is not under sensors"}},
      {"rig_base_is_camera.yaml",
       Reader::kRig,
       {"rig_base_is_camera.yaml:1:", "base_imu", "'cam0' is a camera", "must be an imu"}},
      {"rig_dw_count.yaml",
       Reader::kRig,
       {"rig_dw_count.yaml:7:", "sensors.imu0", "Dw of model imu2 has 6 numbers", "got 9"}},
      {"rig_tg_count.yaml",
       Reader::kRig,
       {"rig_tg_count.yaml:7:", "sensors.imu0", "Tg of g_sensitivity upper has 6 numbers"}},
      {"rig_gyro_with_da.yaml",
       Reader::kRig,
       {"rig_gyro_with_da.yaml:17:", "sensors.gyro0", "gyroscope-only sensor has no Da"}},
      {"rig_gyro_full_rotation.yaml",
       Reader::kRig,
       {"rig_gyro_full_rotation.yaml:20:", "sensors.gyro0",
        "model full cannot estimate its rotation"}},
      {"rig_not_rigid.yaml",
       Reader::kRig,
       {"rig_not_rigid.yaml:14:", "sensors.cam0.T_B_S", "not a rigid transform"}},
      {"rig_sigma_shape.yaml",
       Reader::kRig,
       {"rig_sigma_shape.yaml:15:", "sensors.cam0.sigma.t_B_S", "expected 3 numbers, got 2"}},
      {"rig_sigma_unknown_key.yaml",
       Reader::kRig,
       {"rig_sigma_unknown_key.yaml:15:", "sensors.cam0.sigma", "unknown key 'Da'"}},
      {"rig_missing_noise.yaml",
       Reader::kRig,
       {"rig_missing_noise.yaml:5:", "sensors.imu0", "missing required key 'noise'"}},
      {"rig_wrong_rotation_key.yaml",
       Reader::kRig,
       {"rig_wrong_rotation_key.yaml:7:", "sensors.imu0", "R_I_w is not a parameter of model imu2",
        "it estimates R_I_a"}},
      {"rig_bad_estimate.yaml",
       Reader::kRig,
       {"rig_bad_estimate.yaml:15:", "sensors.cam0", "unknown estimate item 'focal'"}},
      {"rig_duplicate_key.yaml",
       Reader::kRig,
       {"rig_duplicate_key.yaml:15:", "sensors.cam0", "key 'intrinsics' is given twice"}},
      {"rig_malformed.yaml", Reader::kRig, {"rig_malformed.yaml:16:", "malformed YAML"}},
      {"rig_bad_number.yaml",
       Reader::kRig,
       {"rig_bad_number.yaml:12:", "sensors.cam0.intrinsics", "expected a number, got 'abc'"}},
      {"rig_distortion_count.yaml",
       Reader::kRig,
       {"rig_distortion_count.yaml:16:", "sensors.cam0",
        "distortion_coeffs of distortion_model radtan are 4 numbers, got 5"}},
      {"rig_camera_model.yaml",
       Reader::kRig,
       {"rig_camera_model.yaml:11:", "sensors.cam0", "unknown camera_model 'fisheye'"}},
      {"rig_line_delay_imu.yaml",
       Reader::kRig,
       {"rig_line_delay_imu.yaml:6:", "sensors.imu0", "line_delay applies to cameras only"}},
      {"rig_prior_sigma_zero.yaml",
       Reader::kRig,
       {"rig_prior_sigma_zero.yaml:15:", "sensors.cam0.prior_sigma.time_offset", "must be > 0"}},
      {"rig_unknown_top_key.yaml",
       Reader::kRig,
       {"rig_unknown_top_key.yaml:1:", "unknown key 'calibration' for a rig file"}},
      {"rig_missing_target.yaml",
       Reader::kRig,
       {"rig_missing_target.yaml:1:", "missing required key 'target'"}},
      {"rig_nan_intrinsics.yaml",
       Reader::kRig,
       {"rig_nan_intrinsics.yaml:12:", "sensors.cam0.intrinsics", "finite number, got '.nan'"}},
      {"target_unknown_type.yaml",
       Reader::kTarget,
       {"target_unknown_type.yaml:", "unknown target_type 'circles'"}},
      {"target_missing_key.yaml",
       Reader::kTarget,
       {"target_missing_key.yaml:", "missing required key 'tagSize'"}},
      {"imu_columns.csv", Reader::kImu, {"imu_columns.csv:3:", "expected 7 columns", "got 6"}},
      {"imu_nan.csv", Reader::kImu, {"imu_nan.csv:3:", "angular rate is nan"}},
      {"imu_duplicate_stamp.csv",
       Reader::kImu,
       {"imu_duplicate_stamp.csv:4:", "duplicate timestamp 2000"}},
      {"imu_decreasing.csv",
       Reader::kImu,
       {"imu_decreasing.csv:4:", "timestamp 2000 is before the previous one (3000)"}},
      {"imu_bad_number.csv", Reader::kImu, {"imu_bad_number.csv:3:", "'1.2.3' is not a number"}},
      {"imu_bad_header.csv",
       Reader::kImu,
       {"imu_bad_header.csv:1:", "header has 6 columns, expected 7"}},
      {"imu_bad_stamp.csv",
       Reader::kImu,
       {"imu_bad_stamp.csv:2:", "'1.5e9' is not an integer number of nanoseconds"}},
      {"imu_empty_line.csv", Reader::kImu, {"imu_empty_line.csv:3:", "empty line"}},
      {"imu_no_samples.csv", Reader::kImu, {"imu_no_samples.csv:", "no samples"}},
      {"gyro_inf.csv", Reader::kGyro, {"gyro_inf.csv:3:", "angular rate is -inf"}},
      {"gyro_out_of_range.csv",
       Reader::kGyro,
       {"gyro_out_of_range.csv:3:", "angular rate -5000 rad/s is beyond any IMU's range"}},
      {"imu_out_of_range.csv",
       Reader::kImu,
       {"imu_out_of_range.csv:3:", "specific force 9.81e6 m/s^2 is beyond any IMU's range"}},
      {"corners_outside_image.csv",
       Reader::kCorners,
       {"corners_outside_image.csv:3:",
        "corner (10.5, 520.5) is outside the camera's 752x480 image"}},
      {"corners_id_outside.csv",
       Reader::kCorners,
       {"corners_id_outside.csv:3:", "corner_id 144 is outside the target (ids 0..143)"}},
      {"corners_duplicate_id.csv",
       Reader::kCorners,
       {"corners_duplicate_id.csv:3:", "corner_id 3 appears twice in frame 1000"}},
      // Ids repeat from frame to frame; only a repeat within one frame is an error.
      {"corners_duplicate_id_later_frame.csv",
       Reader::kCorners,
       {"corners_duplicate_id_later_frame.csv:6:", "corner_id 3 appears twice in frame 2000"}},
      {"corners_frame_order.csv",
       Reader::kCorners,
       {"corners_frame_order.csv:3:", "before the previous frame"}},
      {"corners_bad_sigma.csv",
       Reader::kCorners,
       {"corners_bad_sigma.csv:3:", "sigma must be > 0 px, got -1"}},
      {"corners_columns.csv",
       Reader::kCorners,
       {"corners_columns.csv:2:", "expected 4 or 5 columns", "got 6"}},
      {"corners_sigma_column_missing.csv",
       Reader::kCorners,
       {"corners_sigma_column_missing.csv:3:", "expected 5 columns", "got 4"}},
      {"cam_empty_filename.csv", Reader::kImages, {"cam_empty_filename.csv:3:", "empty filename"}},
      {"rig_bad_sensor_name.yaml",
       Reader::kRig,
       {"rig_bad_sensor_name.yaml:9:", "'cam 0.left' cannot name a sensor"}},
      {"kalibr_imu_unknown_model.yaml",
       Reader::kKalibrImu,
       {"kalibr_imu_unknown_model.yaml:11:", "imu0",
        "'scale-misalignment-size-effect' is not supported"}},
      {"kalibr_camchain_missing_chain.yaml",
       Reader::kKalibrCamchain,
       {"kalibr_camchain_missing_chain.yaml:10:", "cam1", "missing required key 'T_cn_cnm1'"}},
      {"groundtruth_quaternion.csv",
       Reader::kGroundTruth,
       {"groundtruth_quaternion.csv:3:", "not a unit quaternion"}},
  };
  return corpus;
}

void Read(Reader reader, const std::string& path) {
  Warnings warnings;
  const InertialRange range;
  switch (reader) {
    case Reader::kRig:
      LoadRig(path, &warnings);
      break;
    case Reader::kTarget:
      LoadTargetConfig(path);
      break;
    case Reader::kImu:  // with LoadDataset's range check
      ReadImuCsv(path, &warnings, &range);
      break;
    case Reader::kGyro:
      ReadGyroCsv(path, &warnings, &range);
      break;
    case Reader::kImages:
      ReadImageCsv(path, false, &warnings);
      break;
    case Reader::kCorners: {
      const CornerImage image{752, 480, 1.0};      // LoadDataset's check of a 752x480 camera
      ReadCornersCsv(path, 144, nullptr, &image);  // a 6x6 aprilgrid
      break;
    }
    case Reader::kGroundTruth:
      ReadGroundTruthCsv(path);
      break;
    case Reader::kKalibrImu:  // the IMU file is read first: the camchain is not reached
      RigFromKalibr(path + ".camchain-not-read.yaml", path, TargetConfig{});
      break;
    case Reader::kKalibrCamchain:  // camera-only
      RigFromKalibr(path, "", TargetConfig{});
      break;
  }
}

class BadInput : public ::testing::TestWithParam<BadFile> {};

TEST_P(BadInput, IsRejectedWithItsSpecificMessage) {
  const BadFile& bad = GetParam();
  const std::string path = std::string(CTCAL_SOURCE_DIR) + "/tests/data/bad/" + bad.file;
  ASSERT_TRUE(std::filesystem::is_regular_file(path)) << path;
  try {
    Read(bad.reader, path);
    FAIL() << bad.file << " was accepted";
  } catch (const std::runtime_error& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.find('\n'), std::string::npos) << "one line: " << msg;
    EXPECT_EQ(msg.find(path), 0u) << "starts with the file: " << msg;
    for (const std::string& fragment : bad.fragments)
      EXPECT_NE(msg.find(fragment), std::string::npos) << "'" << fragment << "' in: " << msg;
  }
}

INSTANTIATE_TEST_SUITE_P(Corpus, BadInput, ::testing::ValuesIn(Corpus()),
                         [](const ::testing::TestParamInfo<BadFile>& param) {
                           std::string name = param.param.file;
                           for (char& c : name) {
                             if (!std::isalnum(static_cast<unsigned char>(c)))
                               c = '_';
                           }
                           return name;
                         });

// Every file of the corpus has its test (a new file without one fails here).
TEST(BadInputCorpus, EveryFileIsCovered) {
  std::set<std::string> listed;
  for (const BadFile& b : Corpus())
    listed.insert(b.file);
  for (const auto& entry :
       std::filesystem::directory_iterator(std::string(CTCAL_SOURCE_DIR) + "/tests/data/bad")) {
    EXPECT_TRUE(listed.count(entry.path().filename().string())) << entry.path();
  }
}

}  // namespace
}  // namespace ctcal
