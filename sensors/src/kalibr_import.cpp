// Kalibr's own files (camchain, imu.yaml, target) read as a rig with initial guesses
// (kalibr_files.h, SPEC section 8's import-kalibr): the inverse of kalibr_files.cpp's writer.
#include <yaml-cpp/yaml.h>

#include <Eigen/Dense>
#include <stdexcept>

#include "ctcal/sensors/imu_intrinsics.h"
#include "ctcal/sensors/kalibr_files.h"
#include "ctcal/sensors/kalibr_imu_model.h"
#include "ctcal/sensors/rig_yaml.h"
#include "rigid_inverse.h"
#include "yaml_in.h"

namespace ctcal {
namespace {

using internal::Inverse;
using internal::YamlIn;

Eigen::Matrix4d RotationOnly(const Eigen::Matrix3d& R) {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = R;
  return T;
}

// A `scale-misalignment` block into our model (kalibr_imu_model.h); returns R_I_i.
Eigen::Matrix3d ReadScaleMisalignment(const YamlIn& in, const YAML::Node& node,
                                      const std::string& where, const KalibrImportOptions& options,
                                      SensorConfig& s) {
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
  return imported.R_I_i;
}

// One IMU block of Kalibr's imu.yaml, into our frames. *T_b_S receives the pose of our frame I
// of this IMU in Kalibr's frame b.
SensorConfig ReadKalibrImuBlock(const YamlIn& in, const YAML::Node& node, const std::string& name,
                                const std::string& where, const KalibrImportOptions& options,
                                Eigen::Matrix4d* T_b_S) {
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
    // Kalibr's default: the IMU is taken as ideal. A model asked for instead starts from the
    // identity and is estimated (the IMU's own frame is then the model's, SPEC section 3).
    s.imu_model = options.calibrated_imu_model;
    s.g_sensitivity = s.imu_model == ImuModel::kNone ? GSensitivity::kNone : options.g_sensitivity;
    if (s.imu_model != ImuModel::kNone) {
      const StoredImuIntrinsics identity = ImuIntrinsics(s.imu_model, s.g_sensitivity).ToStored();
      s.D_w = identity.Dw;
      s.D_a = identity.Da;
      s.T_g = identity.Tg;
      s.estimate.insert(EstimateItem::kIntrinsics);
    }
  } else if (model == "scale-misalignment") {
    R_I_i = ReadScaleMisalignment(in, node, where, options, s);
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

// The IMU blocks of one imu.yaml: Kalibr's output (imu0:, imu1:, ...) or its single-IMU input
// file (keys at the top level).
std::vector<std::pair<std::string, YAML::Node>> ImuBlocks(const YamlIn& in,
                                                          const YAML::Node& root) {
  in.RequireMap(root, "");
  std::vector<std::pair<std::string, YAML::Node>> blocks;
  if (!root["imu0"]) {
    blocks.emplace_back("", root);
    return blocks;
  }
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
  return blocks;
}

// The IMUs of every file, in order, named imu0, imu1, ...; returns T_b_B (our base in Kalibr's b).
Eigen::Matrix4d ReadImus(const std::vector<std::string>& imu_yamls,
                         const KalibrImportOptions& options, RigConfig& rig) {
  std::vector<Eigen::Matrix4d> T_b_S;
  for (const std::string& path : imu_yamls) {
    const YamlIn in(path);
    const YAML::Node root = YamlIn::LoadFile(path);
    for (const auto& [key, node] : ImuBlocks(in, root)) {
      const std::string name = "imu" + std::to_string(T_b_S.size());
      T_b_S.emplace_back();
      rig.sensors.push_back(
          ReadKalibrImuBlock(in, node, name, key.empty() ? name : key, options, &T_b_S.back()));
    }
  }
  const Eigen::Matrix4d T_b_B = T_b_S[0];
  rig.base_imu = rig.sensors[0].name;
  rig.sensors[0].time_offset = 0.0;
  for (std::size_t k = 1; k < T_b_S.size(); ++k) {
    rig.sensors[k].T_B_S = Inverse(T_b_B) * T_b_S[k];
    rig.sensors[k].estimate.insert(EstimateItem::kExtrinsics);
    rig.sensors[k].estimate.insert(EstimateItem::kTimeOffset);
  }
  return T_b_B;
}

SensorConfig ReadKalibrCameraIntrinsics(const YamlIn& in, const YAML::Node& c,
                                        const std::string& name) {
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
  return s;
}

// The cameras of a camchain. With IMUs, a camera's pose is T_cam_imu when given; a camchain
// without it (Kalibr's camera calibration, before its camera-IMU step) chains the cameras by
// T_cn_cnm1 from an identity guess for cam0, which ctcal's coarse initialisation then replaces
// (docs/initialisation.md).
void ReadCameras(const std::string& camchain_yaml, const Eigen::Matrix4d& T_b_B,
                 const KalibrImportOptions& options, RigConfig& rig,
                 std::vector<std::string>* warnings) {
  const bool camera_only = rig.sensors.empty();
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
    SensorConfig s = ReadKalibrCameraIntrinsics(in, c, name);
    if (options.estimate_camera_intrinsics && !(camera_only && k == 0))
      s.estimate.insert(EstimateItem::kIntrinsics);
    if (camera_only && k == 0) {
      rig.base_imu = name;
    } else if (!camera_only && c["T_cam_imu"]) {
      // T_B_C = T_B_b * T_b_C = inverse(T_b_B) * inverse(T_cam_imu).
      s.T_B_S = Inverse(T_b_B) * Inverse(in.Rigid(c["T_cam_imu"], name + ".T_cam_imu"));
    } else if (k > 0 && c["T_cn_cnm1"]) {
      // T_B_Cn = T_B_Cn-1 * inverse(T_cn_cnm1).
      s.T_B_S = T_B_prev * Inverse(in.Rigid(c["T_cn_cnm1"], name + ".T_cn_cnm1"));
    } else if (camera_only) {
      in.Fail(c, name, "missing required key 'T_cn_cnm1' (camera-only camchain)");
    } else if (warnings) {
      warnings->push_back(camchain_yaml + ": " + name +
                          ": no T_cam_imu: T_B_S starts at the identity and ctcal calibrate's "
                          "initialisation finds it");
    }
    if (!camera_only) {
      if (c["timeshift_cam_imu"])
        s.time_offset = in.FiniteDouble(c["timeshift_cam_imu"], name + ".timeshift_cam_imu");
      s.estimate.insert(EstimateItem::kTimeOffset);
    }
    if (!(camera_only && k == 0))
      s.estimate.insert(EstimateItem::kExtrinsics);
    T_B_prev = s.T_B_S;
    rig.sensors.push_back(s);
  }
}

}  // namespace

RigConfig RigFromKalibr(const std::string& camchain_yaml, const std::vector<std::string>& imu_yamls,
                        const TargetConfig& target, const KalibrImportOptions& options,
                        std::vector<std::string>* warnings) {
  RigConfig rig;
  rig.target = target;
  // Our base frame B in Kalibr's b: T_b_B (identity for a camera-only rig: b is cam0).
  Eigen::Matrix4d T_b_B = Eigen::Matrix4d::Identity();
  if (!imu_yamls.empty())
    T_b_B = ReadImus(imu_yamls, options, rig);
  if (!camchain_yaml.empty())
    ReadCameras(camchain_yaml, T_b_B, options, rig, warnings);
  if (rig.sensors.empty())
    throw std::runtime_error("no Kalibr camchain and no imu.yaml: nothing to import");
  // Kalibr writes the rotation blocks with ~8 digits; re-orthonormalise so that our stricter
  // consumers get exact rotations.
  for (SensorConfig& s : rig.sensors) {
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(s.T_B_S.topLeftCorner<3, 3>(),
                                                Eigen::ComputeFullU | Eigen::ComputeFullV);
    s.T_B_S.topLeftCorner<3, 3>() = svd.matrixU() * svd.matrixV().transpose();
  }
  ValidateRig(rig, camchain_yaml.empty() ? imu_yamls.front() : camchain_yaml);
  return rig;
}

RigConfig RigFromKalibr(const std::string& camchain_yaml, const std::string& imu_yaml,
                        const TargetConfig& target, const KalibrImportOptions& options) {
  KalibrImportOptions old = options;
  old.estimate_camera_intrinsics = false;
  old.calibrated_imu_model = ImuModel::kNone;
  return RigFromKalibr(
      camchain_yaml,
      imu_yaml.empty() ? std::vector<std::string>{} : std::vector<std::string>{imu_yaml}, target,
      old, nullptr);
}

}  // namespace ctcal
