#include "ctcal/calibrator/calibration_state.h"

#include <cmath>
#include <stdexcept>

#include "ctcal/spline/so3.h"

namespace ctcal {
namespace {

constexpr double kDeg = M_PI / 180.0;

// Comparison units of marginal_covariance.h: 1 deg, 1 cm, 1 ms, 1 px, 1e-3 (scale, misalignment,
// g-sensitivity, distortion and the unitless projection parameters), 1 us per image row.
double UnitOf(const std::string& key, const std::string& camera_param_name) {
  if (key == "R_B_S" || key == "R_I_a" || key == "R_I_w")
    return kDeg;
  if (key == "t_B_S")
    return 0.01;
  if (key == "time_offset")
    return 1e-3;
  if (key == "line_delay")
    return 1e-6;
  // Pixels: Kalibr's focal length and centre, and mrcal's (camera_model mrcal).
  for (const char* px : {"fu", "fv", "pu", "pv", "fx", "fy", "cx", "cy"})
    if (key == "intrinsics" && camera_param_name == px)
      return 1.0;
  return 1e-3;
}

}  // namespace

Eigen::Vector3d BiasSpline::Evaluate(std::int64_t t_ns) const {
  const int K = NumKnots();
  if (K == 0)
    return Eigen::Vector3d::Zero();
  const double s = static_cast<double>(t_ns - timing.t0_ns) / static_cast<double>(timing.dt_ns);
  if (s <= 0.0)
    return Eigen::Map<const Eigen::Vector3d>(Knot(0));
  if (s >= K - 1)
    return Eigen::Map<const Eigen::Vector3d>(Knot(K - 1));
  const int k = static_cast<int>(std::floor(s));
  const double u = s - k;
  return (1.0 - u) * Eigen::Map<const Eigen::Vector3d>(Knot(k)) +
         u * Eigen::Map<const Eigen::Vector3d>(Knot(k + 1));
}

Eigen::Matrix3d SensorState::R_B_S() const {
  return Eigen::Quaterniond(q_B_S[3], q_B_S[0], q_B_S[1], q_B_S[2]).toRotationMatrix();
}

Eigen::Isometry3d SensorState::T_B_S() const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R_B_S();
  T.translation() = p_B_S();
  return T;
}

CalibrationState::CalibrationState(const RigConfig& rig) : rig_(rig) {
  for (const SensorConfig& s : rig.sensors) {
    auto st = std::make_unique<SensorState>();
    st->config = s;
    st->is_base = s.name == rig.base_imu;
    if (st->is_base)
      base_index_ = sensors_.size();
    const Eigen::Quaterniond q(Eigen::Matrix3d(s.T_B_S.topLeftCorner<3, 3>()));
    st->q_B_S = {q.x(), q.y(), q.z(), q.w()};
    for (int i = 0; i < 3; ++i)
      st->t_B_S[static_cast<std::size_t>(i)] = s.T_B_S(i, 3);
    st->time_offset = st->is_base ? 0.0 : s.time_offset;
    st->line_delay = s.line_delay;
    try {
      if (s.type == SensorType::kImu) {
        StoredImuIntrinsics stored{s.D_w, s.D_a, s.T_g, std::nullopt};
        const std::string rot = RotationKey(s.imu_model);
        if (rot == "R_I_a")
          stored.rotation = s.R_I_a;
        else if (rot == "R_I_w")
          stored.rotation = s.R_I_w;
        st->imu = ImuIntrinsics::FromStored(s.imu_model, s.g_sensitivity, stored);
      } else if (s.type == SensorType::kGyro) {
        st->gyro = GyroIntrinsics::FromStored(s.gyro_model, s.D_w);
      } else {
        st->camera = CameraModel::Create(s.camera_model, s.intrinsics, s.distortion_model,
                                         s.distortion_coeffs, Eigen::Vector2i(s.width, s.height));
      }
    } catch (const std::exception& e) {
      throw std::runtime_error("sensors." + s.name + ": " + e.what());
    }
    sensors_.push_back(std::move(st));
  }
  if (rig.Find(rig.base_imu) == nullptr)
    throw std::runtime_error("base_imu '" + rig.base_imu + "' names no sensor");
  if (rig.gravity_W)
    SetGravity(*rig.gravity_W);
  else
    SetGravity(Eigen::Vector3d(0.0, 0.0, -1.0));
}

SensorState* CalibrationState::Find(const std::string& name) {
  for (auto& s : sensors_) {
    if (s->name() == name)
      return s.get();
  }
  return nullptr;
}

void CalibrationState::SetGravity(const Eigen::Vector3d& g_W) {
  const Eigen::Vector3d g = rig_.gravity_magnitude * g_W.normalized();
  g_W_ = {g.x(), g.y(), g.z()};
}

std::vector<ParameterBlockInfo> CalibrationState::Blocks() {
  std::vector<ParameterBlockInfo> blocks;
  for (auto& sp : sensors_) {
    SensorState& s = *sp;
    const SensorConfig& c = s.config;
    std::vector<std::string> camera_names;
    if (s.camera)
      camera_names = s.camera->ParamNames();
    bool params_done = false;
    for (const ParameterKey& key : SensorParameterKeys(rig_, c)) {
      ParameterBlockInfo b;
      b.sensor = c.name;
      b.key = key.key;
      b.estimated = c.Estimates(key.item);
      std::vector<std::string> keys_of_block = {key.key};
      if (key.key == "Dw") {
        b.values = s.imu ? s.imu->Dw() : s.gyro->Dw();
      } else if (key.key == "Da") {
        b.values = s.imu->Da();
      } else if (key.key == "Tg") {
        b.values = s.imu->Tg();
      } else if (key.key == "R_I_a" || key.key == "R_I_w") {
        b.values = s.imu->q_rotation();
        b.left_rotation = true;
      } else if (key.key == "intrinsics" || key.key == "distortion_coeffs") {
        if (params_done)
          continue;
        params_done = true;
        b.key = "params";
        b.values = s.camera->mutable_params();
        keys_of_block = {"intrinsics"};
        if (s.camera->NumDistortionCoeffs() > 0)
          keys_of_block.push_back("distortion_coeffs");
      } else if (key.key == "line_delay") {
        b.values = &s.line_delay;
      } else if (key.key == "R_B_S") {
        b.values = s.q_B_S.data();
        b.left_rotation = true;
      } else if (key.key == "t_B_S") {
        b.values = s.t_B_S.data();
      } else if (key.key == "time_offset") {
        b.values = &s.time_offset;
      } else {
        throw std::logic_error("CalibrationState: unknown parameter key " + key.key);
      }
      if (b.values == nullptr)
        continue;  // the model has no such block
      bool any_prior = false;
      int camera_index = 0;
      for (const std::string& k : keys_of_block) {
        const int size = k == "intrinsics"          ? s.camera->NumIntrinsics()
                         : k == "distortion_coeffs" ? s.camera->NumDistortionCoeffs()
                                                    : key.size;
        const std::vector<double>* prior = c.prior_sigma.Find(k);
        for (int i = 0; i < size; ++i) {
          b.names.push_back(ParameterName(c.name, k, key.scalar ? -1 : i));
          const std::string pname =
              b.key == "params" ? camera_names[static_cast<std::size_t>(camera_index++)] : "";
          b.unit.push_back(UnitOf(k, pname));
          // A dimension without a prior of its own (e.g. only distortion_coeffs given) gets an
          // information of 1e-18: none in effect, but one prior per block keeps it simple.
          b.prior_sigma.push_back(prior != nullptr ? (*prior)[static_cast<std::size_t>(i)] : 1e9);
          any_prior = any_prior || prior != nullptr;
        }
      }
      if (!any_prior)
        b.prior_sigma.clear();
      b.tangent_size = static_cast<int>(b.names.size());
      b.ambient_size = b.left_rotation ? 4 : b.tangent_size;
      blocks.push_back(std::move(b));
    }
  }
  if (!rig_.IsCameraOnly()) {
    ParameterBlockInfo g;
    g.key = "gravity_W";
    g.values = g_W_.data();
    g.ambient_size = 3;
    g.tangent_size = 2;  // ceres::SphereManifold<3>: the tangent is the direction's angle (rad)
    g.estimated = true;
    g.names = {"gravity_W.direction[0]", "gravity_W.direction[1]"};
    g.unit = {kDeg, kDeg};
    blocks.push_back(std::move(g));
  }
  return blocks;
}

RigConfig CalibrationState::ToRig() const {
  RigConfig out = rig_;
  for (const auto& sp : sensors_) {
    const SensorState& s = *sp;
    SensorConfig* c = out.Find(s.name());
    if (s.imu) {
      const StoredImuIntrinsics st = s.imu->ToStored();
      c->D_w = st.Dw;
      c->D_a = st.Da;
      c->T_g = st.Tg;
      if (st.rotation) {
        if (RotationKey(c->imu_model) == "R_I_a")
          c->R_I_a = *st.rotation;
        else
          c->R_I_w = *st.rotation;
      }
    } else if (s.gyro) {
      c->D_w = s.gyro->ToStored();
    } else if (s.camera) {
      c->intrinsics = s.camera->intrinsics();
      c->distortion_coeffs = s.camera->distortion_coeffs();
      c->line_delay = s.line_delay;
    }
    if (!s.is_base) {
      Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
      T.topLeftCorner<3, 3>() = s.R_B_S();
      T.topRightCorner<3, 1>() = s.p_B_S();
      c->T_B_S = T;
      c->time_offset = s.time_offset;
    }
    c->sigma = SigmaBlock{};
  }
  if (!rig_.IsCameraOnly())
    out.gravity_W = gravity();
  return out;
}

}  // namespace ctcal
