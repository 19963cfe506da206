#include "ctcal/sensors/dataset.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <stdexcept>
#include <string_view>
#include <thread>

#include "ctcal/sensors/number_format.h"
#include "ctcal/sensors/parallel_for.h"
#include "dataset_gaps.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;

const char* const kImuHeader = "#timestamp [ns],w_x,w_y,w_z [rad/s],a_x,a_y,a_z [m/s^2]";
const char* const kGyroHeader = "#timestamp [ns],w_x,w_y,w_z [rad/s]";
const char* const kImageHeader = "#timestamp [ns],filename";
const char* const kCornersHeader = "#timestamp [ns],corner_id,u,v";
const char* const kCornersSigmaHeader = "#timestamp [ns],corner_id,u,v,sigma";
const char* const kGroundTruthHeader =
    "#timestamp [ns],p_x,p_y,p_z,q_w,q_x,q_y,q_z,v_x,v_y,v_z,bw_x,bw_y,bw_z,ba_x,ba_y,ba_z";
const char* const kGyroBiasHeader = "#timestamp [ns],bw_x,bw_y,bw_z";
const char* const kImuBiasHeader = "#timestamp [ns],bw_x,bw_y,bw_z,ba_x,ba_y,ba_z";

std::string_view Trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string_view::npos)
    return {};
  const auto e = s.find_last_not_of(" \t");
  return s.substr(b, e - b + 1);
}

// The fields of `line`, trimmed, as views into it (a dataset has millions of fields: no copies).
void SplitFields(std::string_view line, std::vector<std::string_view>* out) {
  out->clear();
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    out->push_back(Trim(line.substr(
        start, comma == std::string_view::npos ? std::string_view::npos : comma - start)));
    if (comma == std::string_view::npos)
      break;
    start = comma + 1;
  }
}

// One CSV file read row by row, with the file and line in every error.
class CsvFile {
 public:
  explicit CsvFile(const std::string& path) : path_(path), in_(path) {
    if (!in_)
      throw std::runtime_error(path + ": cannot open file");
  }

  // Reads the next data row; false at the end. Skips (and validates) the header line. The fields
  // view the row's text: valid until the next call.
  bool Next(std::vector<std::string_view>* fields) {
    std::string& line = line_;
    while (std::getline(in_, line)) {
      ++line_no_;
      if (!line.empty() && line.back() == '\r')
        line.pop_back();
      // A UTF-8 byte order mark, as Windows programs start a "CSV UTF-8" file with it.
      if (line_no_ == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0)
        line.erase(0, 3);
      if (line_no_ == 1 && !line.empty() && line[0] == '#') {
        SplitFields(std::string_view(line).substr(1), fields);
        header_columns_ = static_cast<int>(fields->size());
        continue;
      }
      // Blank lines at the end of a file (as some writers leave them) end it; one followed by a
      // row is an error at the blank line.
      if (Trim(line).empty()) {
        if (blank_line_no_ == 0)
          blank_line_no_ = line_no_;
        continue;
      }
      if (blank_line_no_ != 0) {
        line_no_ = blank_line_no_;
        Fail("empty line (a dataset file has one row per line, no blank lines)");
      }
      SplitFields(line, fields);
      return true;
    }
    return false;
  }

  // The column count fixed by the header (0 when the file has none).
  int header_columns() const { return header_columns_; }
  int line() const { return line_no_; }
  const std::string& path() const { return path_; }

  void CheckHeader(int columns, const char* expected) const {
    if (header_columns_ != 0 && header_columns_ != columns) {
      throw std::runtime_error(path_ + ":1: header has " + std::to_string(header_columns_) +
                               " columns, expected " + std::to_string(columns) + " (" + expected +
                               ")");
    }
  }

  void CheckColumns(const std::vector<std::string_view>& f, int columns,
                    const char* expected) const {
    if (static_cast<int>(f.size()) != columns) {
      Fail("expected " + std::to_string(columns) + " columns (" + expected + "), got " +
           std::to_string(f.size()));
    }
  }

  [[noreturn]] void Fail(const std::string& what) const {
    throw std::runtime_error(path_ + ":" + std::to_string(line_no_) + ": " + what);
  }

  std::int64_t Stamp(std::string_view s) const {
    std::int64_t v = 0;
    const auto res = std::from_chars(s.data(), s.data() + s.size(), v);
    if (s.empty() || res.ec != std::errc() || res.ptr != s.data() + s.size())
      Fail("timestamp '" + std::string(s) + "' is not an integer number of nanoseconds");
    return v;
  }

  int Int(std::string_view s, const char* what) const {
    int v = 0;
    const auto res = std::from_chars(s.data(), s.data() + s.size(), v);
    if (s.empty() || res.ec != std::errc() || res.ptr != s.data() + s.size())
      Fail(std::string(what) + " '" + std::string(s) + "' is not an integer");
    return v;
  }

  double Number(std::string_view s, const char* what) const {
    double v = 0.0;
    if (!ParseDouble(s, &v))
      Fail(std::string(what) + " '" + std::string(s) + "' is not a number");
    if (!std::isfinite(v))
      Fail(std::string(what) + " is " + std::string(s) + " (NaN and Inf are not measurements)");
    return v;
  }

  Eigen::Vector3d Vector3(const std::vector<std::string_view>& f, int first,
                          const char* what) const {
    return Eigen::Vector3d(Number(f[first], what), Number(f[first + 1], what),
                           Number(f[first + 2], what));
  }

  // A reading: finite, and within `range` on every axis when one is given (InertialRange).
  Eigen::Vector3d Reading(const std::vector<std::string_view>& f, int first, const char* what,
                          const double* range, const char* unit) const {
    const Eigen::Vector3d v = Vector3(f, first, what);
    for (int k = 0; range && k < 3; ++k) {
      if (std::abs(v[k]) > *range) {
        Fail(std::string(what) + " " + std::string(f[first + k]) + " " + unit +
             " is beyond any IMU's range (" + FormatDouble(*range) + " " + unit +
             " per axis): a corrupt sample, or not in the SPEC's units");
      }
    }
    return v;
  }

  // Strictly increasing stamps.
  void CheckIncreasing(std::int64_t t, bool first, std::int64_t previous) const {
    if (first)
      return;
    if (t == previous)
      Fail("duplicate timestamp " + std::to_string(t));
    if (t < previous) {
      Fail("timestamp " + std::to_string(t) + " is before the previous one (" +
           std::to_string(previous) + "); stamps must increase");
    }
  }

 private:
  std::string path_;
  std::ifstream in_;
  std::string line_;  // the current row's text, which Next's fields view
  int line_no_ = 0;
  int blank_line_no_ = 0;  // the first blank line, 0 while there is none
  int header_columns_ = 0;
};

void Warn(Warnings* warnings, const std::string& what) {
  if (warnings)
    warnings->push_back(what);
  else
    std::cerr << "warning: " << what << "\n";
}

}  // namespace

// Intervals longer than 1.5x the median: dropped samples or frames. A warning with their count,
// since the data stays usable (the spline bridges them) but the user should know.
void WarnGaps(const std::string& path, const std::vector<std::int64_t>& t, Warnings* warnings) {
  if (t.size() < 3)
    return;
  std::vector<std::int64_t> dt(t.size() - 1);
  for (std::size_t i = 1; i < t.size(); ++i)
    dt[i - 1] = t[i] - t[i - 1];
  std::vector<std::int64_t> sorted = dt;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double median = static_cast<double>(sorted[sorted.size() / 2]);
  int count = 0;
  std::int64_t longest = 0;
  std::size_t longest_at = 0;
  for (std::size_t i = 0; i < dt.size(); ++i) {
    if (static_cast<double>(dt[i]) > 1.5 * median) {
      ++count;
      if (dt[i] > longest) {
        longest = dt[i];
        longest_at = i + 1;
      }
    }
  }
  if (count > 0) {
    char buf[256];
    std::snprintf(buf, sizeof(buf),
                  "%d gap(s): intervals longer than 1.5x the median %.6g s; the longest %.6g s "
                  "before sample %zu (t = %lld ns)",
                  count, median * 1e-9, static_cast<double>(longest) * 1e-9, longest_at,
                  static_cast<long long>(t[longest_at]));
    Warn(warnings, path + ": " + buf);
  }
}

namespace {

std::ofstream OpenForWrite(const std::string& path) {
  const fs::path parent = fs::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty())
    fs::create_directories(parent, ec);
  std::ofstream f(path);
  if (!f)
    throw std::runtime_error(path + ": cannot write file");
  return f;
}

std::string Num(const std::string& path, double x, const char* what) {
  if (!std::isfinite(x))
    throw std::runtime_error(path + ": cannot write a non-finite " + std::string(what));
  return FormatDouble(x);
}

void CheckWriteOrder(const std::string& path, std::size_t i, std::int64_t t, std::int64_t prev) {
  if (i > 0 && t <= prev) {
    throw std::runtime_error(path + ": stamps must increase (row " + std::to_string(i) + " has " +
                             std::to_string(t) + " after " + std::to_string(prev) + ")");
  }
}

void Finish(std::ofstream& f, const std::string& path) {
  f.flush();
  if (!f)
    throw std::runtime_error(path + ": write failed");
}

}  // namespace

int TargetCornerCount(const TargetConfig& target) {
  if (target.type == TargetType::kAprilGrid)
    return 4 * target.tag_rows * target.tag_cols;
  if (target.type == TargetType::kCharuco)
    return (target.squares_x - 1) * (target.squares_y - 1);
  return target.target_rows * target.target_cols;
}

std::vector<ImuSample> ReadImuCsv(const std::string& path, Warnings* warnings,
                                  const InertialRange* range) {
  CsvFile csv(path);
  std::vector<ImuSample> out;
  std::vector<std::int64_t> stamps;
  std::vector<std::string_view> f;
  while (csv.Next(&f)) {
    csv.CheckHeader(7, kImuHeader);
    csv.CheckColumns(f, 7, kImuHeader);
    ImuSample s;
    s.t_ns = csv.Stamp(f[0]);
    csv.CheckIncreasing(s.t_ns, out.empty(), out.empty() ? 0 : out.back().t_ns);
    s.w_m = csv.Reading(f, 1, "angular rate", range ? &range->max_rate : nullptr, "rad/s");
    s.a_m =
        csv.Reading(f, 4, "specific force", range ? &range->max_specific_force : nullptr, "m/s^2");
    out.push_back(s);
    stamps.push_back(s.t_ns);
  }
  csv.CheckHeader(7, kImuHeader);
  if (out.empty())
    throw std::runtime_error(path + ": no samples");
  WarnGaps(path, stamps, warnings);
  return out;
}

std::vector<GyroSample> ReadGyroCsv(const std::string& path, Warnings* warnings,
                                    const InertialRange* range) {
  CsvFile csv(path);
  std::vector<GyroSample> out;
  std::vector<std::int64_t> stamps;
  std::vector<std::string_view> f;
  while (csv.Next(&f)) {
    csv.CheckHeader(4, kGyroHeader);
    csv.CheckColumns(f, 4, kGyroHeader);
    GyroSample s;
    s.t_ns = csv.Stamp(f[0]);
    csv.CheckIncreasing(s.t_ns, out.empty(), out.empty() ? 0 : out.back().t_ns);
    s.w_m = csv.Reading(f, 1, "angular rate", range ? &range->max_rate : nullptr, "rad/s");
    out.push_back(s);
    stamps.push_back(s.t_ns);
  }
  csv.CheckHeader(4, kGyroHeader);
  if (out.empty())
    throw std::runtime_error(path + ": no samples");
  WarnGaps(path, stamps, warnings);
  return out;
}

std::vector<ImageEntry> ReadImageCsv(const std::string& path, bool check_images,
                                     Warnings* warnings) {
  CsvFile csv(path);
  const fs::path image_dir = fs::path(path).parent_path() / "data";
  std::vector<ImageEntry> out;
  std::vector<std::int64_t> stamps;
  std::vector<std::string_view> f;
  int missing = 0;
  std::string first_missing;
  int first_missing_line = 0;
  while (csv.Next(&f)) {
    csv.CheckHeader(2, kImageHeader);
    csv.CheckColumns(f, 2, kImageHeader);
    ImageEntry e;
    e.t_ns = csv.Stamp(f[0]);
    csv.CheckIncreasing(e.t_ns, out.empty(), out.empty() ? 0 : out.back().t_ns);
    e.filename = std::string(f[1]);
    if (e.filename.empty())
      csv.Fail("empty filename");
    if (check_images && !fs::is_regular_file(image_dir / e.filename)) {
      if (missing++ == 0) {
        first_missing = (image_dir / e.filename).string();
        first_missing_line = csv.line();
      }
    }
    out.push_back(e);
    stamps.push_back(e.t_ns);
  }
  csv.CheckHeader(2, kImageHeader);
  if (missing > 0) {
    throw std::runtime_error(path + ":" + std::to_string(first_missing_line) + ": image file " +
                             first_missing + " does not exist (" + std::to_string(missing) +
                             " of " + std::to_string(out.size()) + " images missing)");
  }
  WarnGaps(path, stamps, warnings);
  return out;
}

std::vector<CornerObservation> ReadCornersCsv(const std::string& path, int num_corners,
                                              const std::set<std::int64_t>* frame_stamps,
                                              const CornerImage* image) {
  CsvFile csv(path);
  std::vector<CornerObservation> out;
  std::vector<std::string_view> f;
  int columns = 0;
  // The frame (its index in the file) that last held each corner id: a duplicate within a frame
  // in O(1), without a set per frame (a minute's corners are 300k rows).
  std::vector<int> frame_of_id(static_cast<std::size_t>(std::max(num_corners, 0)), -1);
  int frame = 0;
  while (csv.Next(&f)) {
    if (columns == 0) {
      columns = csv.header_columns() != 0 ? csv.header_columns() : static_cast<int>(f.size());
      if (columns != 4 && columns != 5) {
        csv.Fail("expected 4 or 5 columns (" + std::string(kCornersHeader) + "[,sigma]), got " +
                 std::to_string(columns));
      }
    }
    csv.CheckColumns(f, columns, columns == 4 ? kCornersHeader : kCornersSigmaHeader);
    CornerObservation c;
    c.t_ns = csv.Stamp(f[0]);
    if (!out.empty() && c.t_ns != out.back().t_ns) {
      if (c.t_ns < out.back().t_ns) {
        csv.Fail("timestamp " + std::to_string(c.t_ns) + " is before the previous frame (" +
                 std::to_string(out.back().t_ns) + "); frames must be in increasing time");
      }
      ++frame;
    }
    if (out.empty() || c.t_ns != out.back().t_ns) {
      if (frame_stamps && !frame_stamps->count(c.t_ns)) {
        csv.Fail("frame " + std::to_string(c.t_ns) +
                 " is not in the camera's data.csv (corners of an image that does not exist)");
      }
    }
    c.corner_id = csv.Int(f[1], "corner_id");
    if (c.corner_id < 0 || c.corner_id >= num_corners) {
      csv.Fail("corner_id " + std::to_string(c.corner_id) + " is outside the target (ids 0.." +
               std::to_string(num_corners - 1) + ")");
    }
    int& seen_in = frame_of_id[static_cast<std::size_t>(c.corner_id)];
    if (seen_in == frame) {
      csv.Fail("corner_id " + std::to_string(c.corner_id) + " appears twice in frame " +
               std::to_string(c.t_ns));
    }
    seen_in = frame;
    c.u = csv.Number(f[2], "u");
    c.v = csv.Number(f[3], "v");
    if (columns == 5) {
      c.sigma = csv.Number(f[4], "sigma");
      if (!(*c.sigma > 0.0))
        csv.Fail("sigma must be > 0 px, got " + std::string(f[4]));
    }
    if (image) {
      const double margin = 0.5 + 5.0 * c.sigma.value_or(image->pixel_sigma);
      if (!(c.u >= -margin && c.u <= image->width - 1 + margin && c.v >= -margin &&
            c.v <= image->height - 1 + margin)) {
        csv.Fail("corner (" + std::string(f[2]) + ", " + std::string(f[3]) +
                 ") is outside the camera's " + std::to_string(image->width) + "x" +
                 std::to_string(image->height) +
                 " image (by more than 5 sigma): another camera's corners, or the wrong "
                 "resolution?");
      }
    }
    out.push_back(c);
  }
  return out;
}

std::vector<GroundTruthState> ReadGroundTruthCsv(const std::string& path) {
  CsvFile csv(path);
  std::vector<GroundTruthState> out;
  std::vector<std::string_view> f;
  while (csv.Next(&f)) {
    csv.CheckHeader(17, kGroundTruthHeader);
    csv.CheckColumns(f, 17, kGroundTruthHeader);
    GroundTruthState s;
    s.t_ns = csv.Stamp(f[0]);
    csv.CheckIncreasing(s.t_ns, out.empty(), out.empty() ? 0 : out.back().t_ns);
    s.p_W_B = csv.Vector3(f, 1, "position");
    s.q_W_B = Eigen::Quaterniond(csv.Number(f[4], "q_w"), csv.Number(f[5], "q_x"),
                                 csv.Number(f[6], "q_y"), csv.Number(f[7], "q_z"));
    if (std::abs(s.q_W_B.norm() - 1.0) > 1e-6)
      csv.Fail("quaternion is not a unit quaternion (norm " + FormatDouble(s.q_W_B.norm()) + ")");
    s.v_W = csv.Vector3(f, 8, "velocity");
    s.b_g = csv.Vector3(f, 11, "gyro bias");
    s.b_a = csv.Vector3(f, 14, "accel bias");
    out.push_back(s);
  }
  csv.CheckHeader(17, kGroundTruthHeader);
  return out;
}

std::vector<BiasSample> ReadBiasesCsv(const std::string& path, bool with_accel) {
  CsvFile csv(path);
  const int columns = with_accel ? 7 : 4;
  const char* header = with_accel ? kImuBiasHeader : kGyroBiasHeader;
  std::vector<BiasSample> out;
  std::vector<std::string_view> f;
  while (csv.Next(&f)) {
    csv.CheckHeader(columns, header);
    csv.CheckColumns(f, columns, header);
    BiasSample b;
    b.t_ns = csv.Stamp(f[0]);
    csv.CheckIncreasing(b.t_ns, out.empty(), out.empty() ? 0 : out.back().t_ns);
    b.b_g = csv.Vector3(f, 1, "gyro bias");
    if (with_accel)
      b.b_a = csv.Vector3(f, 4, "accel bias");
    out.push_back(b);
  }
  csv.CheckHeader(columns, header);
  return out;
}

void WriteImuCsv(const std::string& path, const std::vector<ImuSample>& samples) {
  std::ofstream f = OpenForWrite(path);
  f << kImuHeader << "\n";
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const ImuSample& s = samples[i];
    CheckWriteOrder(path, i, s.t_ns, i ? samples[i - 1].t_ns : 0);
    f << s.t_ns;
    for (int k = 0; k < 3; ++k)
      f << "," << Num(path, s.w_m(k), "angular rate");
    for (int k = 0; k < 3; ++k)
      f << "," << Num(path, s.a_m(k), "specific force");
    f << "\n";
  }
  Finish(f, path);
}

void WriteGyroCsv(const std::string& path, const std::vector<GyroSample>& samples) {
  std::ofstream f = OpenForWrite(path);
  f << kGyroHeader << "\n";
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const GyroSample& s = samples[i];
    CheckWriteOrder(path, i, s.t_ns, i ? samples[i - 1].t_ns : 0);
    f << s.t_ns;
    for (int k = 0; k < 3; ++k)
      f << "," << Num(path, s.w_m(k), "angular rate");
    f << "\n";
  }
  Finish(f, path);
}

void WriteImageCsv(const std::string& path, const std::vector<ImageEntry>& images) {
  std::ofstream f = OpenForWrite(path);
  f << kImageHeader << "\n";
  for (std::size_t i = 0; i < images.size(); ++i) {
    CheckWriteOrder(path, i, images[i].t_ns, i ? images[i - 1].t_ns : 0);
    if (images[i].filename.empty() || images[i].filename.find(',') != std::string::npos)
      throw std::runtime_error(path + ": an image filename must be non-empty without commas");
    f << images[i].t_ns << "," << images[i].filename << "\n";
  }
  Finish(f, path);
}

void WriteCornersCsv(const std::string& path, const std::vector<CornerObservation>& corners) {
  const bool with_sigma = !corners.empty() && corners.front().sigma.has_value();
  std::ofstream f = OpenForWrite(path);
  f << (with_sigma ? kCornersSigmaHeader : kCornersHeader) << "\n";
  for (std::size_t i = 0; i < corners.size(); ++i) {
    const CornerObservation& c = corners[i];
    if (c.sigma.has_value() != with_sigma)
      throw std::runtime_error(path + ": either every corner has a sigma or none has");
    if (i > 0 && c.t_ns < corners[i - 1].t_ns)
      throw std::runtime_error(path + ": corner frames must be in increasing time");
    f << c.t_ns << "," << c.corner_id << "," << Num(path, c.u, "u") << "," << Num(path, c.v, "v");
    if (with_sigma)
      f << "," << Num(path, *c.sigma, "sigma");
    f << "\n";
  }
  Finish(f, path);
}

void WriteGroundTruthCsv(const std::string& path, const std::vector<GroundTruthState>& states) {
  std::ofstream f = OpenForWrite(path);
  f << kGroundTruthHeader << "\n";
  for (std::size_t i = 0; i < states.size(); ++i) {
    const GroundTruthState& s = states[i];
    CheckWriteOrder(path, i, s.t_ns, i ? states[i - 1].t_ns : 0);
    const double values[16] = {s.p_W_B.x(), s.p_W_B.y(), s.p_W_B.z(), s.q_W_B.w(),
                               s.q_W_B.x(), s.q_W_B.y(), s.q_W_B.z(), s.v_W.x(),
                               s.v_W.y(),   s.v_W.z(),   s.b_g.x(),   s.b_g.y(),
                               s.b_g.z(),   s.b_a.x(),   s.b_a.y(),   s.b_a.z()};
    f << s.t_ns;
    for (double v : values)
      f << "," << Num(path, v, "state");
    f << "\n";
  }
  Finish(f, path);
}

void WriteBiasesCsv(const std::string& path, const std::vector<BiasSample>& biases) {
  const bool with_accel = !biases.empty() && biases.front().b_a.has_value();
  std::ofstream f = OpenForWrite(path);
  f << (with_accel ? kImuBiasHeader : kGyroBiasHeader) << "\n";
  for (std::size_t i = 0; i < biases.size(); ++i) {
    const BiasSample& b = biases[i];
    CheckWriteOrder(path, i, b.t_ns, i ? biases[i - 1].t_ns : 0);
    if (b.b_a.has_value() != with_accel)
      throw std::runtime_error(path + ": either every row has an accel bias or none has");
    f << b.t_ns;
    for (int k = 0; k < 3; ++k)
      f << "," << Num(path, b.b_g(k), "gyro bias");
    if (with_accel) {
      for (int k = 0; k < 3; ++k)
        f << "," << Num(path, (*b.b_a)(k), "accel bias");
    }
    f << "\n";
  }
  Finish(f, path);
}

namespace {

// One sensor's files (LoadDataset).
SensorData LoadSensor(const std::string& data_dir, const RigConfig& rig, const SensorConfig& s,
                      const InertialRange& range, Warnings* warnings) {
  const fs::path dir = fs::path(data_dir) / s.name;
  if (!fs::is_directory(dir)) {
    throw std::runtime_error(dir.string() + ": no such folder (sensor '" + s.name +
                             "' of the rig has no data)");
  }
  SensorData d;
  const std::string data_csv = (dir / "data.csv").string();
  switch (s.type) {
    case SensorType::kImu:
      d.imu = ReadImuCsv(data_csv, warnings, &range);
      break;
    case SensorType::kGyro:
      d.gyro = ReadGyroCsv(data_csv, warnings, &range);
      break;
    case SensorType::kCamera: {
      const std::string corners_csv = (dir / "corners.csv").string();
      d.has_corners = fs::is_regular_file(corners_csv);
      const bool has_list = fs::is_regular_file(data_csv);
      if (!d.has_corners && !has_list) {
        throw std::runtime_error(dir.string() + ": camera '" + s.name +
                                 "' has neither corners.csv nor data.csv");
      }
      if (has_list)
        d.images = ReadImageCsv(data_csv, !d.has_corners, warnings);
      if (d.has_corners) {
        std::set<std::int64_t> stamps;
        for (const ImageEntry& e : d.images)
          stamps.insert(e.t_ns);
        const CornerImage image{s.width, s.height, s.pixel_sigma};
        d.corners = ReadCornersCsv(corners_csv, TargetCornerCount(rig.target),
                                   has_list ? &stamps : nullptr, &image);
      }
      break;
    }
  }
  return d;
}

}  // namespace

std::map<std::string, SensorData> LoadDataset(const std::string& data_dir, const RigConfig& rig,
                                              Warnings* warnings) {
  if (!fs::is_directory(data_dir))
    throw std::runtime_error(data_dir + ": no such dataset folder");
  // The sensors' files on the hardware's threads, each into its own slot; the warnings and the
  // first error in the rig's order, as a serial read gives them.
  const InertialRange range;
  const size_t n = rig.sensors.size();
  std::vector<SensorData> loaded(n);
  std::vector<Warnings> sensor_warnings(n);
  std::vector<std::exception_ptr> errors(n);
  ParallelFor(static_cast<int>(std::thread::hardware_concurrency()), n, [&](size_t i) {
    try {
      loaded[i] = LoadSensor(data_dir, rig, rig.sensors[i], range, &sensor_warnings[i]);
    } catch (...) {
      errors[i] = std::current_exception();
    }
  });
  std::map<std::string, SensorData> out;
  for (size_t i = 0; i < n; ++i) {
    for (const std::string& w : sensor_warnings[i])
      Warn(warnings, w);
    if (errors[i])
      std::rethrow_exception(errors[i]);
    out[rig.sensors[i].name] = std::move(loaded[i]);
  }
  return out;
}

}  // namespace ctcal
