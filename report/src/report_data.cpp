// CSV files of report_data.h: one writer and one strict reader per file.
#include "ctcal/report/report_data.h"

#include <zlib.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "ctcal/sensors/number_format.h"

namespace ctcal::report {
namespace {

namespace fs = std::filesystem;

void CreateDataDir(const std::string& out_dir) {
  std::error_code ec;
  fs::create_directories(ReportDataDir(out_dir), ec);
  if (ec)
    throw std::runtime_error(ReportDataDir(out_dir) + ": cannot create: " + ec.message());
}

// Writes `text` to `path`: gzip (level 3: ~5x smaller at a few ms per MB) for a `.gz` path,
// plain text otherwise.
void WriteText(const std::string& out_dir, const std::string& path, const std::string& text) {
  CreateDataDir(out_dir);
  if (path.size() > 3 && path.compare(path.size() - 3, 3, ".gz") == 0) {
    gzFile f = gzopen(path.c_str(), "wb3");
    if (f == nullptr)
      throw std::runtime_error(path + ": cannot open for writing");
    const bool ok = text.empty() || gzwrite(f, text.data(), static_cast<unsigned>(text.size())) ==
                                        static_cast<int>(text.size());
    if (gzclose(f) != Z_OK || !ok)
      throw std::runtime_error(path + ": write failed");
    return;
  }
  std::ofstream f(path);
  f << text;
  f.flush();
  if (!f)
    throw std::runtime_error(path + ": write failed");
}

// The whole file, gzip or plain (zlib reads a plain file as it is); std::nullopt when absent.
// A `.csv.gz` path that does not exist falls back to the plain `.csv` of older folders.
std::optional<std::string> ReadText(const std::string& path) {
  std::string p = path;
  if (!fs::exists(p) && p.size() > 3 && p.compare(p.size() - 3, 3, ".gz") == 0)
    p.resize(p.size() - 3);
  if (!fs::exists(p))
    return std::nullopt;
  gzFile f = gzopen(p.c_str(), "rb");
  if (f == nullptr)
    throw std::runtime_error(p + ": cannot open");
  std::string text;
  char buf[1 << 16];
  int n = 0;
  while ((n = gzread(f, buf, sizeof buf)) > 0)
    text.append(buf, static_cast<size_t>(n));
  int err = Z_OK;
  const char* msg = gzerror(f, &err);
  gzclose(f);
  if (n < 0 || (err != Z_OK && err != Z_STREAM_END))
    throw std::runtime_error(p + ": cannot read: " + (msg ? msg : "zlib error"));
  return text;
}

std::string Fixed3(double x) {
  if (!std::isfinite(x))
    return FormatDouble(x);
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.3f", x);
  return buf;
}

// `digits` significant digits (for values a plot needs, not bit-exact), YAML's non-finite.
std::string Digits(double x, int digits) {
  if (!std::isfinite(x))
    return FormatDouble(x);
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.*g", digits, x);
  return buf;
}

// Exact (shortest round trip) by default; `digits` significant digits for plot-only columns.
std::string V3(const Eigen::Vector3d& v, int digits = 0) {
  const auto f = [digits](double x) { return digits > 0 ? Digits(x, digits) : FormatDouble(x); };
  return f(v.x()) + "," + f(v.y()) + "," + f(v.z());
}

std::vector<std::string> Split(const std::string& line) {
  std::vector<std::string> out;
  std::string cell;
  std::istringstream s(line);
  while (std::getline(s, cell, ','))
    out.push_back(cell);
  if (!line.empty() && line.back() == ',')
    out.push_back("");
  return out;
}

// Reads the data rows of a CSV (skipping `#` lines and blank lines); calls row(cells, where).
template <typename F>
void ForEachRow(const std::string& path, size_t columns, F row) {
  const std::optional<std::string> text = ReadText(path);
  if (!text)
    return;  // a missing file is an empty table (the section is then omitted with a note)
  std::istringstream f(*text);
  std::string line;
  int n = 0;
  while (std::getline(f, line)) {
    ++n;
    if (!line.empty() && line.back() == '\r')
      line.pop_back();
    if (line.empty() || line[0] == '#')
      continue;
    const std::string where = path + ":" + std::to_string(n);
    const auto cells = Split(line);
    if (columns != 0 && cells.size() != columns) {
      throw std::runtime_error(where + ": expected " + std::to_string(columns) + " columns, got " +
                               std::to_string(cells.size()));
    }
    row(cells, where);
  }
}

double Num(const std::string& s, const std::string& where) {
  double x = 0;
  if (!ParseDouble(s, &x))
    throw std::runtime_error(where + ": '" + s + "' is not a number");
  return x;
}

std::int64_t Int(const std::string& s, const std::string& where) {
  try {
    size_t used = 0;
    const long long v = std::stoll(s, &used);
    if (used == s.size())
      return v;
  } catch (const std::exception&) {
  }
  throw std::runtime_error(where + ": '" + s + "' is not an integer");
}

Eigen::Vector3d Vec(const std::vector<std::string>& c, size_t i, const std::string& where) {
  return {Num(c[i], where), Num(c[i + 1], where), Num(c[i + 2], where)};
}

void WriteInertial(const std::string& out_dir, const std::string& path,
                   const std::vector<InertialSample>& rows) {
  std::ostringstream f;
  f << "#t_ns,meas_x,meas_y,meas_z,pred_x,pred_y,pred_z\n";
  for (const auto& r : rows)
    f << r.t_ns << "," << V3(r.meas) << "," << V3(r.pred) << "\n";
  WriteText(out_dir, path, f.str());
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
  const std::string path = CornersPath(out_dir, camera);
  std::ostringstream f;
  f << "#t_ns,frame,corner_id,u,v,du,dv,whitened,outlier\n";
  for (const auto& r : rows) {
    // The detector's corners to 1e-3 px, the errors to 7 significant digits (the whitened RMS
    // recomputed from the file agrees with result.yaml to 5e-7 relative).
    f << r.t_ns << "," << r.frame << "," << r.corner_id << "," << Fixed3(r.u) << "," << Fixed3(r.v)
      << "," << Digits(r.du, 7) << "," << Digits(r.dv, 7) << "," << Digits(r.whitened, 7) << ","
      << (r.outlier ? 1 : 0) << "\n";
  }
  WriteText(out_dir, path, f.str());
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
  const std::string path = BiasPath(out_dir, sensor);
  std::ostringstream f;
  f << "#t_ns,b_x,b_y,b_z,sigma_x,sigma_y,sigma_z,part\n";
  for (const auto* part : {&track.gyro, &track.accel}) {
    const char* name = part == &track.gyro ? "gyro" : "accel";
    for (const auto& r : *part)
      f << r.t_ns << "," << V3(r.b, 7) << "," << V3(r.sigma, 7) << "," << name << "\n";
  }
  WriteText(out_dir, path, f.str());
}

void WriteTrajectory(const std::string& out_dir, const std::vector<PoseSample>& rows) {
  const std::string path = TrajectoryPath(out_dir);
  std::ostringstream f;
  f << "#t_ns,p_x,p_y,p_z,q_w,q_x,q_y,q_z\n";
  for (const auto& r : rows) {
    f << r.t_ns << "," << V3(r.p_W_B) << "," << FormatDouble(r.q_W_B.w()) << ","
      << FormatDouble(r.q_W_B.x()) << "," << FormatDouble(r.q_W_B.y()) << ","
      << FormatDouble(r.q_W_B.z()) << "\n";
  }
  WriteText(out_dir, path, f.str());
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
  std::ostringstream f;
  f << "#name";
  for (const auto& name : c.names)
    f << "," << name;
  f << "\n";
  for (Eigen::Index r = 0; r < n; ++r) {
    f << c.names[r];
    for (Eigen::Index k = 0; k < n; ++k)
      f << "," << FormatDouble(c.values(r, k));
    f << "\n";
  }
  WriteText(out_dir, path, f.str());
}

void WriteRunInfo(const std::string& out_dir, const RunInfo& info) {
  const std::string path = RunInfoPath(out_dir);
  std::ostringstream f;
  f << "#key,value\n";
  for (const auto& [key, value] : info) {
    if (key.find(',') != std::string::npos || key.find('\n') != std::string::npos ||
        value.find('\n') != std::string::npos)
      throw std::invalid_argument(path + ": run info key '" + key +
                                  "' has a comma or a newline (value: no newline)");
    f << key << "," << value << "\n";  // the value may contain commas: it is the rest of the line
  }
  WriteText(out_dir, path, f.str());
}

std::vector<CornerResidual> ReadCornerResiduals(const std::string& path) {
  std::vector<CornerResidual> out;
  ForEachRow(path, 9, [&](const std::vector<std::string>& c, const std::string& where) {
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
      throw std::runtime_error(where + ": outlier must be 0 or 1, got " + c[8]);
    r.outlier = o == 1;
    out.push_back(r);
  });
  return out;
}

std::vector<InertialSample> ReadInertialSamples(const std::string& path) {
  std::vector<InertialSample> out;
  ForEachRow(path, 7, [&](const std::vector<std::string>& c, const std::string& where) {
    out.push_back({Int(c[0], where), Vec(c, 1, where), Vec(c, 4, where)});
  });
  return out;
}

BiasTrack ReadBiasTrack(const std::string& path) {
  BiasTrack out;
  ForEachRow(path, 8, [&](const std::vector<std::string>& c, const std::string& where) {
    const BiasSample s{Int(c[0], where), Vec(c, 1, where), Vec(c, 4, where)};
    if (c[7] == "gyro")
      out.gyro.push_back(s);
    else if (c[7] == "accel")
      out.accel.push_back(s);
    else
      throw std::runtime_error(where + ": part must be gyro or accel, got '" + c[7] + "'");
  });
  return out;
}

std::vector<PoseSample> ReadTrajectory(const std::string& path) {
  std::vector<PoseSample> out;
  ForEachRow(path, 8, [&](const std::vector<std::string>& c, const std::string& where) {
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
  auto names = Split(header);
  names.erase(names.begin());
  const size_t n = names.size();
  out.values = Eigen::MatrixXd::Constant(n, n, std::numeric_limits<double>::quiet_NaN());
  size_t r = 0;
  ForEachRow(path, n + 1, [&](const std::vector<std::string>& c, const std::string& where) {
    if (r >= n)
      throw std::runtime_error(where + ": more rows than parameter names");
    if (c[0] != names[r])
      throw std::runtime_error(where + ": row " + std::to_string(r) + " is '" + c[0] +
                               "', expected '" + names[r] + "' (rows in header order)");
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

ReportData LoadReportData(const std::string& out_dir, const std::vector<std::string>& sensors) {
  ReportData d;
  for (const std::string& s : sensors) {
    if (auto c = ReadCornerResiduals(CornersPath(out_dir, s)); !c.empty())
      d.corners[s] = std::move(c);
    if (auto g = ReadInertialSamples(GyroPath(out_dir, s)); !g.empty())
      d.gyro[s] = std::move(g);
    if (auto a = ReadInertialSamples(AccelPath(out_dir, s)); !a.empty())
      d.accel[s] = std::move(a);
    if (auto b = ReadBiasTrack(BiasPath(out_dir, s)); !b.gyro.empty() || !b.accel.empty())
      d.bias[s] = std::move(b);
  }
  d.trajectory = ReadTrajectory(TrajectoryPath(out_dir));
  d.correlation = ReadCorrelation(CorrelationPath(out_dir));
  d.run_info = ReadRunInfo(RunInfoPath(out_dir));
  return d;
}

void WriteReportData(const std::string& out_dir, const ReportData& d) {
  for (const auto& [s, rows] : d.corners)
    WriteCornerResiduals(out_dir, s, rows);
  for (const auto& [s, rows] : d.gyro)
    WriteGyroSamples(out_dir, s, rows);
  for (const auto& [s, rows] : d.accel)
    WriteAccelSamples(out_dir, s, rows);
  for (const auto& [s, track] : d.bias)
    WriteBiasTrack(out_dir, s, track);
  if (!d.trajectory.empty())
    WriteTrajectory(out_dir, d.trajectory);
  if (!d.correlation.names.empty())
    WriteCorrelation(out_dir, d.correlation);
  WriteRunInfo(out_dir, d.run_info);
}

}  // namespace ctcal::report
