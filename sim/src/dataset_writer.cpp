#include "ctcal/sim/dataset_writer.h"

#include <filesystem>
#include <optional>
#include <stdexcept>

#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig_yaml.h"
#include "ctcal/targets/target_config.h"

namespace ctcal::sim {
namespace {

namespace fs = std::filesystem;

fs::path MakeDir(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    throw std::runtime_error("cannot create folder " + dir.string() + ": " + ec.message());
  return dir;
}

void WriteInertial(const InertialData& d, const fs::path& dir) {
  std::vector<ctcal::BiasSample> biases;
  biases.reserve(d.biases.size());
  for (const BiasState& b : d.biases) {
    biases.push_back({b.t_ns, b.b_g, std::nullopt});
    if (d.has_accel)
      biases.back().b_a = b.b_a;
  }
  WriteBiasesCsv((dir / "biases.csv").string(), biases);
  if (d.has_accel) {
    std::vector<ImuSample> samples;
    samples.reserve(d.samples.size());
    for (const InertialSample& s : d.samples)
      samples.push_back({s.t_ns, s.w_m, s.a_m});
    WriteImuCsv((dir / "data.csv").string(), samples);
  } else {
    std::vector<GyroSample> samples;
    samples.reserve(d.samples.size());
    for (const InertialSample& s : d.samples)
      samples.push_back({s.t_ns, s.w_m});
    WriteGyroCsv((dir / "data.csv").string(), samples);
  }
}

void WriteCamera(const CameraData& d, const fs::path& dir, const WriteOptions& options) {
  std::vector<ImageEntry> images;
  images.reserve(d.frames_ns.size());
  for (const std::int64_t ns : d.frames_ns)
    images.push_back({ns, std::to_string(ns) + ".png"});
  WriteImageCsv((dir / "data.csv").string(), images);
  std::vector<CornerObservation> corners;
  corners.reserve(d.corners.size());
  for (const SimulatedCorner& c : d.corners) {
    if (options.corners_true_only)
      corners.push_back({c.t_ns, c.corner_id, c.uv_true.x(), c.uv_true.y(), std::nullopt});
    else
      corners.push_back({c.t_ns, c.corner_id, c.uv.x(), c.uv.y(), c.sigma});
  }
  WriteCornersCsv((dir / (options.corners_true_only ? "corners_true.csv" : "corners.csv")).string(),
                  corners);
}

void WriteGroundTruth(const std::vector<GroundTruthSample>& gt, const fs::path& dir) {
  std::vector<GroundTruthState> states;
  states.reserve(gt.size());
  for (const GroundTruthSample& s : gt) {
    // q and -q are the same rotation; a positive w makes the file unambiguous.
    Eigen::Quaterniond q = s.state.q_W_B;
    if (q.w() < 0.0)
      q.coeffs() = -q.coeffs();
    states.push_back({s.t_ns, s.state.p_W_B, q, s.state.v_W, s.b_g, s.b_a});
  }
  WriteGroundTruthCsv((dir / "data.csv").string(), states);
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

std::map<std::string, SensorData> ToSensorData(const SimulatedDataset& data) {
  std::map<std::string, SensorData> out;
  for (const InertialData& d : data.inertial) {
    SensorData& s = out[d.sensor];
    for (const InertialSample& m : d.samples) {
      if (d.has_accel)
        s.imu.push_back({m.t_ns, m.w_m, m.a_m});
      else
        s.gyro.push_back({m.t_ns, m.w_m});
    }
  }
  for (const CameraData& d : data.cameras) {
    SensorData& s = out[d.sensor];
    s.has_corners = true;
    for (const std::int64_t ns : d.frames_ns)
      s.images.push_back({ns, std::to_string(ns) + ".png"});
    for (const SimulatedCorner& c : d.corners)
      s.corners.push_back({c.t_ns, c.corner_id, c.uv.x(), c.uv.y(), c.sigma});
  }
  return out;
}

}  // namespace ctcal::sim
