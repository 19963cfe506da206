#include "ctcal/sim/simulator.h"

#include <cmath>
#include <stdexcept>

#include "ctcal/sensors/camera_model.h"
#include "ctcal/sensors/gyro_intrinsics.h"
#include "ctcal/sensors/imu_intrinsics.h"
#include "ctcal/sim/kinematics.h"
#include "ctcal/sim/random.h"
#include "ctcal/sim/scenario.h"
#include "ctcal/targets/board.h"

namespace ctcal::sim {
namespace {

// Purposes of the forked random streams of one sensor (random.h: Fork).
enum Stream : std::uint64_t { kPhase = 1, kInitialBias, kBiasWalk, kWhiteNoise, kCorners };

std::uint64_t StreamId(std::size_t sensor_index, Stream purpose) {
  return 1000 * (sensor_index + 1) + purpose;
}

std::int64_t ToNs(double t) {
  return std::llround(t * 1e9);
}
double ToSeconds(std::int64_t ns) {
  return static_cast<double>(ns) * 1e-9;
}

// The stamps of a sensor with `rate_hz` on its own clock whose base times t_S + offset lie inside
// [t0, t1]; the first stamp sits at a random phase of the sample period.
std::vector<std::int64_t> SensorStamps(double rate_hz, double offset, double phase, double t0,
                                       double t1) {
  const double dt = 1.0 / rate_hz;
  std::vector<std::int64_t> stamps;
  const double k0 = std::ceil((t0 - offset - phase) / dt);
  for (double k = k0;; k += 1.0) {
    const std::int64_t ns = ToNs(phase + k * dt);
    const double t_B = ToSeconds(ns) + offset;
    if (t_B < t0)
      continue;
    if (t_B > t1)
      break;
    stamps.push_back(ns);
  }
  return stamps;
}

Eigen::Matrix3d Rotation(const Eigen::Matrix4d& T) {
  return T.topLeftCorner<3, 3>();
}
Eigen::Vector3d Translation(const Eigen::Matrix4d& T) {
  return T.topRightCorner<3, 1>();
}

void Report(const SimOptions& options, double fraction, const std::string& what) {
  if (options.progress)
    options.progress(fraction, what);
}

InertialData SimulateInertial(const SensorConfig& s, std::size_t index, bool is_base,
                              const Trajectory& traj, const Eigen::Vector3d& g_W,
                              const SimOptions& options, const Random& root) {
  if (!(s.noise.update_rate > 0.0) || !std::isfinite(s.noise.update_rate))
    throw std::invalid_argument("sensors." + s.name + ": noise.update_rate must be positive");
  const double rate = s.noise.update_rate;
  const double dt = 1.0 / rate;
  const bool is_imu = s.type == SensorType::kImu;

  // The base IMU defines the base clock: its samples start exactly at t_begin, offset 0.
  Random phase_rng = root.Fork(StreamId(index, kPhase));
  const double offset = is_base ? 0.0 : s.time_offset;
  const double phase = is_base ? options.t_begin : phase_rng.Uniform(0.0, dt);
  const std::vector<std::int64_t> stamps = SensorStamps(rate, offset, phase, options.t_begin,
                                                        options.t_begin + options.duration + 1e-12);
  if (stamps.size() < 2)
    throw std::invalid_argument("sensors." + s.name +
                                ": fewer than 2 samples inside the simulated interval (is the "
                                "duration shorter than two sample periods?)");

  const Eigen::Matrix3d R_B_S = is_base ? Eigen::Matrix3d::Identity() : Rotation(s.T_B_S);
  const Eigen::Vector3d t_B_S = is_base ? Eigen::Vector3d::Zero() : Translation(s.T_B_S);

  ImuIntrinsics imu_model;
  GyroIntrinsics gyro_model;
  try {
    if (is_imu) {
      StoredImuIntrinsics stored;
      const ImuModelLayout layout = ImuModelLayout::Of(s.imu_model, s.g_sensitivity);
      if (layout.Dw != MatrixForm::kAbsent)
        stored.Dw = s.D_w;
      if (layout.Da != MatrixForm::kAbsent)
        stored.Da = s.D_a;
      if (layout.Tg != MatrixForm::kAbsent)
        stored.Tg = s.T_g;
      if (layout.rotation == ImuRotation::kR_I_w)
        stored.rotation = s.R_I_w;
      if (layout.rotation == ImuRotation::kR_I_a)
        stored.rotation = s.R_I_a;
      imu_model = ImuIntrinsics::FromStored(s.imu_model, s.g_sensitivity, stored);
    } else {
      gyro_model = GyroIntrinsics::FromStored(s.gyro_model, s.D_w);
    }
  } catch (const std::exception& e) {
    throw std::invalid_argument("sensors." + s.name + ": " + e.what());
  }

  Random bias0_rng = root.Fork(StreamId(index, kInitialBias));
  Random walk_rng = root.Fork(StreamId(index, kBiasWalk));
  Random noise_rng = root.Fork(StreamId(index, kWhiteNoise));
  Eigen::Vector3d b_g = bias0_rng.Gaussian3(options.initial_gyro_bias_sigma);
  Eigen::Vector3d b_a =
      is_imu ? bias0_rng.Gaussian3(options.initial_accel_bias_sigma) : Eigen::Vector3d::Zero();
  const double sigma_w = options.white_noise ? s.noise.GyroSampleSigma() : 0.0;
  const double sigma_a = options.white_noise && is_imu ? s.noise.AccelSampleSigma() : 0.0;
  const double walk_g = options.bias_random_walk ? s.noise.GyroBiasSigma(dt) : 0.0;
  const double walk_a = options.bias_random_walk && is_imu ? s.noise.AccelBiasSigma(dt) : 0.0;

  InertialData out;
  out.sensor = s.name;
  out.has_accel = is_imu;
  out.samples.reserve(stamps.size());
  out.biases.reserve(stamps.size());
  for (const std::int64_t ns : stamps) {
    const double t_B = ToSeconds(ns) + offset;
    const InertialTruth ideal = IdealInertial(traj.Evaluate(t_B), g_W, R_B_S, t_B_S);
    InertialSample sample;
    sample.t_ns = ns;
    if (is_imu) {
      imu_model.RawFromTrue(ideal.w_S, ideal.a_S, b_g, b_a, &sample.w_m, &sample.a_m);
      sample.w_m += noise_rng.Gaussian3(sigma_w);
      sample.a_m += noise_rng.Gaussian3(sigma_a);
    } else {
      sample.w_m = gyro_model.RawFromTrue(ideal.w_S, b_g) + noise_rng.Gaussian3(sigma_w);
    }
    out.samples.push_back(sample);
    out.biases.push_back(BiasState{ns, b_g, b_a});
    // Euler-Maruyama step of the Wiener process to the next sample.
    b_g += walk_rng.Gaussian3(walk_g);
    if (is_imu)
      b_a += walk_rng.Gaussian3(walk_a);
  }
  return out;
}

CameraData SimulateCamera(const SensorConfig& s, std::size_t index, bool is_base,
                          const Trajectory& traj, const Board& board, const SimOptions& options,
                          const Random& root) {
  CameraModel camera = [&] {
    try {
      return CameraModel::Create(s.camera_model, s.intrinsics, s.distortion_model,
                                 s.distortion_coeffs, Eigen::Vector2i(s.width, s.height));
    } catch (const std::exception& e) {
      throw std::invalid_argument("sensors." + s.name + ": " + e.what());
    }
  }();
  if (!(s.line_delay >= 0.0) || !(s.pixel_sigma > 0.0))
    throw std::invalid_argument("sensors." + s.name +
                                ": line_delay must be >= 0 and pixel_sigma > 0");
  const double period = 1.0 / options.camera_rate_hz;
  Random phase_rng = root.Fork(StreamId(index, kPhase));
  Random rng = root.Fork(StreamId(index, kCorners));
  const double offset = is_base ? 0.0 : s.time_offset;
  const double phase = is_base ? options.t_begin : phase_rng.Uniform(0.0, period);
  // A rolling-shutter image is read over height * line_delay: keep whole images inside.
  const double readout = s.line_delay * s.height;
  const std::vector<std::int64_t> stamps =
      SensorStamps(options.camera_rate_hz, offset, phase, options.t_begin,
                   options.t_begin + options.duration - readout + 1e-12);
  if (stamps.empty())
    throw std::invalid_argument("sensors." + s.name +
                                ": no image inside the simulated interval (is the rolling-shutter "
                                "readout height * line_delay longer than the duration?)");

  const Eigen::Matrix3d R_B_C = is_base ? Eigen::Matrix3d::Identity() : Rotation(s.T_B_S);
  const Eigen::Vector3d t_B_C = is_base ? Eigen::Vector3d::Zero() : Translation(s.T_B_S);
  const double min_cos_view = std::cos(options.max_view_angle_deg * M_PI / 180.0);
  const double sigma = options.white_noise ? s.pixel_sigma : 0.0;

  // The corner as seen at base time t: false when it is not detectable.
  const auto see = [&](const Eigen::Vector3d& p_W, double t, Eigen::Vector2d* uv) {
    const Pose T_W_C = SensorPoseInWorld(traj.Evaluate(t), R_B_C, t_B_C);
    const Eigen::Vector3d to_camera = T_W_C.t - p_W;
    // The printed side faces +z_W; oblique views are not detected.
    if (!(to_camera.z() > min_cos_view * to_camera.norm()))
      return false;
    const Eigen::Vector3d p_C = T_W_C.R.transpose() * (p_W - T_W_C.t);
    if (!(p_C.z() > 1e-3))
      return false;
    return camera.Project(p_C, uv) && camera.IsInImage(*uv, options.image_border_px);
  };

  CameraData out;
  out.sensor = s.name;
  out.frames_ns = stamps;
  for (const std::int64_t ns : stamps) {
    const double t_image = ToSeconds(ns) + offset;
    for (int id = 0; id < board.NumCorners(); ++id) {
      const Eigen::Vector3d& p_W = board.Corner(id);
      Eigen::Vector2d uv;
      if (!see(p_W, t_image, &uv))
        continue;
      if (s.line_delay > 0.0) {
        // Fixed point of the row time; converges to 1e-9 px in a few steps.
        bool ok = true;
        for (int it = 0; it < 50; ++it) {
          Eigen::Vector2d next;
          if (!see(p_W, t_image + uv.y() * s.line_delay, &next)) {
            ok = false;
            break;
          }
          const double change = std::abs(next.y() - uv.y());
          uv = next;
          if (change < 1e-9)
            break;
        }
        if (!ok)
          continue;
      }
      // Draw both numbers for every visible corner so the noise sequence does not depend on
      // the dropout probability.
      const bool dropped = rng.Bernoulli(options.corner_dropout);
      const double nu = rng.Gaussian(sigma);
      const double nv = rng.Gaussian(sigma);
      if (dropped)
        continue;
      SimulatedCorner obs;
      obs.t_ns = ns;
      obs.corner_id = id;
      obs.uv_true = uv;
      obs.uv = uv + Eigen::Vector2d(nu, nv);
      obs.sigma = s.pixel_sigma;
      out.corners.push_back(obs);
    }
  }
  return out;
}

}  // namespace

KinematicState RotatedTrajectory::Evaluate(double t) const {
  KinematicState x = base_.Evaluate(t);
  x.q_W_B = (x.q_W_B * Eigen::Quaterniond(R_T_B_)).normalized();
  x.w_B = R_T_B_.transpose() * x.w_B;
  x.alpha_B = R_T_B_.transpose() * x.alpha_B;
  return x;
}

Eigen::Matrix3d ScenarioMount(const RigConfig& rig) {
  const SensorConfig* reference = nullptr;
  for (const SensorConfig& s : rig.sensors) {
    if (s.type == SensorType::kCamera) {
      reference = &s;
      break;
    }
  }
  if (reference == nullptr)
    return Eigen::Matrix3d::Identity();
  const bool is_base = reference->name == rig.base_imu;
  const Eigen::Vector3d axis_B =
      (is_base ? Eigen::Matrix3d::Identity() : Rotation(reference->T_B_S)) *
      Eigen::Vector3d::UnitZ();
  // The 24 proper rotations with entries in {-1, 0, 1}: choose the one taking the optical axis
  // closest to -z_T, preferring the identity on ties (first in the enumeration).
  Eigen::Matrix3d best = Eigen::Matrix3d::Identity();
  double best_score = -(best * axis_B).z();
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (const auto& perm : perms) {
    for (int signs = 0; signs < 8; ++signs) {
      Eigen::Matrix3d R = Eigen::Matrix3d::Zero();
      for (int row = 0; row < 3; ++row)
        R(row, perm[row]) = (signs >> row) & 1 ? -1.0 : 1.0;
      if (R.determinant() < 0.0)
        continue;
      const double score = -(R * axis_B).z();
      if (score > best_score + 1e-12) {
        best = R;
        best_score = score;
      }
    }
  }
  return best;
}

SimulatedDataset Simulate(const RigConfig& rig, const Trajectory& traj, const SimOptions& options) {
  if (!(options.duration > 0.0) || !std::isfinite(options.duration))
    throw std::invalid_argument("duration must be a positive number of seconds");
  if (!(options.camera_rate_hz > 0.0))
    throw std::invalid_argument("camera rate must be positive");
  if (rig.Find(rig.base_imu) == nullptr)
    throw std::invalid_argument("base_imu '" + rig.base_imu + "' names no sensor of the rig");

  const Board board(rig.target);
  const Random root(options.seed);
  const Eigen::Vector3d g_W = rig.gravity_magnitude * GravityDirectionW();

  SimulatedDataset data;
  data.truth = rig;
  // A camera-only rig has no gravity (SPEC section 7).
  if (rig.IsCameraOnly())
    data.truth.gravity_W.reset();
  else
    data.truth.gravity_W = g_W;

  const std::size_t n = rig.sensors.size();
  for (std::size_t i = 0; i < n; ++i) {
    const SensorConfig& s = rig.sensors[i];
    const bool is_base = s.name == rig.base_imu;
    Report(options, static_cast<double>(i) / n, s.name);
    if (s.IsInertial())
      data.inertial.push_back(SimulateInertial(s, i, is_base, traj, g_W, options, root));
    else
      data.cameras.push_back(SimulateCamera(s, i, is_base, traj, board, options, root));
  }

  // Ground truth at the base sensor's samples.
  const SensorConfig& base = rig.Base();
  if (base.IsInertial()) {
    for (const InertialData& d : data.inertial) {
      if (d.sensor != base.name)
        continue;
      for (std::size_t k = 0; k < d.samples.size(); ++k) {
        const std::int64_t ns = d.samples[k].t_ns;
        data.groundtruth.push_back(
            {ns, traj.Evaluate(ToSeconds(ns)), d.biases[k].b_g, d.biases[k].b_a});
      }
    }
  } else {
    for (const CameraData& d : data.cameras) {
      if (d.sensor != base.name)
        continue;
      for (const std::int64_t ns : d.frames_ns) {
        data.groundtruth.push_back(
            {ns, traj.Evaluate(ToSeconds(ns)), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()});
      }
    }
  }
  Report(options, 1.0, "done");
  return data;
}

}  // namespace ctcal::sim
