#include "ctcal/sim/dataset_writer.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include "ctcal/sensors/number_format.h"
#include "ctcal/sensors/rig_yaml.h"
#include "ctcal/targets/target_config.h"

namespace ctcal::sim {
namespace {

namespace fs = std::filesystem;

// A text file written with stdio (much faster than iostreams for ~10^5 lines); every failure,
// including a short write found at close, throws with the path.
class CsvFile {
 public:
  CsvFile(const fs::path& path, const char* header) : path_(path.string()) {
    file_ = std::fopen(path_.c_str(), "w");
    if (file_ == nullptr)
      throw std::runtime_error("cannot write " + path_ + ": " + std::strerror(errno));
    std::fputs(header, file_);
    std::fputc('\n', file_);
  }
  ~CsvFile() {
    if (file_ != nullptr)
      std::fclose(file_);
  }
  CsvFile(const CsvFile&) = delete;
  CsvFile& operator=(const CsvFile&) = delete;

  CsvFile& Int(std::int64_t v) {
    Separator();
    std::fprintf(file_, "%lld", static_cast<long long>(v));
    return *this;
  }
  CsvFile& Num(double v) {
    Separator();
    const std::string s = FormatDouble(v);
    std::fwrite(s.data(), 1, s.size(), file_);
    return *this;
  }
  CsvFile& Vec(const Eigen::Vector3d& v) { return Num(v.x()).Num(v.y()).Num(v.z()); }
  CsvFile& Str(const std::string& s) {
    Separator();
    std::fputs(s.c_str(), file_);
    return *this;
  }
  void EndLine() {
    std::fputc('\n', file_);
    first_ = true;
  }
  void Close() {
    const bool failed = std::ferror(file_) != 0;
    const int rc = std::fclose(file_);
    file_ = nullptr;
    if (failed || rc != 0)
      throw std::runtime_error("error while writing " + path_);
  }

 private:
  void Separator() {
    if (!first_)
      std::fputc(',', file_);
    first_ = false;
  }

  std::string path_;
  std::FILE* file_ = nullptr;
  bool first_ = true;
};

fs::path MakeDir(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    throw std::runtime_error("cannot create folder " + dir.string() + ": " + ec.message());
  return dir;
}

void WriteInertial(const InertialData& d, const fs::path& dir) {
  {
    CsvFile f(dir / "data.csv", d.has_accel ? "#timestamp [ns],w_x,w_y,w_z [rad/s],a_x,a_y,a_z "
                                              "[m/s^2]"
                                            : "#timestamp [ns],w_x,w_y,w_z [rad/s]");
    for (const InertialSample& s : d.samples) {
      f.Int(s.t_ns).Vec(s.w_m);
      if (d.has_accel)
        f.Vec(s.a_m);
      f.EndLine();
    }
    f.Close();
  }
  CsvFile f(dir / "biases.csv", d.has_accel ? "#timestamp [ns],bw_x,bw_y,bw_z,ba_x,ba_y,ba_z"
                                            : "#timestamp [ns],bw_x,bw_y,bw_z");
  for (const BiasSample& b : d.biases) {
    f.Int(b.t_ns).Vec(b.b_g);
    if (d.has_accel)
      f.Vec(b.b_a);
    f.EndLine();
  }
  f.Close();
}

void WriteCamera(const CameraData& d, const fs::path& dir, const WriteOptions& options) {
  {
    CsvFile f(dir / "data.csv", "#timestamp [ns],filename");
    for (const std::int64_t ns : d.frames_ns) {
      f.Int(ns).Str(std::to_string(ns) + ".png");
      f.EndLine();
    }
    f.Close();
  }
  if (options.corners_true_only) {
    CsvFile f(dir / "corners_true.csv", "#timestamp [ns],corner_id,u,v");
    for (const CornerObservation& c : d.corners) {
      f.Int(c.t_ns).Int(c.corner_id).Num(c.uv_true.x()).Num(c.uv_true.y());
      f.EndLine();
    }
    f.Close();
    return;
  }
  CsvFile f(dir / "corners.csv", "#timestamp [ns],corner_id,u,v,sigma");
  for (const CornerObservation& c : d.corners) {
    f.Int(c.t_ns).Int(c.corner_id).Num(c.uv.x()).Num(c.uv.y()).Num(c.sigma);
    f.EndLine();
  }
  f.Close();
}

void WriteGroundTruth(const std::vector<GroundTruthSample>& gt, const fs::path& dir) {
  CsvFile f(dir / "data.csv",
            "#timestamp [ns],p_x,p_y,p_z,q_w,q_x,q_y,q_z,v_x,v_y,v_z,bw_x,bw_y,bw_z,ba_x,ba_y,"
            "ba_z");
  for (const GroundTruthSample& s : gt) {
    // q and -q are the same rotation; a positive w makes the file unambiguous.
    Eigen::Quaterniond q = s.state.q_W_B;
    if (q.w() < 0.0)
      q.coeffs() = -q.coeffs();
    f.Int(s.t_ns).Vec(s.state.p_W_B).Num(q.w()).Num(q.x()).Num(q.y()).Num(q.z());
    f.Vec(s.state.v_W).Vec(s.b_g).Vec(s.b_a);
    f.EndLine();
  }
  f.Close();
}

}  // namespace

void WriteDataset(const SimulatedDataset& data, const RigConfig& guess, const std::string& dir,
                  const WriteOptions& options) {
  const fs::path root = MakeDir(dir);
  for (const InertialData& d : data.inertial)
    WriteInertial(d, MakeDir(root / d.sensor));
  for (const CameraData& d : data.cameras)
    WriteCamera(d, MakeDir(root / d.sensor), options);
  WriteGroundTruth(data.groundtruth, MakeDir(root / "groundtruth"));
  SaveRig(data.truth, (root / "truth.yaml").string());
  SaveRig(guess, (root / "rig.yaml").string());
  SaveTargetConfig(data.truth.target, (root / "target.yaml").string());
}

}  // namespace ctcal::sim
