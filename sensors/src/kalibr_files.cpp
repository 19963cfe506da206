#include "ctcal/sensors/kalibr_files.h"

#include <yaml-cpp/yaml.h>

#include <Eigen/Dense>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "ctcal/sensors/imu_intrinsics.h"
#include "ctcal/sensors/kalibr_imu_model.h"
#include "ctcal/sensors/number_format.h"
#include "ctcal/sensors/rig_yaml.h"
#include "yaml_in.h"

namespace ctcal {
namespace {

using internal::YamlIn;

Eigen::Matrix4d Inverse(const Eigen::Matrix4d& T) {
  Eigen::Matrix4d inv = Eigen::Matrix4d::Identity();
  inv.topLeftCorner<3, 3>() = T.topLeftCorner<3, 3>().transpose();
  inv.topRightCorner<3, 1>() = -T.topLeftCorner<3, 3>().transpose() * T.topRightCorner<3, 1>();
  return inv;
}

Eigen::Matrix4d RotationOnly(const Eigen::Matrix3d& R) {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = R;
  return T;
}

template <typename Derived>
void EmitMatrix(YAML::Emitter& out, const Eigen::MatrixBase<Derived>& m) {
  out << YAML::BeginSeq;
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    out << YAML::Flow << YAML::BeginSeq;
    for (Eigen::Index c = 0; c < m.cols(); ++c)
      out << FormatDouble(m(r, c));
    out << YAML::EndSeq;
  }
  out << YAML::EndSeq;
}

void EmitNumbers(YAML::Emitter& out, const std::vector<double>& v) {
  out << YAML::Flow << YAML::BeginSeq;
  for (double x : v)
    out << FormatDouble(x);
  out << YAML::EndSeq;
}

ImuIntrinsics IntrinsicsOf(const SensorConfig& s) {
  StoredImuIntrinsics stored;
  stored.Dw = s.D_w;
  stored.Da = s.D_a;
  stored.Tg = s.T_g;
  const std::string rot = RotationKey(s.imu_model);
  if (rot == "R_I_a")
    stored.rotation = s.R_I_a;
  else if (rot == "R_I_w")
    stored.rotation = s.R_I_w;
  return ImuIntrinsics::FromStored(s.imu_model, s.g_sensitivity, stored);
}

// Kalibr's model of an IMU, written in our frame I. SPEC fixes the files' IMU frame to ours
// (`T_cam_imu = inverse(T_B_C)`), while Kalibr's canonical form (lower-triangular M's) lives in
// its frame i = R_i_I I. Kalibr's equations hold in any frame: with a_i = R_i_I a_I,
//   a_m = (M_a R_i_I) a_I,   w_m = M_g (C_gyro_i R_i_I) w_I + A (C_gyro_i R_i_I) a_I,
// so M_a and C_gyro_i absorb R_i_I and the files stay exact (M_a is then full, not triangular).
KalibrScaleMisalignment KalibrModelOf(const SensorConfig& s) {
  if (s.imu_model == ImuModel::kNone)
    return {};
  Eigen::Matrix3d R_i_I;
  KalibrScaleMisalignment k = ToKalibrScaleMisalignment(IntrinsicsOf(s), &R_i_I);
  k.M_accel = k.M_accel * R_i_I;
  k.C_gyro_i = k.C_gyro_i * R_i_I;
  return k;
}

// The cameras in Kalibr's order: rig order, the base camera first in a camera-only rig.
std::vector<const SensorConfig*> KalibrCameras(const RigConfig& rig) {
  std::vector<const SensorConfig*> cams;
  if (rig.IsCameraOnly())
    cams.push_back(&rig.Base());
  for (const SensorConfig& s : rig.sensors) {
    if (s.type == SensorType::kCamera && !(rig.IsCameraOnly() && s.name == rig.base_imu))
      cams.push_back(&s);
  }
  return cams;
}

std::vector<const SensorConfig*> KalibrImus(const RigConfig& rig) {
  std::vector<const SensorConfig*> imus;
  if (!rig.IsCameraOnly())
    imus.push_back(&rig.Base());
  for (const SensorConfig& s : rig.sensors) {
    if (s.type == SensorType::kImu && s.name != rig.base_imu)
      imus.push_back(&s);
  }
  return imus;
}

void Save(const std::string& text, const std::string& path) {
  std::ofstream f(path);
  if (!f)
    throw std::runtime_error(path + ": cannot write file");
  f << text;
  if (!f)
    throw std::runtime_error(path + ": write failed");
}

}  // namespace

std::string EmitKalibrCamchain(const RigConfig& rig,
                               const std::vector<std::vector<int>>& cam_overlaps) {
  const std::vector<const SensorConfig*> cams = KalibrCameras(rig);
  const bool camera_only = rig.IsCameraOnly();
  YAML::Emitter out;
  out << YAML::BeginMap;
  for (std::size_t n = 0; n < cams.size(); ++n) {
    const SensorConfig& c = *cams[n];
    out << YAML::Key << "cam" + std::to_string(n) << YAML::Value << YAML::BeginMap;
    if (!camera_only) {
      out << YAML::Key << "T_cam_imu" << YAML::Value;
      EmitMatrix(out, Inverse(c.T_B_S));
    }
    if (n > 0) {
      out << YAML::Key << "T_cn_cnm1" << YAML::Value;
      EmitMatrix(out, Inverse(c.T_B_S) * cams[n - 1]->T_B_S);
    }
    out << YAML::Key << "cam_overlaps" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    if (n < cam_overlaps.size()) {
      for (int k : cam_overlaps[n])
        out << k;
    } else if (cam_overlaps.empty()) {
      for (std::size_t k = 0; k < cams.size(); ++k) {
        if (k != n)
          out << static_cast<int>(k);
      }
    }
    out << YAML::EndSeq;
    out << YAML::Key << "camera_model" << YAML::Value << c.camera_model;
    out << YAML::Key << "distortion_coeffs" << YAML::Value;
    EmitNumbers(out, c.distortion_coeffs);
    out << YAML::Key << "distortion_model" << YAML::Value << c.distortion_model;
    out << YAML::Key << "intrinsics" << YAML::Value;
    EmitNumbers(out, c.intrinsics);
    out << YAML::Key << "resolution" << YAML::Value << YAML::Flow << YAML::BeginSeq << c.width
        << c.height << YAML::EndSeq;
    out << YAML::Key << "rostopic" << YAML::Value
        << (c.rostopic ? *c.rostopic : "/" + c.name + "/image_raw");
    if (!camera_only)
      out << YAML::Key << "timeshift_cam_imu" << YAML::Value << FormatDouble(c.time_offset);
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

std::string EmitKalibrImu(const RigConfig& rig) {
  const std::vector<const SensorConfig*> imus = KalibrImus(rig);
  if (imus.empty())
    throw std::runtime_error("a camera-only rig has no imu.yaml");
  YAML::Emitter out;
  out << YAML::BeginMap;
  for (std::size_t k = 0; k < imus.size(); ++k) {
    const SensorConfig& s = *imus[k];
    const KalibrScaleMisalignment m = KalibrModelOf(s);
    const Eigen::Matrix4d T_B_S = s.name == rig.base_imu ? Eigen::Matrix4d::Identity() : s.T_B_S;
    const Eigen::Matrix4d T_i_b = Inverse(T_B_S);
    out << YAML::Key << "imu" + std::to_string(k) << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "T_i_b" << YAML::Value;
    EmitMatrix(out, T_i_b);
    out << YAML::Key << "accelerometer_noise_density" << YAML::Value
        << FormatDouble(s.noise.accelerometer_noise_density);
    out << YAML::Key << "accelerometer_random_walk" << YAML::Value
        << FormatDouble(s.noise.accelerometer_random_walk);
    out << YAML::Key << "gyroscope_noise_density" << YAML::Value
        << FormatDouble(s.noise.gyroscope_noise_density);
    out << YAML::Key << "gyroscope_random_walk" << YAML::Value
        << FormatDouble(s.noise.gyroscope_random_walk);
    if (s.imu_model == ImuModel::kNone) {
      out << YAML::Key << "model" << YAML::Value << "calibrated";
    } else {
      out << YAML::Key << "model" << YAML::Value << "scale-misalignment";
      out << YAML::Key << "gyroscopes" << YAML::Value << YAML::BeginMap;
      out << YAML::Key << "A" << YAML::Value;
      EmitMatrix(out, m.A_gyro);
      out << YAML::Key << "C_gyro_i" << YAML::Value;
      EmitMatrix(out, m.C_gyro_i);
      out << YAML::Key << "M" << YAML::Value;
      EmitMatrix(out, m.M_gyro);
      out << YAML::EndMap;
      out << YAML::Key << "accelerometers" << YAML::Value << YAML::BeginMap;
      out << YAML::Key << "M" << YAML::Value;
      EmitMatrix(out, m.M_accel);
      out << YAML::EndMap;
    }
    out << YAML::Key << "rostopic" << YAML::Value << (s.rostopic ? *s.rostopic : "/" + s.name);
    out << YAML::Key << "time_offset" << YAML::Value
        << FormatDouble(s.name == rig.base_imu ? 0.0 : s.time_offset);
    out << YAML::Key << "update_rate" << YAML::Value << FormatDouble(s.noise.update_rate);
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

std::vector<std::string> SaveKalibrFiles(const RigConfig& rig, const std::string& dir,
                                         const std::vector<std::vector<int>>& cam_overlaps) {
  namespace fs = std::filesystem;
  std::vector<std::string> written;
  const bool camera_only = rig.IsCameraOnly();
  const std::string camchain =
      (fs::path(dir) / (camera_only ? "camchain.yaml" : "camchain-imucam.yaml")).string();
  Save(EmitKalibrCamchain(rig, cam_overlaps), camchain);
  written.push_back(camchain);
  if (!camera_only) {
    const std::string imu = (fs::path(dir) / "imu.yaml").string();
    Save(EmitKalibrImu(rig), imu);
    written.push_back(imu);
  }
  return written;
}

namespace {

// One IMU block of Kalibr's imu.yaml, into our frames. *T_b_S receives the pose of our frame I
// of this IMU in Kalibr's frame b; *R_i_I Kalibr's i relative to our I.
SensorConfig ReadKalibrImuBlock(const YamlIn& in, const YAML::Node& node, const std::string& name,
                                const KalibrImportOptions& options, Eigen::Matrix4d* T_b_S) {
  const std::string where = name;
  in.CheckKeys(node, where,
               {"T_i_b", "accelerometer_noise_density", "accelerometer_random_walk",
                "gyroscope_noise_density", "gyroscope_random_walk", "model", "gyroscopes",
                "accelerometers", "rostopic", "time_offset", "update_rate"},
               "a Kalibr IMU");
  SensorConfig s;
  s.name = name;
  s.type = SensorType::kImu;
  auto req = [&](const char* key) {
    if (!node[key])
      in.Fail(node, where, std::string("missing required key '") + key + "'");
    return in.FiniteDouble(node[key], where + "." + key);
  };
  s.noise.accelerometer_noise_density = req("accelerometer_noise_density");
  s.noise.accelerometer_random_walk = req("accelerometer_random_walk");
  s.noise.gyroscope_noise_density = req("gyroscope_noise_density");
  s.noise.gyroscope_random_walk = req("gyroscope_random_walk");
  s.noise.update_rate = req("update_rate");
  if (node["rostopic"])
    s.rostopic = in.String(node["rostopic"], where + ".rostopic");
  if (node["time_offset"])
    s.time_offset = in.FiniteDouble(node["time_offset"], where + ".time_offset");
  const Eigen::Matrix4d T_i_b = node["T_i_b"]
                                    ? Eigen::Matrix4d(in.Rigid(node["T_i_b"], where + ".T_i_b"))
                                    : Eigen::Matrix4d::Identity();
  const std::string model =
      node["model"] ? in.String(node["model"], where + ".model") : std::string("calibrated");
  Eigen::Matrix3d R_I_i = Eigen::Matrix3d::Identity();
  if (model == "calibrated") {
    s.imu_model = ImuModel::kNone;
    s.g_sensitivity = GSensitivity::kNone;
  } else if (model == "scale-misalignment") {
    KalibrScaleMisalignment k;
    if (node["gyroscopes"]) {
      const YAML::Node g = node["gyroscopes"];
      in.CheckKeys(g, where + ".gyroscopes", {"M", "A", "C_gyro_i"}, "Kalibr gyroscopes");
      if (g["M"])
        k.M_gyro = in.Matrix(g["M"], where + ".gyroscopes.M", 3, 3);
      if (g["A"])
        k.A_gyro = in.Matrix(g["A"], where + ".gyroscopes.A", 3, 3);
      if (g["C_gyro_i"])
        k.C_gyro_i = in.Rotation(g["C_gyro_i"], where + ".gyroscopes.C_gyro_i");
    }
    if (node["accelerometers"]) {
      const YAML::Node a = node["accelerometers"];
      in.CheckKeys(a, where + ".accelerometers", {"M"}, "Kalibr accelerometers");
      if (a["M"])
        k.M_accel = in.Matrix(a["M"], where + ".accelerometers.M", 3, 3);
    }
    KalibrImuImport imported;
    try {
      imported = FromKalibrScaleMisalignment(k, options.imu_model, options.g_sensitivity);
    } catch (const std::invalid_argument& e) {
      in.Fail(node, where, std::string("scale-misalignment model: ") + e.what());
    }
    const StoredImuIntrinsics stored = imported.intrinsics.ToStored();
    s.imu_model = options.imu_model;
    s.g_sensitivity = options.g_sensitivity;
    s.D_w = stored.Dw;
    s.D_a = stored.Da;
    s.T_g = stored.Tg;
    if (stored.rotation) {
      if (RotationKey(s.imu_model) == "R_I_a")
        s.R_I_a = *stored.rotation;
      else
        s.R_I_w = *stored.rotation;
    }
    R_I_i = imported.R_I_i;
  } else {
    in.Fail(node["model"], where,
            "Kalibr IMU model '" + model +
                "' is not supported (calibrated or scale-misalignment; "
                "scale-misalignment-size-effect has lever arms ctcal does not model)");
  }
  // T_b_I = T_b_i * T_i_I = inverse(T_i_b) * R_i_I.
  *T_b_S = Inverse(T_i_b) * RotationOnly(R_I_i.transpose());
  return s;
}

}  // namespace

RigConfig RigFromKalibr(const std::string& camchain_yaml, const std::string& imu_yaml,
                        const TargetConfig& target, const KalibrImportOptions& options) {
  RigConfig rig;
  rig.target = target;
  const bool camera_only = imu_yaml.empty();
  // Our base frame B in Kalibr's b: T_b_B (identity for a camera-only rig: b is cam0).
  Eigen::Matrix4d T_b_B = Eigen::Matrix4d::Identity();
  if (!camera_only) {
    const YamlIn in(imu_yaml);
    const YAML::Node root = YamlIn::LoadFile(imu_yaml);
    in.RequireMap(root, "");
    std::vector<std::pair<std::string, YAML::Node>> blocks;
    if (root["imu0"]) {
      for (int k = 0; root["imu" + std::to_string(k)]; ++k)
        blocks.emplace_back("imu" + std::to_string(k), root["imu" + std::to_string(k)]);
      for (const auto& kv : root) {
        const std::string key = in.String(kv.first, "");
        bool listed = false;
        for (const auto& block : blocks)
          listed = listed || block.first == key;
        if (!listed)
          in.Fail(kv.first, "", "unexpected key '" + key + "' (expected imu0, imu1, ...)");
      }
    } else {
      blocks.emplace_back("imu0", root);  // Kalibr's single-IMU input file
    }
    std::vector<Eigen::Matrix4d> T_b_S(blocks.size());
    for (std::size_t k = 0; k < blocks.size(); ++k) {
      rig.sensors.push_back(
          ReadKalibrImuBlock(in, blocks[k].second, blocks[k].first, options, &T_b_S[k]));
    }
    T_b_B = T_b_S[0];
    rig.base_imu = rig.sensors[0].name;
    rig.sensors[0].time_offset = 0.0;
    for (std::size_t k = 1; k < blocks.size(); ++k) {
      rig.sensors[k].T_B_S = Inverse(T_b_B) * T_b_S[k];
      rig.sensors[k].estimate = {EstimateItem::kExtrinsics, EstimateItem::kTimeOffset};
    }
  }

  const YamlIn in(camchain_yaml);
  const YAML::Node root = YamlIn::LoadFile(camchain_yaml);
  in.RequireMap(root, "");
  int n = 0;
  for (; root["cam" + std::to_string(n)]; ++n) {
  }
  if (n == 0)
    in.Fail(root, "", "no cam0 block: not a Kalibr camchain file");
  if (static_cast<int>(root.size()) != n)
    in.Fail(root, "", "keys other than cam0..cam" + std::to_string(n - 1));
  Eigen::Matrix4d T_B_prev = Eigen::Matrix4d::Identity();
  for (int k = 0; k < n; ++k) {
    const std::string name = "cam" + std::to_string(k);
    const YAML::Node c = root[name];
    in.CheckKeys(c, name,
                 {"T_cam_imu", "T_cn_cnm1", "cam_overlaps", "camera_model", "distortion_coeffs",
                  "distortion_model", "intrinsics", "resolution", "rostopic", "timeshift_cam_imu",
                  "line_delay"},
                 "a Kalibr camera");
    SensorConfig s;
    s.name = name;
    s.type = SensorType::kCamera;
    for (const char* key : {"camera_model", "intrinsics", "distortion_model", "resolution"}) {
      if (!c[key])
        in.Fail(c, name, std::string("missing required key '") + key + "'");
    }
    s.camera_model = in.String(c["camera_model"], name + ".camera_model");
    s.intrinsics = in.Vector(c["intrinsics"], name + ".intrinsics", -1);
    s.distortion_model = in.String(c["distortion_model"], name + ".distortion_model");
    if (c["distortion_coeffs"])
      s.distortion_coeffs = in.Vector(c["distortion_coeffs"], name + ".distortion_coeffs", -1);
    if (!c["resolution"].IsSequence() || c["resolution"].size() != 2)
      in.Fail(c["resolution"], name, "resolution: expected [width, height]");
    s.width = in.Int(c["resolution"][0], name + ".resolution");
    s.height = in.Int(c["resolution"][1], name + ".resolution");
    if (c["rostopic"])
      s.rostopic = in.String(c["rostopic"], name + ".rostopic");
    if (c["line_delay"])
      s.line_delay = in.FiniteDouble(c["line_delay"], name + ".line_delay");
    if (camera_only) {
      if (k == 0) {
        rig.base_imu = name;
      } else {
        if (!c["T_cn_cnm1"])
          in.Fail(c, name, "missing required key 'T_cn_cnm1' (camera-only camchain)");
        // T_B_Cn = T_B_Cn-1 * inverse(T_cn_cnm1).
        s.T_B_S = T_B_prev * Inverse(in.Rigid(c["T_cn_cnm1"], name + ".T_cn_cnm1"));
        s.estimate = {EstimateItem::kExtrinsics};
      }
    } else {
      if (!c["T_cam_imu"])
        in.Fail(c, name, "missing required key 'T_cam_imu'");
      // T_B_C = T_B_b * T_b_C = inverse(T_b_B) * inverse(T_cam_imu).
      s.T_B_S = Inverse(T_b_B) * Inverse(in.Rigid(c["T_cam_imu"], name + ".T_cam_imu"));
      if (c["timeshift_cam_imu"])
        s.time_offset = in.FiniteDouble(c["timeshift_cam_imu"], name + ".timeshift_cam_imu");
      s.estimate = {EstimateItem::kExtrinsics, EstimateItem::kTimeOffset};
    }
    T_B_prev = s.T_B_S;
    rig.sensors.push_back(s);
  }
  // Kalibr writes the rotation blocks with ~8 digits; re-orthonormalise so that our stricter
  // consumers get exact rotations.
  for (SensorConfig& s : rig.sensors) {
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(s.T_B_S.topLeftCorner<3, 3>(),
                                                Eigen::ComputeFullU | Eigen::ComputeFullV);
    s.T_B_S.topLeftCorner<3, 3>() = svd.matrixU() * svd.matrixV().transpose();
  }
  ValidateRig(rig, camchain_yaml);
  return rig;
}

}  // namespace ctcal
