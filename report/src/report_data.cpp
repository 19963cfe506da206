// CSV files of report_data.h: one writer and one strict reader per file.
#include "ctcal/report/report_data.h"

#include <libdeflate.h>
#include <zlib.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string_view>
#include <thread>

#include "ctcal/report/report.h"
#include "ctcal/sensors/number_format.h"
#include "ctcal/sensors/parallel_for.h"

namespace ctcal::report {
namespace {

namespace fs = std::filesystem;

// `threads` <= 0: the hardware's threads.
int Workers(int threads) {
  return threads > 0 ? threads : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

void CreateDataDir(const std::string& out_dir) {
  std::error_code ec;
  fs::create_directories(ReportDataDir(out_dir), ec);
  if (ec)
    throw std::runtime_error(ReportDataDir(out_dir) + ": cannot create: " + ec.message());
}

bool IsGzipPath(const std::string& path) {
  return path.size() > 3 && path.compare(path.size() - 3, 3, ".gz") == 0;
}

// A table file written as its rows are formatted: plain text, or for a `.gz` path gzip members of
// kChunk bytes of text each (libdeflate level 1: ~100 MB/s, smaller than zlib's level 3 at a
// fifth of its time; concatenated members are one gzip file to zcat, zlib and Python), so that
// the text of a long recording is never held whole. 1 MiB: the writer runs beside the
// cross-validation's subset solves, whose peak its text and packed copy add to (4 MiB members
// raised the demo's peak by 13 MB; the files are as small).
class TableFile {
 public:
  static constexpr size_t kChunk = size_t{1} << 20;

  TableFile(const std::string& out_dir, std::string path) : path_(std::move(path)) {
    CreateDataDir(out_dir);
    file_ = std::fopen(path_.c_str(), "wb");
    if (file_ == nullptr)
      throw std::runtime_error(
          path_ + (IsGzipPath(path_) ? ": cannot open for writing" : ": write failed"));
    if (IsGzipPath(path_)) {
      compressor_ = libdeflate_alloc_compressor(1);
      if (compressor_ == nullptr) {
        std::fclose(file_);
        throw std::runtime_error(path_ + ": write failed (no memory for the compressor)");
      }
    }
    text_.reserve(kChunk + 4096);
  }
  ~TableFile() {
    if (file_ != nullptr)
      std::fclose(file_);
    if (compressor_ != nullptr)
      libdeflate_free_compressor(compressor_);
  }
  TableFile(const TableFile&) = delete;
  TableFile& operator=(const TableFile&) = delete;

  void Raw(std::string_view s) { text_.append(s); }
  void Char(char c) { text_.push_back(c); }
  void Int(std::int64_t v) {
    char buf[24];
    text_.append(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
  }
  // Exact: the shortest decimal that reads back to `x` (sensors/number_format.h).
  void Exact(double x) {
    char buf[kFormatDoubleChars];
    text_.append(buf, FormatDoubleTo(buf, buf + sizeof buf, x));
  }
  // printf's "%.3f" / "%.<digits>g" (to_chars with a precision is specified as printf), YAML's
  // non-finite names; returns the value as the file holds it (what a reader gets back).
  double Fixed3(double x) { return Rounded(x, std::chars_format::fixed, 3); }
  double Digits(double x, int digits) { return Rounded(x, std::chars_format::general, digits); }
  // Ends a row; writes a chunk when the text has grown past kChunk.
  void EndRow() {
    text_.push_back('\n');
    if (text_.size() >= kChunk)
      Flush();
  }
  void Close() {
    Flush();
    const int closed = std::fclose(file_);
    file_ = nullptr;
    if (closed != 0)
      throw std::runtime_error(path_ + ": write failed");
  }

 private:
  double Rounded(double x, std::chars_format format, int precision) {
    if (!std::isfinite(x)) {
      Exact(x);
      return x;
    }
    char buf[64];
    const auto res = std::to_chars(buf, buf + sizeof buf, x, format, precision);
    if (res.ec != std::errc()) {
      // "%.3f" of a number beyond 1e60 does not fit: exact instead (the buffer holds no text).
      Exact(x);
      return x;
    }
    double back = x;
    std::from_chars(buf, res.ptr, back);
    text_.append(buf, res.ptr);
    return back;
  }

  void Flush() {
    if (text_.empty())
      return;
    const char* bytes = text_.data();
    size_t n = text_.size();
    if (compressor_ != nullptr) {
      packed_.resize(libdeflate_gzip_compress_bound(compressor_, text_.size()));
      n = libdeflate_gzip_compress(compressor_, text_.data(), text_.size(), packed_.data(),
                                   packed_.size());
      bytes = packed_.data();
    }
    if (n == 0 || std::fwrite(bytes, 1, n, file_) != n)
      throw std::runtime_error(path_ + ": write failed");
    text_.clear();
  }

  std::string path_;
  std::FILE* file_ = nullptr;
  libdeflate_compressor* compressor_ = nullptr;
  std::string text_;
  std::vector<char> packed_;
};

// The whole file, gzip or plain (zlib reads a plain file as it is); std::nullopt when absent.
// A `.csv.gz` path that does not exist falls back to the plain `.csv` of older folders.
std::optional<std::string> ReadText(const std::string& path) {
  std::string p = path;
  if (!fs::exists(p) && IsGzipPath(p))
    p.resize(p.size() - 3);
  if (!fs::exists(p))
    return std::nullopt;
  gzFile f = gzopen(p.c_str(), "rb");
  if (f == nullptr)
    throw std::runtime_error(p + ": cannot open");
  gzbuffer(f, 1 << 17);
  std::string text;
  std::error_code ec;
  const auto size = fs::file_size(p, ec);
  if (!ec)
    text.reserve(static_cast<size_t>(size) * (IsGzipPath(p) ? 3 : 1));
  char buf[1 << 16];
  int n = 0;
  while ((n = gzread(f, buf, sizeof buf)) > 0)
    text.append(buf, static_cast<size_t>(n));
  int err = Z_OK;
  const char* msg = gzerror(f, &err);
  const std::string why = msg ? msg : "zlib error";
  gzclose(f);
  if (n < 0 || (err != Z_OK && err != Z_STREAM_END))
    throw std::runtime_error(p + ": cannot read: " + why);
  return text;
}

// Where a row is, for the readers' errors: "<file>:<line>" (built only for an error).
struct Where {
  const std::string& path;
  int line = 0;
  std::string str() const { return path + ":" + std::to_string(line); }
};

// The cells of a line (a trailing comma makes an empty last cell; an empty line has none).
void Split(std::string_view line, std::vector<std::string_view>* out) {
  out->clear();
  if (line.empty())
    return;
  size_t start = 0;
  while (true) {
    const size_t comma = line.find(',', start);
    if (comma == std::string_view::npos) {
      out->push_back(line.substr(start));
      return;
    }
    out->push_back(line.substr(start, comma - start));
    start = comma + 1;
  }
}

// Reads the data rows of a CSV (skipping `#` lines and blank lines); calls row(cells, where).
template <typename F>
void ForEachRow(const std::string& path, size_t columns, F row) {
  const std::optional<std::string> text = ReadText(path);
  if (!text)
    return;  // a missing file is an empty table (the section is then omitted with a note)
  const std::string_view all(*text);
  std::vector<std::string_view> cells;
  Where where{path, 0};
  for (size_t pos = 0; pos < all.size();) {
    size_t eol = all.find('\n', pos);
    if (eol == std::string_view::npos)
      eol = all.size();
    std::string_view line = all.substr(pos, eol - pos);
    pos = eol + 1;
    ++where.line;
    if (!line.empty() && line.back() == '\r')
      line.remove_suffix(1);
    if (line.empty() || line[0] == '#')
      continue;
    Split(line, &cells);
    if (columns != 0 && cells.size() != columns) {
      throw std::runtime_error(where.str() + ": expected " + std::to_string(columns) +
                               " columns, got " + std::to_string(cells.size()));
    }
    row(cells, where);
  }
}

double Num(std::string_view s, const Where& where) {
  double x = 0;
  if (!ParseDouble(s, &x))
    throw std::runtime_error(where.str() + ": '" + std::string(s) + "' is not a number");
  return x;
}

std::int64_t Int(std::string_view s, const Where& where) {
  long long v = 0;
  const auto res = std::from_chars(s.data(), s.data() + s.size(), v);
  if (!s.empty() && res.ec == std::errc() && res.ptr == s.data() + s.size())
    return v;
  // What from_chars does not take (leading blanks, a '+') as std::stoll took it before.
  try {
    size_t used = 0;
    const std::string text(s);
    v = std::stoll(text, &used);
    if (used == text.size())
      return v;
  } catch (const std::exception&) {
  }
  throw std::runtime_error(where.str() + ": '" + std::string(s) + "' is not an integer");
}

Eigen::Vector3d Vec(const std::vector<std::string_view>& c, size_t i, const Where& where) {
  return {Num(c[i], where), Num(c[i + 1], where), Num(c[i + 2], where)};
}

// Exact (shortest round trip) by default; `digits` significant digits for plot-only columns.
// Returns the vector as written.
Eigen::Vector3d V3(TableFile* f, const Eigen::Vector3d& v, int digits = 0) {
  Eigen::Vector3d out = v;
  for (int k = 0; k < 3; ++k) {
    if (k)
      f->Char(',');
    if (digits > 0)
      out[k] = f->Digits(v[k], digits);
    else
      f->Exact(v[k]);
  }
  return out;
}

void WriteInertial(const std::string& out_dir, const std::string& path,
                   const std::vector<InertialSample>& rows) {
  TableFile f(out_dir, path);
  f.Raw("#t_ns,meas_x,meas_y,meas_z,pred_x,pred_y,pred_z\n");
  for (const auto& r : rows) {
    f.Int(r.t_ns);
    f.Char(',');
    V3(&f, r.meas);
    f.Char(',');
    V3(&f, r.pred);
    f.EndRow();
  }
  f.Close();
}

// The writers of the rounded tables: the rows are left as the file holds them.
void WriteCorners(const std::string& out_dir, const std::string& camera,
                  std::vector<CornerResidual>* rows) {
  TableFile f(out_dir, CornersPath(out_dir, camera));
  f.Raw("#t_ns,frame,corner_id,u,v,du,dv,whitened,outlier\n");
  for (CornerResidual& r : *rows) {
    // The detector's corners to 1e-3 px, the errors to 7 significant digits (the whitened RMS
    // recomputed from the file agrees with result.yaml to 5e-7 relative).
    f.Int(r.t_ns);
    f.Char(',');
    f.Int(r.frame);
    f.Char(',');
    f.Int(r.corner_id);
    f.Char(',');
    r.u = f.Fixed3(r.u);
    f.Char(',');
    r.v = f.Fixed3(r.v);
    f.Char(',');
    r.du = f.Digits(r.du, 7);
    f.Char(',');
    r.dv = f.Digits(r.dv, 7);
    f.Char(',');
    r.whitened = f.Digits(r.whitened, 7);
    f.Char(',');
    f.Char(r.outlier ? '1' : '0');
    f.EndRow();
  }
  f.Close();
}

void WriteBias(const std::string& out_dir, const std::string& sensor, BiasTrack* track) {
  TableFile f(out_dir, BiasPath(out_dir, sensor));
  f.Raw("#t_ns,b_x,b_y,b_z,sigma_x,sigma_y,sigma_z,part\n");
  for (auto* part : {&track->gyro, &track->accel}) {
    const char* name = part == &track->gyro ? "gyro" : "accel";
    for (BiasSample& r : *part) {
      f.Int(r.t_ns);
      f.Char(',');
      r.b = V3(&f, r.b, 7);
      f.Char(',');
      r.sigma = V3(&f, r.sigma, 7);
      f.Char(',');
      f.Raw(name);
      f.EndRow();
    }
  }
  f.Close();
}

}  // namespace

std::string ReportDataDir(const std::string& out_dir) {
  return (fs::path(out_dir) / "report_data").string();
}
std::string CornersPath(const std::string& out_dir, const std::string& camera) {
  return (fs::path(ReportDataDir(out_dir)) / (camera + "_corners.csv.gz")).string();
}
std::string GyroPath(const std::string& out_dir, const std::string& sensor) {
  return (fs::path(ReportDataDir(out_dir)) / (sensor + "_gyro.csv.gz")).string();
}
std::string AccelPath(const std::string& out_dir, const std::string& sensor) {
  return (fs::path(ReportDataDir(out_dir)) / (sensor + "_accel.csv.gz")).string();
}
std::string BiasPath(const std::string& out_dir, const std::string& sensor) {
  return (fs::path(ReportDataDir(out_dir)) / (sensor + "_bias.csv.gz")).string();
}
std::string TrajectoryPath(const std::string& out_dir) {
  return (fs::path(ReportDataDir(out_dir)) / "trajectory.csv.gz").string();
}
std::string CorrelationPath(const std::string& out_dir) {
  return (fs::path(ReportDataDir(out_dir)) / "correlation.csv").string();
}
std::string RunInfoPath(const std::string& out_dir) {
  return (fs::path(ReportDataDir(out_dir)) / "run_info.csv").string();
}

void WriteCornerResiduals(const std::string& out_dir, const std::string& camera,
                          const std::vector<CornerResidual>& rows) {
  std::vector<CornerResidual> copy = rows;
  WriteCorners(out_dir, camera, &copy);
}

void WriteGyroSamples(const std::string& out_dir, const std::string& sensor,
                      const std::vector<InertialSample>& rows) {
  WriteInertial(out_dir, GyroPath(out_dir, sensor), rows);
}

void WriteAccelSamples(const std::string& out_dir, const std::string& sensor,
                       const std::vector<InertialSample>& rows) {
  WriteInertial(out_dir, AccelPath(out_dir, sensor), rows);
}

void WriteBiasTrack(const std::string& out_dir, const std::string& sensor, const BiasTrack& track) {
  BiasTrack copy = track;
  WriteBias(out_dir, sensor, &copy);
}

void WriteTrajectory(const std::string& out_dir, const std::vector<PoseSample>& rows) {
  TableFile f(out_dir, TrajectoryPath(out_dir));
  f.Raw("#t_ns,p_x,p_y,p_z,q_w,q_x,q_y,q_z\n");
  for (const auto& r : rows) {
    f.Int(r.t_ns);
    f.Char(',');
    V3(&f, r.p_W_B);
    for (const double q : {r.q_W_B.w(), r.q_W_B.x(), r.q_W_B.y(), r.q_W_B.z()}) {
      f.Char(',');
      f.Exact(q);
    }
    f.EndRow();
  }
  f.Close();
}

void WriteCorrelation(const std::string& out_dir, const Correlation& c) {
  const std::string path = CorrelationPath(out_dir);
  const auto n = static_cast<Eigen::Index>(c.names.size());
  if (c.values.rows() != n || c.values.cols() != n)
    throw std::invalid_argument(path + ": correlation matrix is not names x names");
  for (const auto& name : c.names) {
    if (name.find(',') != std::string::npos)
      throw std::invalid_argument(path + ": parameter name '" + name + "' contains a comma");
  }
  TableFile f(out_dir, path);
  f.Raw("#name");
  for (const auto& name : c.names) {
    f.Char(',');
    f.Raw(name);
  }
  f.EndRow();
  for (Eigen::Index r = 0; r < n; ++r) {
    f.Raw(c.names[r]);
    for (Eigen::Index k = 0; k < n; ++k) {
      f.Char(',');
      f.Exact(c.values(r, k));
    }
    f.EndRow();
  }
  f.Close();
}

void WriteRunInfo(const std::string& out_dir, const RunInfo& info) {
  const std::string path = RunInfoPath(out_dir);
  for (const auto& [key, value] : info) {
    if (key.find(',') != std::string::npos || key.find('\n') != std::string::npos ||
        value.find('\n') != std::string::npos)
      throw std::invalid_argument(path + ": run info key '" + key +
                                  "' has a comma or a newline (value: no newline)");
  }
  TableFile f(out_dir, path);
  f.Raw("#key,value\n");
  for (const auto& [key, value] : info) {
    f.Raw(key);  // the value may contain commas: it is the rest of the line
    f.Char(',');
    f.Raw(value);
    f.EndRow();
  }
  f.Close();
}

std::vector<CornerResidual> ReadCornerResiduals(const std::string& path) {
  std::vector<CornerResidual> out;
  ForEachRow(path, 9, [&](const std::vector<std::string_view>& c, const Where& where) {
    CornerResidual r;
    r.t_ns = Int(c[0], where);
    r.frame = static_cast<int>(Int(c[1], where));
    r.corner_id = static_cast<int>(Int(c[2], where));
    r.u = Num(c[3], where);
    r.v = Num(c[4], where);
    r.du = Num(c[5], where);
    r.dv = Num(c[6], where);
    r.whitened = Num(c[7], where);
    const std::int64_t o = Int(c[8], where);
    if (o != 0 && o != 1)
      throw std::runtime_error(where.str() + ": outlier must be 0 or 1, got " + std::string(c[8]));
    r.outlier = o == 1;
    out.push_back(r);
  });
  return out;
}

std::vector<InertialSample> ReadInertialSamples(const std::string& path) {
  std::vector<InertialSample> out;
  ForEachRow(path, 7, [&](const std::vector<std::string_view>& c, const Where& where) {
    out.push_back({Int(c[0], where), Vec(c, 1, where), Vec(c, 4, where)});
  });
  return out;
}

BiasTrack ReadBiasTrack(const std::string& path) {
  BiasTrack out;
  ForEachRow(path, 8, [&](const std::vector<std::string_view>& c, const Where& where) {
    const BiasSample s{Int(c[0], where), Vec(c, 1, where), Vec(c, 4, where)};
    if (c[7] == "gyro")
      out.gyro.push_back(s);
    else if (c[7] == "accel")
      out.accel.push_back(s);
    else
      throw std::runtime_error(where.str() + ": part must be gyro or accel, got '" +
                               std::string(c[7]) + "'");
  });
  return out;
}

std::vector<PoseSample> ReadTrajectory(const std::string& path) {
  std::vector<PoseSample> out;
  ForEachRow(path, 8, [&](const std::vector<std::string_view>& c, const Where& where) {
    PoseSample p;
    p.t_ns = Int(c[0], where);
    p.p_W_B = Vec(c, 1, where);
    p.q_W_B =
        Eigen::Quaterniond(Num(c[4], where), Num(c[5], where), Num(c[6], where), Num(c[7], where));
    out.push_back(p);
  });
  return out;
}

Correlation ReadCorrelation(const std::string& path) {
  Correlation out;
  std::ifstream f(path);
  if (!f)
    return out;
  std::string header;
  std::getline(f, header);
  if (header.rfind("#name", 0) != 0)
    throw std::runtime_error(path + ":1: expected the header '#name,<parameter names>'");
  std::vector<std::string_view> head;
  Split(header, &head);
  std::vector<std::string> names(head.begin() + (head.empty() ? 0 : 1), head.end());
  const size_t n = names.size();
  out.values = Eigen::MatrixXd::Constant(n, n, std::numeric_limits<double>::quiet_NaN());
  size_t r = 0;
  ForEachRow(path, n + 1, [&](const std::vector<std::string_view>& c, const Where& where) {
    if (r >= n)
      throw std::runtime_error(where.str() + ": more rows than parameter names");
    if (c[0] != names[r])
      throw std::runtime_error(where.str() + ": row " + std::to_string(r) + " is '" +
                               std::string(c[0]) + "', expected '" + names[r] +
                               "' (rows in header order)");
    for (size_t k = 0; k < n; ++k)
      out.values(r, k) = Num(c[k + 1], where);
    ++r;
  });
  if (r != n)
    throw std::runtime_error(path + ": " + std::to_string(r) + " rows for " + std::to_string(n) +
                             " parameter names");
  out.names = std::move(names);
  return out;
}

RunInfo ReadRunInfo(const std::string& path) {
  RunInfo out;
  std::ifstream f(path);
  std::string line;
  int n = 0;
  while (std::getline(f, line)) {
    ++n;
    if (line.empty() || line[0] == '#')
      continue;
    const auto comma = line.find(',');
    if (comma == std::string::npos)
      throw std::runtime_error(path + ":" + std::to_string(n) + ": expected key,value");
    out.emplace_back(line.substr(0, comma), line.substr(comma + 1));
  }
  return out;
}

ReportData LoadReportData(const std::string& out_dir, const std::vector<std::string>& sensors,
                          int threads) {
  // One job per file, each filling its own slot (the result does not depend on the schedule).
  ReportData d;
  const size_t n = sensors.size();
  std::vector<std::vector<CornerResidual>> corners(n);
  std::vector<std::vector<InertialSample>> gyro(n), accel(n);
  std::vector<BiasTrack> bias(n);
  std::vector<std::function<void()>> jobs;
  for (size_t i = 0; i < n; ++i) {
    jobs.emplace_back(
        [&, i] { corners[i] = ReadCornerResiduals(CornersPath(out_dir, sensors[i])); });
    jobs.emplace_back([&, i] { gyro[i] = ReadInertialSamples(GyroPath(out_dir, sensors[i])); });
    jobs.emplace_back([&, i] { accel[i] = ReadInertialSamples(AccelPath(out_dir, sensors[i])); });
    jobs.emplace_back([&, i] { bias[i] = ReadBiasTrack(BiasPath(out_dir, sensors[i])); });
  }
  jobs.emplace_back([&] { d.trajectory = ReadTrajectory(TrajectoryPath(out_dir)); });
  jobs.emplace_back([&] { d.correlation = ReadCorrelation(CorrelationPath(out_dir)); });
  jobs.emplace_back([&] { d.run_info = ReadRunInfo(RunInfoPath(out_dir)); });
  ParallelFor(Workers(threads), jobs.size(), [&](size_t j) { jobs[j](); });
  for (size_t i = 0; i < n; ++i) {
    if (!corners[i].empty())
      d.corners[sensors[i]] = std::move(corners[i]);
    if (!gyro[i].empty())
      d.gyro[sensors[i]] = std::move(gyro[i]);
    if (!accel[i].empty())
      d.accel[sensors[i]] = std::move(accel[i]);
    if (!bias[i].gyro.empty() || !bias[i].accel.empty())
      d.bias[sensors[i]] = std::move(bias[i]);
  }
  return d;
}

namespace {

// The jobs of the tables the report draws rounded (corner residuals, bias tracks: rounded in place
// to their written digits) and of those written exactly (the rest), the largest first, so that
// the threads finish together.
std::vector<std::function<void()>> RoundedTableJobs(const std::string& out_dir, ReportData* d) {
  std::vector<std::function<void()>> jobs;
  for (auto& [s, rows] : d->corners)
    jobs.emplace_back([&, &s = s, &rows = rows] { WriteCorners(out_dir, s, &rows); });
  for (auto& [s, track] : d->bias)
    jobs.emplace_back([&, &s = s, &track = track] { WriteBias(out_dir, s, &track); });
  return jobs;
}

std::vector<std::function<void()>> ExactTableJobs(const std::string& out_dir, const ReportData& d) {
  std::vector<std::function<void()>> jobs;
  for (const auto& [s, rows] : d.gyro)
    jobs.emplace_back([&, &s = s, &rows = rows] { WriteGyroSamples(out_dir, s, rows); });
  for (const auto& [s, rows] : d.accel)
    jobs.emplace_back([&, &s = s, &rows = rows] { WriteAccelSamples(out_dir, s, rows); });
  if (!d.trajectory.empty())
    jobs.emplace_back([&] { WriteTrajectory(out_dir, d.trajectory); });
  if (!d.correlation.names.empty())
    jobs.emplace_back([&] { WriteCorrelation(out_dir, d.correlation); });
  jobs.emplace_back([&] { WriteRunInfo(out_dir, d.run_info); });
  return jobs;
}

void RunJobs(const std::vector<std::function<void()>>& jobs, int threads) {
  ParallelFor(Workers(threads), jobs.size(), [&](size_t j) { jobs[j](); });
}

}  // namespace

ReportData WriteReportData(const std::string& out_dir, ReportData d, int threads) {
  CreateDataDir(out_dir);
  std::vector<std::function<void()>> jobs = RoundedTableJobs(out_dir, &d);
  for (auto& job : ExactTableJobs(out_dir, d))
    jobs.push_back(std::move(job));
  RunJobs(jobs, threads);
  return d;
}

ReportData WriteRoundedReportData(const std::string& out_dir, ReportData d, int threads) {
  CreateDataDir(out_dir);
  RunJobs(RoundedTableJobs(out_dir, &d), threads);
  return d;
}

void WriteExactReportData(const std::string& out_dir, const ReportData& d, int threads) {
  CreateDataDir(out_dir);
  RunJobs(ExactTableJobs(out_dir, d), threads);
}

}  // namespace ctcal::report
