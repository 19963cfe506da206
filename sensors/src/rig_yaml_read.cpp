// The rig file's reader (SPEC section 7): every key checked, every error naming the file, line
// and key.
#include <yaml-cpp/yaml.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <map>
#include <set>
#include <stdexcept>

#include "ctcal/sensors/mrcal_lens.h"
#include "ctcal/sensors/number_format.h"
#include "ctcal/sensors/parameter_names.h"
#include "ctcal/sensors/rig_yaml.h"
#include "rig_yaml_rules.h"
#include "yaml_in.h"

namespace ctcal {

using namespace internal;  // NOLINT(build/namespaces): rig_yaml_rules.h and YamlIn

namespace {

const std::set<std::string> kImuNoiseKeys = {"gyroscope_noise_density", "gyroscope_random_walk",
                                             "accelerometer_noise_density",
                                             "accelerometer_random_walk", "update_rate"};
const std::set<std::string> kGyroNoiseKeys = {"gyroscope_noise_density", "gyroscope_random_walk",
                                              "update_rate"};
// What a gyro's noise block may hold: its keys, or a whole Kalibr imu.yaml block.
const std::set<std::string> kGyroKalibrNoiseKeys = {
    "gyroscope_noise_density",     "gyroscope_random_walk",     "update_rate",
    "accelerometer_noise_density", "accelerometer_random_walk", "rostopic"};

class RigReader {
 public:
  RigReader(const std::string& file, std::vector<std::string>* warnings)
      : in_(file), warnings_(warnings) {
    in_.SetWarn([this](const std::string& line) { Emit(line); });
  }

  RigConfig Read(const YAML::Node& root) {
    if (!root.IsMap())
      in_.Fail(root, "", "expected a rig file: a map with base_imu, target and sensors");
    in_.CheckKeys(root, "",
                  {"base_imu", "gravity_magnitude", "target", "sensors", "gravity_W", "sigma",
                   "solver", "residuals", "observability"},
                  "a rig file");
    for (const char* key : {"base_imu", "target", "sensors"}) {
      if (!root[key])
        in_.Fail(root, "", std::string("missing required key '") + key + "'");
    }
    RigConfig rig;
    rig.base_imu = in_.String(root["base_imu"], "base_imu");
    if (root["gravity_magnitude"]) {
      rig.gravity_magnitude = in_.FiniteDouble(root["gravity_magnitude"], "gravity_magnitude");
      if (!(rig.gravity_magnitude > 0.0))
        in_.Fail(root["gravity_magnitude"], "gravity_magnitude", "must be > 0 (m/s^2)");
    }
    try {
      rig.target = ParseTargetConfig(root["target"], in_.file());
    } catch (const std::runtime_error& e) {
      // The target parser names the file; add the line of the target block.
      in_.Fail(root["target"], "", std::string(e.what()).substr(in_.file().size() + 2));
    }

    const YAML::Node sensors = root["sensors"];
    if (!sensors.IsMap() || sensors.size() == 0)
      in_.Fail(sensors, "sensors", "expected a map of sensor names to sensors");
    // First pass: names and types, which decide what every sensor may contain.
    std::set<std::string> names;
    bool has_imu = false;
    for (const auto& kv : sensors) {
      const std::string name = in_.String(kv.first, "sensors");
      if (name == "groundtruth")
        in_.Fail(kv.first, "sensors", "'groundtruth' cannot name a sensor (reserved)");
      if (!ValidSensorName(name))
        in_.Fail(kv.first, "sensors", "'" + name + "' cannot name a sensor: " + kNameRule);
      if (!names.insert(name).second)
        in_.Fail(kv.first, "sensors", "sensor '" + name + "' is given twice");
      in_.RequireMap(kv.second, Where(name));
      if (!kv.second["type"])
        in_.Fail(kv.second, Where(name), "missing required key 'type' (imu, gyro or camera)");
      SensorConfig s;
      s.name = name;
      s.type = Parse(kv.second["type"], Where(name), "type", ParseSensorType);
      has_imu = has_imu || s.type == SensorType::kImu;
      rig.sensors.push_back(s);
    }
    if (!names.count(rig.base_imu)) {
      in_.Fail(root["base_imu"], "base_imu",
               "names no sensor: '" + rig.base_imu + "' is not under sensors");
    }
    camera_only_ = !has_imu;

    std::size_t i = 0;
    for (const auto& kv : sensors)
      ReadSensor(kv.second, rig.sensors[i++], rig.base_imu);
    // Second pass: sigma blocks, whose keys depend on the whole rig (base, camera-only).
    i = 0;
    for (const auto& kv : sensors) {
      SensorConfig& s = rig.sensors[i++];
      if (kv.second["prior_sigma"])
        s.prior_sigma = ReadSigma(kv.second["prior_sigma"], rig, s, "prior_sigma");
      if (kv.second["sigma"])
        s.sigma = ReadSigma(kv.second["sigma"], rig, s, "sigma");
      if (kv.second["sigma_formal"])
        s.sigma_formal = ReadSigma(kv.second["sigma_formal"], rig, s, "sigma_formal");
    }

    if (root["gravity_W"])
      rig.gravity_W = in_.Vector3(root["gravity_W"], "gravity_W");
    if (root["sigma"]) {
      in_.CheckKeys(root["sigma"], "sigma", {"gravity_W"}, "the top-level sigma");
      if (root["sigma"]["gravity_W"]) {
        const std::vector<double> v =
            ReadSigmaValues(root["sigma"]["gravity_W"], "sigma.gravity_W", 3, false, "sigma");
        rig.sigma_gravity_W = Eigen::Vector3d(v[0], v[1], v[2]);
      }
    }
    if (root["solver"])
      rig.solver = ReadSolver(root["solver"]);
    if (root["residuals"])
      ReadResiduals(root["residuals"], &rig);
    if (root["observability"])
      rig.observability = ReadObservability(root["observability"]);

    ValidateRigAt(rig, in_.file(), [&root](const std::string& where, const std::string& key) {
      YAML::Node node;
      if (where.rfind("sensors.", 0) == 0) {
        const YAML::Node sensor = root["sensors"][where.substr(8)];
        node = !key.empty() && sensor[key] ? sensor[key] : sensor;
      } else if (!where.empty()) {
        node = root[where];
      }
      return node.IsDefined() && node.Mark().line >= 0 ? node.Mark().line + 1 : 0;
    });
    return rig;
  }

 private:
  template <typename R>
  R Parse(const YAML::Node& node, const std::string& where, const std::string& key,
          R (*parse)(const std::string&)) const {
    try {
      return parse(in_.String(node, where + "." + key));
    } catch (const std::invalid_argument& e) {
      in_.Fail(node, where, key + ": " + e.what());
    }
  }

  void Warn(const std::string& what) { Emit(in_.file() + ": warning: " + what); }

  void Emit(const std::string& line) {
    if (warnings_)
      warnings_->push_back(line);
    else
      std::cerr << line << "\n";
  }

  std::vector<double> ReadStored(const YAML::Node& node, const std::string& where,
                                 const std::string& key, int count, const std::string& model) {
    if (!node.IsSequence())
      in_.Fail(node, where, key + ": expected a list of " + std::string(StoredForm(count)));
    if (static_cast<int>(node.size()) != count) {
      in_.Fail(node, where,
               key + " of " + model + " has " + StoredForm(count) + ", got " +
                   std::to_string(node.size()));
    }
    return in_.Vector(node, where + "." + key, count);
  }

  void ReadSensor(const YAML::Node& node, SensorConfig& s, const std::string& base) {
    const std::string where = Where(s.name);
    const bool is_base = s.name == base;
    // noise_estimated / sigma_formal: results only, read back and ignored (SPEC section 7).
    std::set<std::string> allowed = {"type",  "noise",    "estimate",        "prior_sigma",
                                     "sigma", "rostopic", "noise_estimated", "sigma_formal"};
    std::string kind;
    switch (s.type) {
      case SensorType::kImu:
        allowed.insert({"model", "g_sensitivity", "Dw", "Da", "Tg", "R_I_a", "R_I_w"});
        kind = "a sensor of type imu";
        break;
      case SensorType::kGyro:
        allowed.insert({"model", "Dw"});
        kind = "a sensor of type gyro";
        for (const char* key : {"Da", "Tg", "R_I_a", "R_I_w", "g_sensitivity"}) {
          if (node[key]) {
            in_.Fail(node[key], where,
                     std::string("a gyroscope-only sensor has no ") + key +
                         " (only Dw and its bias; SPEC section 3)");
          }
        }
        break;
      case SensorType::kCamera:
        allowed.insert({"camera_model", "intrinsics", "distortion_model", "distortion_coeffs",
                        "resolution", "line_delay", "lensmodel"});
        kind = "a sensor of type camera";
        break;
    }
    allowed.insert({"T_B_S", "time_offset"});
    // SPEC section 7 lists T_B_S and time_offset for "all but the base"; a writer that spells
    // out the base's definition (identity, 0) is read, anything else is an error
    // (docs/conventions.md, "SPEC read twice").
    if (is_base && node["T_B_S"] &&
        in_.Rigid(node["T_B_S"], where + ".T_B_S") != Eigen::Matrix4d::Identity()) {
      in_.Fail(node["T_B_S"], where,
               "T_B_S is not allowed on the base sensor other than as the identity (its frame "
               "is B)");
    }
    if (is_base && node["time_offset"] &&
        in_.FiniteDouble(node["time_offset"], where + ".time_offset") != 0.0) {
      in_.Fail(node["time_offset"], where,
               "time_offset is not allowed on the base sensor other than as 0 (its clock is the "
               "reference)");
    }
    in_.CheckKeys(node, where, allowed, kind);

    if (s.type == SensorType::kImu)
      ReadImu(node, s);
    else if (s.type == SensorType::kGyro)
      ReadGyro(node, s);
    else
      ReadCamera(node, s);

    if (!is_base) {
      if (node["T_B_S"]) {
        s.T_B_S = in_.Rigid(node["T_B_S"], where + ".T_B_S");
      } else {
        Warn(where +
             ": no T_B_S given, using identity (give a guess: the calibration starts "
             "from it)");
      }
      if (node["time_offset"])
        s.time_offset = in_.FiniteDouble(node["time_offset"], where + ".time_offset");
    }

    if (node["estimate"]) {
      const YAML::Node est = node["estimate"];
      if (!est.IsSequence() && !est.IsNull())
        in_.Fail(est, where, "estimate: expected a list such as [extrinsics, time_offset]");
      for (const auto& item : est) {
        const EstimateItem e = Parse(item, where, "estimate", ParseEstimateItem);
        if (!s.estimate.insert(e).second)
          in_.Fail(item, where, "estimate: '" + ToString(e) + "' is listed twice");
      }
    } else if (!is_base) {
      s.estimate = {EstimateItem::kExtrinsics};
      // A camera-only rig pairs frames by stamp and estimates no time offset (SPEC section 7).
      if (!camera_only_)
        s.estimate.insert(EstimateItem::kTimeOffset);
    }
    if (node["rostopic"])
      s.rostopic = in_.String(node["rostopic"], where + ".rostopic");
  }

  // `key`: "noise", or a result's "noise_estimated" (same keys) into *out.
  void ReadInertialNoise(const YAML::Node& sensor_node, SensorConfig& s,
                         const std::string& key_name = "noise", InertialNoise* out = nullptr) {
    const std::string where = Where(s.name) + "." + key_name;
    const YAML::Node node = sensor_node[key_name];
    if (!node)
      in_.Fail(sensor_node, Where(s.name), "missing required key 'noise' (Kalibr's noise keys)");
    InertialNoise& noise = out != nullptr ? *out : s.noise;
    const bool gyro = s.type == SensorType::kGyro;
    const std::set<std::string>& keys = gyro ? kGyroNoiseKeys : kImuNoiseKeys;
    // A gyro's block may be a whole Kalibr imu.yaml block (SPEC section 3): the accelerometer's
    // keys (and its rostopic) are accepted and ignored, with one warning.
    in_.CheckKeys(node, where, gyro ? kGyroKalibrNoiseKeys : kImuNoiseKeys,
                  gyro ? "the noise of a gyro" : "the noise of an imu");
    if (gyro) {
      std::string ignored;
      for (const auto& kv : node) {
        const std::string key = kv.first.Scalar();
        if (!keys.count(key))
          ignored += (ignored.empty() ? "" : ", ") + key;
      }
      if (!ignored.empty())
        Warn(where + ": " + ignored + " ignored (a gyroscope has no accelerometer)");
    }
    std::map<std::string, double> v;
    for (const std::string& key : keys) {
      if (!node[key])
        in_.Fail(node, where, "missing required key '" + key + "'");
      v[key] = in_.FiniteDouble(node[key], where + "." + key);
      if (v[key] < 0.0)
        in_.Fail(node[key], where, key + " must be >= 0");
    }
    if (!(v["update_rate"] > 0.0))
      in_.Fail(node["update_rate"], where, "update_rate must be > 0 (Hz)");
    noise.gyroscope_noise_density = v["gyroscope_noise_density"];
    noise.gyroscope_random_walk = v["gyroscope_random_walk"];
    noise.update_rate = v["update_rate"];
    if (!gyro) {
      noise.accelerometer_noise_density = v["accelerometer_noise_density"];
      noise.accelerometer_random_walk = v["accelerometer_random_walk"];
    }
    // A result's estimate is read back (for the report) and never used as input.
    if (out == nullptr && sensor_node["noise_estimated"]) {
      s.noise_estimated.emplace();
      ReadInertialNoise(sensor_node, s, "noise_estimated", &*s.noise_estimated);
    }
  }

  void ReadImu(const YAML::Node& node, SensorConfig& s) {
    const std::string where = Where(s.name);
    if (node["model"])
      s.imu_model = Parse(node["model"], where, "model", ParseImuModel);
    if (node["g_sensitivity"])
      s.g_sensitivity = Parse(node["g_sensitivity"], where, "g_sensitivity", ParseGSensitivity);
    const std::string model = "model " + ToString(s.imu_model);
    if (s.imu_model == ImuModel::kNone && s.g_sensitivity != GSensitivity::kNone)
      in_.Fail(node["g_sensitivity"], where, "g_sensitivity must be none with model none");
    const std::string rot = RotationKey(s.imu_model);
    for (const char* key : {"Dw", "Da"}) {
      if (node[key] && s.imu_model == ImuModel::kNone)
        in_.Fail(node[key], where, std::string(key) + " is not a parameter of model none");
    }
    for (const char* key : {"R_I_a", "R_I_w"}) {
      if (node[key] && rot != key) {
        in_.Fail(node[key], where,
                 std::string(key) + " is not a parameter of " + model +
                     (rot.empty() ? " (it has no rotation)" : " (it estimates " + rot + ")"));
      }
    }
    if (node["Tg"] && s.g_sensitivity == GSensitivity::kNone)
      in_.Fail(node["Tg"], where, "Tg is given but g_sensitivity is none");

    const int dw = DwCount(s), da = DaCount(s), tg = TgCount(s);
    if (dw > 0)
      s.D_w = node["Dw"] ? ReadStored(node["Dw"], where, "Dw", dw, model) : IdentityStored(dw);
    if (da > 0)
      s.D_a = node["Da"] ? ReadStored(node["Da"], where, "Da", da, model) : IdentityStored(da);
    if (tg > 0) {
      s.T_g = node["Tg"] ? ReadStored(node["Tg"], where, "Tg", tg,
                                      "g_sensitivity " + ToString(s.g_sensitivity))
                         : std::vector<double>(static_cast<std::size_t>(tg), 0.0);
    }
    if (rot == "R_I_a" && node["R_I_a"])
      s.R_I_a = in_.Rotation(node["R_I_a"], where + ".R_I_a");
    if (rot == "R_I_w" && node["R_I_w"])
      s.R_I_w = in_.Rotation(node["R_I_w"], where + ".R_I_w");
    ReadInertialNoise(node, s);
  }

  void ReadGyro(const YAML::Node& node, SensorConfig& s) {
    const std::string where = Where(s.name);
    if (node["model"])
      s.gyro_model = Parse(node["model"], where, "model", ParseGyroModel);
    const int dw = DwCount(s);
    if (node["Dw"] && dw == 0)
      in_.Fail(node["Dw"], where, "Dw is not a parameter of gyro model none");
    if (dw > 0) {
      s.D_w = node["Dw"]
                  ? ReadStored(node["Dw"], where, "Dw", dw, "gyro model " + ToString(s.gyro_model))
                  : IdentityStored(dw);
    }
    ReadInertialNoise(node, s);
  }

  void ReadCamera(const YAML::Node& node, SensorConfig& s) {
    const std::string where = Where(s.name);
    for (const char* key : {"camera_model", "intrinsics", "resolution"}) {
      if (!node[key])
        in_.Fail(node, where, std::string("missing required key '") + key + "'");
    }
    s.camera_model = in_.String(node["camera_model"], where + ".camera_model");
    if (s.camera_model == "mrcal") {
      ReadMrcalLens(node, s);
      ReadImagerKeys(node, s);
      return;
    }
    if (node["lensmodel"])
      in_.Fail(node["lensmodel"], where, "lensmodel is a key of camera_model mrcal only");
    const int n_intrinsics = IntrinsicsCount(s.camera_model);
    if (n_intrinsics < 0) {
      in_.Fail(node["camera_model"], where,
               "unknown camera_model '" + s.camera_model +
                   "' (expected pinhole, omni, ds, eucm, mrcal)");
    }
    if (node["distortion_model"])
      s.distortion_model = in_.String(node["distortion_model"], where + ".distortion_model");
    const int n_dist = DistortionCount(s.distortion_model);
    if (n_dist < 0) {
      in_.Fail(node["distortion_model"], where,
               "unknown distortion_model '" + s.distortion_model +
                   "' (expected radtan, equidistant, none)");
    }
    const bool combo_ok = (s.camera_model == "pinhole") ||
                          (s.camera_model == "omni" && s.distortion_model != "equidistant") ||
                          s.distortion_model == "none";
    if (!combo_ok) {
      in_.Fail(node["distortion_model"], where,
               "camera_model " + s.camera_model + " does not take distortion_model " +
                   s.distortion_model + " (SPEC section 4)");
    }
    if (!node["intrinsics"].IsSequence() ||
        static_cast<int>(node["intrinsics"].size()) != n_intrinsics) {
      in_.Fail(node["intrinsics"], where,
               "intrinsics of camera_model " + s.camera_model + " are " +
                   std::to_string(n_intrinsics) + " numbers, got " +
                   (node["intrinsics"].IsSequence() ? std::to_string(node["intrinsics"].size())
                                                    : std::string("no list")));
    }
    s.intrinsics = in_.Vector(node["intrinsics"], where + ".intrinsics", n_intrinsics);
    if (node["distortion_coeffs"]) {
      const YAML::Node d = node["distortion_coeffs"];
      if (!d.IsSequence() || static_cast<int>(d.size()) != n_dist) {
        in_.Fail(d, where,
                 "distortion_coeffs of distortion_model " + s.distortion_model + " are " +
                     std::to_string(n_dist) + " numbers, got " +
                     (d.IsSequence() ? std::to_string(d.size()) : std::string("no list")));
      }
      s.distortion_coeffs = in_.Vector(d, where + ".distortion_coeffs", n_dist);
    } else if (n_dist > 0) {
      in_.Fail(node, where,
               "missing required key 'distortion_coeffs' (" + std::to_string(n_dist) +
                   " numbers for " + s.distortion_model + ")");
    }
    ReadImagerKeys(node, s);
  }

  // camera_model mrcal (docs/camera_models.md): mrcal's `lensmodel:` name, kept in
  // SensorConfig::distortion_model (the name CameraModel::Create takes for it), and all of mrcal's
  // parameters as `intrinsics`; distortion_model / distortion_coeffs are not used.
  void ReadMrcalLens(const YAML::Node& node, SensorConfig& s) {
    const std::string where = Where(s.name);
    if (!node["lensmodel"])
      in_.Fail(node, where, "camera_model mrcal needs 'lensmodel' (e.g. LENSMODEL_OPENCV8)");
    for (const char* key : {"distortion_model", "distortion_coeffs"}) {
      if (node[key])
        in_.Fail(node[key], where,
                 std::string("camera_model mrcal takes no ") + key +
                     " (mrcal's distortions are part of its intrinsics)");
    }
    s.distortion_model = in_.String(node["lensmodel"], where + ".lensmodel");
    int n = 0;
    try {
      n = MrcalLens::FromName(s.distortion_model)->NumParams();
    } catch (const std::invalid_argument& e) {
      in_.Fail(node["lensmodel"], where, e.what());
    }
    if (!node["intrinsics"].IsSequence() || static_cast<int>(node["intrinsics"].size()) != n) {
      in_.Fail(node["intrinsics"], where,
               "intrinsics of " + s.distortion_model + " are " + std::to_string(n) +
                   " numbers, got " +
                   (node["intrinsics"].IsSequence() ? std::to_string(node["intrinsics"].size())
                                                    : std::string("no list")));
    }
    s.intrinsics = in_.Vector(node["intrinsics"], where + ".intrinsics", n);
    s.distortion_coeffs.clear();
  }

  // resolution, line_delay and the pixel noise, common to every camera model.
  void ReadImagerKeys(const YAML::Node& node, SensorConfig& s) {
    const std::string where = Where(s.name);
    const YAML::Node res = node["resolution"];
    if (!res.IsSequence() || res.size() != 2)
      in_.Fail(res, where, "resolution: expected [width, height]");
    s.width = in_.Int(res[0], where + ".resolution");
    s.height = in_.Int(res[1], where + ".resolution");
    if (s.width <= 0 || s.height <= 0)
      in_.Fail(res, where, "resolution: width and height must be > 0");
    if (node["line_delay"]) {
      s.line_delay = in_.FiniteDouble(node["line_delay"], where + ".line_delay");
      if (s.line_delay < 0.0)
        in_.Fail(node["line_delay"], where, "line_delay must be >= 0 (seconds per row)");
    }
    if (node["noise"]) {
      in_.CheckKeys(node["noise"], where + ".noise", {"pixel_sigma"}, "the noise of a camera");
      if (node["noise"]["pixel_sigma"]) {
        s.pixel_sigma = in_.FiniteDouble(node["noise"]["pixel_sigma"], where + ".noise");
        if (!(s.pixel_sigma > 0.0))
          in_.Fail(node["noise"]["pixel_sigma"], where, "noise.pixel_sigma must be > 0 (px)");
      }
    }
    // A result's estimate is read back (for the report) and never used as input.
    if (node["noise_estimated"]) {
      const YAML::Node e = node["noise_estimated"];
      in_.CheckKeys(e, where + ".noise_estimated", {"pixel_sigma"}, "the noise of a camera");
      if (e["pixel_sigma"])
        s.pixel_sigma_estimated = in_.FiniteDouble(e["pixel_sigma"], where + ".noise_estimated");
    }
  }

  std::vector<double> ReadSigmaValues(const YAML::Node& node, const std::string& where, int size,
                                      bool scalar, const std::string& block) {
    std::vector<double> v;
    if (scalar) {
      if (!node.IsScalar())
        in_.Fail(node, where, "expected one number");
      v.push_back(in_.Double(node, where));
    } else {
      v = in_.Vector(node, where, size, true);
    }
    for (double x : v) {
      // sigma: >= 0, .inf when undetermined, .nan when the covariance failed; prior_sigma: > 0,
      // .inf for "no prior on this component".
      const bool is_sigma = block == "sigma" || block == "sigma_formal";
      const bool ok = is_sigma ? (std::isnan(x) || x >= 0.0) : (x > 0.0);
      if (!ok) {
        in_.Fail(node, where,
                 is_sigma ? "a sigma must be >= 0 (or .inf / .nan)"
                          : "a prior_sigma must be > 0 (or .inf for no prior)");
      }
    }
    return v;
  }

  SigmaBlock ReadSigma(const YAML::Node& node, const RigConfig& rig, const SensorConfig& s,
                       const std::string& block) {
    const std::string where = Where(s.name) + "." + block;
    SigmaBlock out;
    if (node.IsNull())
      return out;
    const std::vector<ParameterKey> keys = SensorParameterKeys(rig, s);
    std::set<std::string> allowed;
    for (const ParameterKey& k : keys)
      allowed.insert(k.key);
    // SPEC section 7 splits T_B_S into R_B_S and t_B_S for every sensor. A gyroscope's position
    // enters no measurement, so ctcal has no t_B_S parameter for it; a file that gives one (as a
    // SPEC-literal writer may) is read, checked and ignored (docs/conventions.md, "SPEC read
    // twice").
    const bool gyro_translation =
        s.type == SensorType::kGyro && s.name != rig.base_imu && node.IsMap() && node["t_B_S"];
    if (gyro_translation) {
      allowed.insert("t_B_S");
      ReadSigmaValues(node["t_B_S"], where + ".t_B_S", 3, false, block);
      if (block == "prior_sigma")
        Warn(where + ".t_B_S: ignored (a gyroscope's position enters no measurement)");
    }
    in_.CheckKeys(node, where, allowed, block + " of this sensor");
    for (const ParameterKey& k : keys) {
      if (node[k.key]) {
        out.values[k.key] =
            ReadSigmaValues(node[k.key], where + "." + k.key, k.size, k.scalar, block);
      }
    }
    return out;
  }

  SolverSummary ReadSolver(const YAML::Node& node) {
    in_.CheckKeys(node, "solver", {"method", "iterations", "final_cost", "seconds"}, "solver");
    SolverSummary s;
    if (node["method"])
      s.method = in_.String(node["method"], "solver.method");
    if (node["iterations"])
      s.iterations = in_.Int(node["iterations"], "solver.iterations");
    if (node["final_cost"])
      s.final_cost = in_.Double(node["final_cost"], "solver.final_cost");
    if (node["seconds"])
      s.seconds = in_.Double(node["seconds"], "solver.seconds");
    return s;
  }

  void ReadResiduals(const YAML::Node& node, RigConfig* rig) {
    if (node.IsNull())
      return;
    in_.RequireMap(node, "residuals");
    for (const auto& kv : node) {
      const std::string name = in_.String(kv.first, "residuals");
      const std::string where = "residuals." + name;
      if (!rig->Find(name))
        in_.Fail(kv.first, "residuals", "'" + name + "' names no sensor of the rig");
      in_.CheckKeys(kv.second, where,
                    {"count", "rms_px", "rms_gyro", "rms_accel", "rms_whitened",
                     "rms_whitened_gyro", "rms_whitened_accel"},
                    "the residuals of a sensor");
      SensorResiduals r;
      if (kv.second["count"])
        r.count = in_.Int64(kv.second["count"], where + ".count");
      auto opt = [&](const char* key, std::optional<double>* out) {
        if (kv.second[key])
          *out = in_.Double(kv.second[key], where + "." + key);
      };
      opt("rms_px", &r.rms_px);
      opt("rms_gyro", &r.rms_gyro);
      opt("rms_accel", &r.rms_accel);
      opt("rms_whitened", &r.rms_whitened);
      opt("rms_whitened_gyro", &r.rms_whitened_gyro);
      opt("rms_whitened_accel", &r.rms_whitened_accel);
      if (!rig->residuals.emplace(name, r).second)
        in_.Fail(kv.first, "residuals", "'" + name + "' is given twice");
    }
  }

  Observability ReadObservability(const YAML::Node& node) {
    Observability o;
    if (node.IsNull())
      return o;
    in_.CheckKeys(node, "observability",
                  {"unobservable", "weak", "directions", "motion", "predicted_unobservable"},
                  "observability");
    if (node["unobservable"])
      o.unobservable = in_.StringList(node["unobservable"], "observability.unobservable");
    if (node["weak"])
      o.weak = in_.StringList(node["weak"], "observability.weak");
    if (node["predicted_unobservable"]) {
      o.predicted_unobservable =
          in_.StringList(node["predicted_unobservable"], "observability.predicted_unobservable");
    }
    if (node["directions"] && !node["directions"].IsNull()) {
      const std::string where = "observability.directions";
      if (!node["directions"].IsSequence())
        in_.Fail(node["directions"], where, "expected a list");
      for (const auto& d : node["directions"]) {
        in_.CheckKeys(d, where, {"eigenvalue", "parameters"}, "a direction");
        ObservabilityDirection dir;
        if (!d["eigenvalue"])
          in_.Fail(d, where, "missing required key 'eigenvalue'");
        dir.eigenvalue = in_.Double(d["eigenvalue"], where + ".eigenvalue");
        if (d["parameters"] && !d["parameters"].IsNull()) {
          if (!d["parameters"].IsSequence())
            in_.Fail(d["parameters"], where, "parameters: expected a list of {name, loading}");
          for (const auto& p : d["parameters"]) {
            in_.CheckKeys(p, where + ".parameters", {"name", "loading"}, "a loading");
            if (!p["name"] || !p["loading"])
              in_.Fail(p, where + ".parameters", "each entry needs name and loading");
            dir.parameters.push_back({in_.String(p["name"], where + ".parameters.name"),
                                      in_.Double(p["loading"], where + ".parameters.loading")});
          }
        }
        o.directions.push_back(dir);
      }
    }
    if (node["motion"] && !node["motion"].IsNull()) {
      const std::string where = "observability.motion";
      if (!node["motion"].IsSequence())
        in_.Fail(node["motion"], where, "expected a list");
      for (const auto& m : node["motion"]) {
        in_.CheckKeys(m, where, {"primitive", "sensor", "axis", "t0", "t1"}, "a motion primitive");
        if (!m["primitive"])
          in_.Fail(m, where, "missing required key 'primitive'");
        MotionPrimitive p;
        p.primitive = in_.String(m["primitive"], where + ".primitive");
        if (m["sensor"])
          p.sensor = in_.String(m["sensor"], where + ".sensor");
        if (m["axis"])
          p.axis = in_.Vector3(m["axis"], where + ".axis");
        // SPEC section 2: timestamps in files are integer nanoseconds (here on the base clock).
        if (m["t0"])
          p.t0 = SecondsFromNs(in_.Int64(m["t0"], where + ".t0 (integer nanoseconds)"));
        if (m["t1"])
          p.t1 = SecondsFromNs(in_.Int64(m["t1"], where + ".t1 (integer nanoseconds)"));
        o.motion.push_back(p);
      }
    }
    return o;
  }

  YamlIn in_;
  std::vector<std::string>* warnings_;
  bool camera_only_ = false;
};

}  // namespace

RigConfig ParseRig(const YAML::Node& root, const std::string& file,
                   std::vector<std::string>* warnings) {
  RigReader reader(file, warnings);
  return reader.Read(root);
}

RigConfig LoadRig(const std::string& path, std::vector<std::string>* warnings) {
  return ParseRig(YamlIn::LoadFile(path), path, warnings);
}

RigConfig ParseRigString(const std::string& yaml, const std::string& file,
                         std::vector<std::string>* warnings) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(file + ":" + std::to_string(e.mark.line + 1) +
                             ": malformed YAML: " + e.msg);
  }
  return ParseRig(root, file, warnings);
}

}  // namespace ctcal
