// `ctcal calibrate` on broken copies of a short simulated recording: every CSV of every sensor,
// the corners, the rig file, the images and recordings that cannot calibrate anything. Each case
// must end with exit code 2 and one error line naming the file and line, or the sensor and key
// (or, for a gap of an hour, a warning naming the file and a result within its sigma): never a
// signal, a hang (every run is under `timeout`) or a silent wrong answer. Cases that fail while
// reading fail the same way for either method (the files are read before the method is chosen):
// they alternate between spline and discrete; the cases that reach the initialisation run both.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "../calibrator/simulated_recording.h"
#include "cli_test_util.h"
#include "ctcal/sensors/compare.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;

constexpr int kTimeoutSeconds = 60;

std::vector<std::string> ReadLines(const fs::path& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);)
    lines.push_back(line);
  return lines;
}

void WriteLines(const fs::path& path, const std::vector<std::string>& lines) {
  std::ofstream out(path);
  for (const std::string& line : lines)
    out << line << "\n";
}

// A CSV line split at the commas.
std::vector<std::string> Fields(const std::string& line) {
  std::vector<std::string> f;
  std::size_t start = 0;
  for (std::size_t comma; (comma = line.find(',', start)) != std::string::npos; start = comma + 1)
    f.push_back(line.substr(start, comma - start));
  f.push_back(line.substr(start));
  return f;
}

std::string Join(const std::vector<std::string>& f) {
  std::string s;
  for (const std::string& x : f)
    s += (s.empty() ? "" : ",") + x;
  return s;
}

// Field `field` (0-based) of line `line` of a CSV set to `value`; "" removes the field.
void SetField(const fs::path& path, int line, int field, const std::string& value) {
  std::vector<std::string> lines = ReadLines(path);
  std::vector<std::string> f = Fields(lines.at(line - 1));
  if (value.empty())
    f.erase(f.begin() + field);
  else
    f.at(field) = value;
  lines[line - 1] = Join(f);
  WriteLines(path, lines);
}

// The first `count` lines of a file (the header and count - 1 rows).
void KeepLines(const fs::path& path, std::size_t count) {
  std::vector<std::string> lines = ReadLines(path);
  lines.resize(std::min(count, lines.size()));
  WriteLines(path, lines);
}

// Every row from line `from` on shifted by `shift_ns`.
void ShiftStamps(const fs::path& path, int from, std::int64_t shift_ns) {
  std::vector<std::string> lines = ReadLines(path);
  for (std::size_t i = from - 1; i < lines.size(); ++i) {
    std::vector<std::string> f = Fields(lines[i]);
    f[0] = std::to_string(std::stoll(f[0]) + shift_ns);
    lines[i] = Join(f);
  }
  WriteLines(path, lines);
}

// The first occurrence of `from` in the file replaced by `to` (which must be there: a case that
// breaks nothing would pass for the wrong reason).
void Replace(const fs::path& path, const std::string& from, const std::string& to) {
  std::string text = test::Slurp(path.string());
  const std::size_t at = text.find(from);
  if (at == std::string::npos)
    throw std::logic_error(path.string() + " holds no '" + from + "'");
  text.replace(at, from.size(), to);
  std::ofstream(path) << text;
}

// The first line holding `part` replaced by `line` ("": removed).
void ReplaceLine(const fs::path& path, const std::string& part, const std::string& line) {
  std::vector<std::string> lines = ReadLines(path);
  const auto at = std::find_if(lines.begin(), lines.end(), [&](const std::string& l) {
    return l.find(part) != std::string::npos;
  });
  if (at == lines.end())
    throw std::logic_error(path.string() + " has no line with '" + part + "'");
  if (line.empty())
    lines.erase(at);
  else
    *at = line;
  WriteLines(path, lines);
}

// The rows of a CSV up to the stamp `end_ns` (exclusive), header kept.
void KeepBefore(const fs::path& path, std::int64_t end_ns) {
  std::vector<std::string> lines = ReadLines(path), kept;
  for (const std::string& line : lines) {
    if (line.empty() || line[0] == '#' || std::stoll(Fields(line)[0]) < end_ns)
      kept.push_back(line);
  }
  WriteLines(path, kept);
}

struct Case {
  std::string name;
  std::function<void(const fs::path&)> breaks;  // applied to a copy of the recording
  std::vector<std::string> says;                // each in the error line
  bool both_methods = false;                    // reaches the initialisation
};

// Runs every case on its own copy of `recording` and checks its one error line.
void ExpectOneClearError(const std::string& recording, const std::vector<Case>& cases) {
  const fs::path root =
      fs::path(recording).parent_path() / (fs::path(recording).filename().string() + "_bad");
  fs::create_directories(root);
  int run = 0;
  for (const Case& c : cases) {
    const fs::path dir = root / c.name;
    fs::remove_all(dir);
    fs::copy(recording, dir, fs::copy_options::recursive);
    c.breaks(dir);
    std::vector<std::string> methods = {run++ % 2 ? "discrete" : "spline"};
    if (c.both_methods)
      methods = {"spline", "discrete"};
    for (const std::string& method : methods) {
      const std::string args = "calibrate --rig " + (dir / "rig.yaml").string() + " --data " +
                               dir.string() + " --out " + (dir / ("out_" + method)).string() +
                               " --threads 1 --method " + method;
      const test::CliRun r =
          test::RunCtcal(args, (dir / ("run_" + method)).string(), kTimeoutSeconds);
      SCOPED_TRACE(c.name + " (" + method + "): " + r.err);
      EXPECT_EQ(r.code, 2) << "124: timed out, > 128: a signal";
      // One error line, the last; the lines before it are warnings or Ceres' own log.
      const std::size_t at = r.err.find("ctcal calibrate: error: ");
      ASSERT_NE(at, std::string::npos);
      const std::string line = r.err.substr(at);
      EXPECT_EQ(test::Lines(line), 1);
      for (const std::string& s : c.says)
        EXPECT_NE(line.find(s), std::string::npos) << "expected '" << s << "'";
    }
  }
}

// A 4 s recording of the default rig (base and auxiliary IMU, gyro, two cameras), corners given.
std::string Recording(const std::string& name) {
  return test::SimulateOnce("ctcal_bad_input_" + name, "--scenario full --seed 3 --duration 4");
}

// Each stream file of each inertial sensor, broken at its line 5 (header, then rows).
TEST(CalibrateBadInput, InertialFiles) {
  std::vector<Case> cases;
  for (const std::string s : {"imu0", "imu1", "gyro0"}) {
    const std::string file = s + "/data.csv";
    const auto at = [file](const fs::path& d) { return d / file; };
    cases.push_back(
        {s + "_empty", [=](const fs::path& d) { std::ofstream(at(d)); }, {file + ": no samples"}});
    cases.push_back({s + "_header_only",
                     [=](const fs::path& d) { KeepLines(at(d), 1); },
                     {file + ": no samples"}});
    cases.push_back({s + "_columns",
                     [=](const fs::path& d) { SetField(at(d), 5, 3, ""); },
                     {file + ":5: expected", "columns"}});
    cases.push_back({s + "_text",
                     [=](const fs::path& d) { SetField(at(d), 5, 2, "abc"); },
                     {file + ":5: angular rate 'abc' is not a number"}});
    cases.push_back({s + "_nan",
                     [=](const fs::path& d) { SetField(at(d), 5, 1, "nan"); },
                     {file + ":5: angular rate is nan"}});
    cases.push_back({s + "_inf",
                     [=](const fs::path& d) { SetField(at(d), 5, 3, "-inf"); },
                     {file + ":5: angular rate is -inf"}});
    cases.push_back({s + "_stamp_text",
                     [=](const fs::path& d) { SetField(at(d), 5, 0, "1.5e9"); },
                     {file + ":5: timestamp '1.5e9' is not an integer"}});
    cases.push_back(
        {s + "_duplicate_stamp",
         [=](const fs::path& d) { SetField(at(d), 6, 0, Fields(ReadLines(at(d))[4])[0]); },
         {file + ":6: duplicate timestamp"}});
    cases.push_back({s + "_decreasing_stamp",
                     [=](const fs::path& d) {
                       std::vector<std::string> lines = ReadLines(at(d));
                       std::swap(lines[5], lines[6]);
                       WriteLines(at(d), lines);
                     },
                     {file + ":7: timestamp", "is before the previous one"}});
    cases.push_back({s + "_far_outside_range",
                     [=](const fs::path& d) { SetField(at(d), 100, 2, "1e4"); },
                     {file + ":100: angular rate 1e4 rad/s is beyond any IMU's range"}});
  }
  cases.push_back({"imu0_specific_force_far_outside_range",
                   [](const fs::path& d) { SetField(d / "imu0/data.csv", 300, 6, "1e6"); },
                   {"imu0/data.csv:300: specific force 1e6 m/s^2 is beyond any IMU's range"}});
  cases.push_back({"imu1_missing_folder",
                   [](const fs::path& d) { fs::remove_all(d / "imu1"); },
                   {"imu1: no such folder (sensor 'imu1' of the rig has no data)"}});
  ExpectOneClearError(Recording("inertial"), cases);
}

TEST(CalibrateBadInput, CornerFiles) {
  std::vector<Case> cases;
  for (const std::string cam : {"cam0", "cam1"}) {
    const std::string file = cam + "/corners.csv";
    const auto at = [file](const fs::path& d) { return d / file; };
    cases.push_back({cam + "_never_sees_the_board",
                     [=](const fs::path& d) { KeepLines(at(d), 1); },
                     {"sensor '" + cam + "': the camera never sees the board"},
                     true});
    cases.push_back({cam + "_columns",
                     [=](const fs::path& d) { SetField(at(d), 5, 4, ""); },
                     {file + ":5: expected 5 columns"}});
    cases.push_back({cam + "_text",
                     [=](const fs::path& d) { SetField(at(d), 5, 2, "x"); },
                     {file + ":5: u 'x' is not a number"}});
    cases.push_back({cam + "_nan",
                     [=](const fs::path& d) { SetField(at(d), 5, 3, "nan"); },
                     {file + ":5: v is nan"}});
    cases.push_back({cam + "_id_beyond_the_board",
                     [=](const fs::path& d) { SetField(at(d), 5, 1, "144"); },
                     {file + ":5: corner_id 144 is outside the target (ids 0..143)"}});
    cases.push_back({cam + "_u_outside_the_image",
                     [=](const fs::path& d) { SetField(at(d), 5, 2, "5000.5"); },
                     {file + ":5: corner (5000.5, ", "is outside the camera's"}});
    cases.push_back({cam + "_v_outside_the_image",
                     [=](const fs::path& d) { SetField(at(d), 5, 3, "-20"); },
                     {file + ":5: corner (", ", -20) is outside the camera's"}});
    cases.push_back({cam + "_sigma_zero",
                     [=](const fs::path& d) { SetField(at(d), 5, 4, "0"); },
                     {file + ":5: sigma must be > 0 px, got 0"}});
    cases.push_back({cam + "_sigma_negative",
                     [=](const fs::path& d) { SetField(at(d), 5, 4, "-1"); },
                     {file + ":5: sigma must be > 0 px, got -1"}});
    cases.push_back({cam + "_frame_not_listed",
                     [=](const fs::path& d) { KeepLines(d / cam / "data.csv", 1); },
                     {file + ":2: frame", "is not in the camera's data.csv"}});
    cases.push_back({cam + "_image_list_duplicate_stamp",
                     [=](const fs::path& d) {
                       const fs::path list = d / cam / "data.csv";
                       SetField(list, 3, 0, Fields(ReadLines(list)[1])[0]);
                     },
                     {cam + "/data.csv:3: duplicate timestamp"}});
  }
  ExpectOneClearError(Recording("corners"), cases);
}

TEST(CalibrateBadInput, RigFile) {
  const auto edit = [](std::string from, std::string to) {
    return [=](const fs::path& d) { Replace(d / "rig.yaml", from, to); };
  };
  const auto line = [](std::string part, std::string replacement) {
    return [=](const fs::path& d) { ReplaceLine(d / "rig.yaml", part, replacement); };
  };
  const std::vector<Case> cases = {
      {"missing_file",
       [](const fs::path& d) { fs::remove(d / "rig.yaml"); },
       {"rig.yaml: cannot open file"}},
      {"empty",
       [](const fs::path& d) { std::ofstream(d / "rig.yaml"); },
       {"rig.yaml: expected a rig file"}},
      {"malformed", edit("base_imu: imu0", "base_imu: [imu0"), {"rig.yaml:", "malformed YAML"}},
      {"missing_base_imu",
       edit("base_imu: imu0\n", ""),
       {"rig.yaml:1: missing required key 'base_imu'"}},
      {"missing_intrinsics",
       line("    intrinsics: [", ""),
       {"rig.yaml:", "sensors.cam0: missing required key 'intrinsics'"}},
      {"missing_noise",
       line("    noise: {gyroscope_noise_density", ""),
       {"rig.yaml:", "sensors.imu0: missing required key 'noise'"}},
      {"unknown_key",
       edit("    intrinsics: [", "    focal: ["),
       {"rig.yaml:", "sensors.cam0: unknown key 'focal'"}},
      {"rate_not_a_number",
       edit("update_rate: 300.0", "update_rate: fast"),
       {"rig.yaml:", "sensors.imu1.noise.update_rate: expected a number, got 'fast'"}},
      {"T_B_S_not_a_matrix",
       edit("T_B_S: [[", "T_B_S: identity #"),
       {"rig.yaml:", "sensors.imu1.T_B_S: expected a 4x4 matrix"}},
      {"unknown_camera_model",
       edit("camera_model: pinhole", "camera_model: fisheye"),
       {"rig.yaml:", "sensors.cam0: unknown camera_model 'fisheye'"}},
      {"unknown_distortion_model",
       edit("distortion_model: radtan", "distortion_model: kannala"),
       {"rig.yaml:", "sensors.cam0: unknown distortion_model 'kannala'"}},
      {"unknown_imu_model",
       edit("model: imu2", "model: scale_only"),
       {"rig.yaml:", "sensors.imu0: model: unknown IMU model 'scale_only'"}},
      {"unknown_sensor_type",
       edit("type: gyro", "type: lidar"),
       {"rig.yaml:", "sensors.gyro0: type: unknown sensor type 'lidar'"}},
      {"T_B_S_not_a_rotation",
       line("    T_B_S: [[",
            "    T_B_S: [[2.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], "
            "[0.0, 0.0, 0.0, 1.0]]"),
       {"rig.yaml:", "sensors.imu1.T_B_S: not a rigid transform"}},
      {"R_I_a_a_reflection",
       edit("R_I_a: [[1.0,", "R_I_a: [[-1.0,"),
       {"rig.yaml:", "sensors.imu0.R_I_a: not a rotation matrix"}},
      {"negative_rate",
       edit("update_rate: 300.0", "update_rate: -300.0"),
       {"rig.yaml:", "sensors.imu1.noise: update_rate must be"}},
      {"negative_noise",
       edit("gyroscope_noise_density: ", "gyroscope_noise_density: -"),
       {"rig.yaml:", "sensors.imu0.noise: gyroscope_noise_density must be >= 0"}},
      {"negative_resolution",
       edit("resolution: [", "resolution: [-"),
       {"rig.yaml:", "sensors.cam0: resolution: width and height must be > 0"}},
      {"negative_tag_size",
       edit("tagSize: ", "tagSize: -"),
       {"rig.yaml:", "target: tagSize must be > 0"}},
      {"negative_pixel_sigma",
       edit("pixel_sigma: ", "pixel_sigma: -"),
       {"rig.yaml:", "sensors.cam0: noise.pixel_sigma must be > 0"}},
      {"negative_focal_length",
       edit("intrinsics: [", "intrinsics: [-"),
       {"rig.yaml: sensors.cam0.intrinsics: camera model 'pinhole'",
        "focal lengths fu, fv must be positive"}},
      {"negative_line_delay",
       edit("line_delay: 0.0", "line_delay: -0.001"),
       {"rig.yaml:", "sensors.cam0: line_delay must be >= 0"}},
      {"time_offset_nan",
       edit("time_offset: 0.0", "time_offset: .nan"),
       {"rig.yaml:", "sensors.imu1.time_offset: expected a finite number"}},
      {"time_offset_an_hour",
       edit("time_offset: 0.0", "time_offset: 3600.0"),
       {"initialisation stage 'time offset', sensor 'imu1': sensor time ranges do not overlap"},
       true},
  };
  ExpectOneClearError(Recording("rig"), cases);
}

// Cameras given as images (detection first): a 1 s recording, so that detection is short.
TEST(CalibrateBadInput, Images) {
  const std::string recording = test::SimulateOnce(
      "ctcal_bad_input_images", "--scenario full --seed 3 --duration 1 --images");
  const auto first_image = [](const fs::path& d, const std::string& cam) {
    return d / cam / "data" / Fields(ReadLines(d / cam / "data.csv").at(1))[1];
  };
  const auto blank = [](const fs::path& d, const std::string& cam, cv::Size size) {
    for (const auto& e : fs::directory_iterator(d / cam / "data"))
      cv::imwrite(e.path().string(), cv::Mat(size, CV_8UC1, cv::Scalar(128)));
  };
  const std::vector<Case> cases = {
      {"missing_image",
       [=](const fs::path& d) { fs::remove(first_image(d, "cam0")); },
       {"cam0/data.csv:2: image file", "does not exist (1 of 20 images missing)"}},
      {"unreadable_images",
       [](const fs::path& d) {
         for (const auto& e : fs::directory_iterator(d / "cam1" / "data"))
           std::ofstream(e.path()) << "not a png";
       },
       {"stage 'corner detection', sensor 'cam1': no image could be read (first: cannot read "
        "image "}},
      {"image_of_another_size",
       [=](const fs::path& d) {
         fs::copy_file(first_image(d, "cam1"), first_image(d, "cam0"),
                       fs::copy_options::overwrite_existing);
       },
       {"stage 'corner detection', sensor 'cam0': ",
        " is 512x512 pixels, the rig's resolution is 752x480"}},
      {"board_never_in_view",
       [=](const fs::path& d) {
         blank(d, "cam1", {512, 512});
       },
       {"stage 'corner detection', sensor 'cam1': the board is in none of its 20 images"}},
  };
  ExpectOneClearError(recording, cases);
}

// Recordings that read well but cannot calibrate the rig.
TEST(CalibrateBadInput, Recordings) {
  const auto all_files = [](const fs::path& d, const std::function<void(const fs::path&)>& f) {
    for (const char* s : {"imu0", "imu1", "gyro0", "cam0", "cam1"})
      for (const char* file : {"data.csv", "corners.csv"})
        if (fs::exists(d / s / file))
          f(d / s / file);
  };
  const std::vector<Case> cases = {
      {"a_fifth_of_a_second",
       [=](const fs::path& d) {
         all_files(d, [](const fs::path& p) { KeepBefore(p, 1'200'000'000); });
       },
       {"sensor 'cam0': too few views of the board"},
       true},
      {"only_the_base_imu",
       [](const fs::path& d) {
         const std::string rig = test::Slurp((d / "rig.yaml").string());
         std::ofstream(d / "rig.yaml") << rig.substr(0, rig.find("  imu1:"));
       },
       {"sensor 'imu0': the rig has no camera"},
       true},
      {"at_rest",
       [=](const fs::path& d) {
         for (const char* s : {"imu0", "imu1", "gyro0"}) {
           std::vector<std::string> lines = ReadLines(d / s / "data.csv");
           std::vector<std::string> first = Fields(lines[1]);
           for (std::size_t i = 2; i < lines.size(); ++i) {
             first[0] = Fields(lines[i])[0];
             lines[i] = Join(first);
           }
           WriteLines(d / s / "data.csv", lines);
         }
       },
       {"stage 'time offset', sensor 'imu1': ambiguous correlation: no rotation"},
       true},
  };
  ExpectOneClearError(Recording("recordings"), cases);
}

// An hour's gap in an auxiliary gyro's stream: a warning naming the file, and the samples before
// the gap calibrate it (the ones an hour later are outside the trajectory and dropped).
TEST(CalibrateBadInput, AnHoursGapIsAWarningAndTheResultHoldsItsSigma) {
  const std::string recording = Recording("gap");
  const fs::path dir = recording + "_gap";
  fs::remove_all(dir);
  fs::copy(recording, dir, fs::copy_options::recursive);
  ShiftStamps(dir / "gyro0/data.csv", 402, 3'600'000'000'000);
  const test::CliRun r =
      test::RunCtcal("calibrate --rig " + (dir / "rig.yaml").string() + " --data " + dir.string() +
                         " --out " + (dir / "out").string() + " --threads 1",
                     (dir / "run").string(), kTimeoutSeconds);
  ASSERT_EQ(r.code, 0) << r.err;
  // In the log (stdout and OUT/log.txt), with the calibration's other findings.
  EXPECT_NE(r.out.find("warning: " + (dir / "gyro0/data.csv").string() +
                       ": 1 gap(s): intervals longer than 1.5x the median"),
            std::string::npos)
      << r.out;
  std::vector<std::string> warnings;
  const Comparison c = CompareRigs(LoadRig(recording + "/truth.yaml", &warnings),
                                   LoadRig((dir / "out/result.yaml").string(), &warnings));
  int finite = 0, within3 = 0;
  for (const ComparisonRow& row : c.rows) {
    if (!row.error_over_sigma)
      continue;
    ++finite;
    within3 += std::abs(*row.error_over_sigma) < 3.0;
  }
  ASSERT_GT(finite, 80);
  EXPECT_GE(within3, static_cast<int>(std::ceil(0.95 * finite)));
}

}  // namespace
}  // namespace ctcal
