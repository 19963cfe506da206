#include "ctcal/calibrator/report_data_builder.h"

#include <SuiteSparse_config.h>
#include <ceres/version.h>

#include <Eigen/Core>
#include <cmath>
#include <functional>
#include <limits>
#include <opencv2/core/version.hpp>
#include <stdexcept>
#include <thread>
#include <vector>

#include "ctcal/sensors/gyro_intrinsics.h"
#include "ctcal/sensors/parallel_for.h"

namespace ctcal {
namespace {

const SensorState& StateOf(const CalibrationState& state, const std::string& name) {
  for (const auto& s : state.sensors()) {
    if (s->name() == name)
      return *s;
  }
  throw std::runtime_error("report data: sensors." + name + " is not in the calibration state");
}

std::int64_t Shifted(std::int64_t t_ns, double shift_s) {
  // Rounding the shift to 1 ns moves a prediction by (1 ns x image velocity), ~1e-6 px.
  return t_ns + static_cast<std::int64_t>(std::llround(shift_s * 1e9));
}

std::vector<report::CornerResidual> Corners(const SensorState& s,
                                            const std::vector<ReportCorner>& corners,
                                            const TrajectoryEvaluator& trajectory) {
  const Eigen::Matrix3d R_B_C = s.R_B_S();
  const Eigen::Vector3d t_B_C = s.p_B_S();
  std::vector<report::CornerResidual> rows;
  rows.reserve(corners.size());
  int frame = -1;
  std::int64_t last_stamp = std::numeric_limits<std::int64_t>::min();
  // The pose at the last corner's time, reused by the next corner at the same time (every corner
  // of a frame without a line delay): the trajectory is a function of the time alone.
  std::int64_t kin_t = 0;
  bool have_kin = false;
  Se3Kinematics<double> kin;
  for (const ReportCorner& c : corners) {
    if (c.t_ns != last_stamp) {
      ++frame;
      last_stamp = c.t_ns;
    }
    const std::int64_t t = Shifted(c.t_ns, s.time_offset + c.uv.y() * s.line_delay);
    if (!have_kin || t != kin_t) {
      kin = trajectory(t, 0);
      kin_t = t;
      have_kin = true;
    }
    const Eigen::Vector3d p_C =
        R_B_C.transpose() * (kin.R_W_B.transpose() * (c.p_W - kin.p_W_B) - t_B_C);
    report::CornerResidual r;
    r.t_ns = c.t_ns;
    r.frame = frame;
    r.corner_id = c.corner_id;
    r.u = c.uv.x();
    r.v = c.uv.y();
    r.outlier = c.outlier;
    Eigen::Vector2d uv;
    if (s.camera->Project(p_C, &uv)) {
      r.du = c.uv.x() - uv.x();
      r.dv = c.uv.y() - uv.y();
      r.whitened = std::hypot(r.du, r.dv) / c.sigma_px;
    } else {
      // Not projectable at the final values: only an outlier can get here (the solve keeps every
      // inlier projectable); NaN keeps it out of every statistic.
      r.du = r.dv = r.whitened = std::numeric_limits<double>::quiet_NaN();
    }
    rows.push_back(r);
  }
  return rows;
}

// The sensor's biases at t_ns (own clock): the caller's evaluator, else the state's splines.
struct Biases {
  const SensorState& s;
  const BiasEvaluator* override_ = nullptr;
  void At(std::int64_t t_ns, Eigen::Vector3d* b_g, Eigen::Vector3d* b_a) const {
    *b_g = Eigen::Vector3d::Zero();
    *b_a = Eigen::Vector3d::Zero();
    if (override_ != nullptr && *override_) {
      (*override_)(t_ns, b_g, b_a);
      return;
    }
    *b_g = s.bias_gyro.Evaluate(t_ns);
    if (s.config.type == SensorType::kImu)
      *b_a = s.bias_accel.Evaluate(t_ns);
  }
};

const BiasEvaluator* BiasOverride(const ReportInputs& in, const std::string& name) {
  const auto it = in.bias.find(name);
  return it == in.bias.end() ? nullptr : &it->second;
}

// The random-walk envelope of the header, one row per `every` samples and at the last one.
void AddBiasRow(const SensorState& s, std::int64_t t_ns, std::int64_t t_first,
                const Eigen::Vector3d& b_g, const Eigen::Vector3d& b_a, report::BiasTrack* track) {
  const double dt = 1e-9 * static_cast<double>(t_ns - t_first);
  const InertialNoise& n = s.config.noise;
  track->gyro.push_back({t_ns, b_g, Eigen::Vector3d::Constant(n.GyroBiasSigma(dt))});
  if (s.config.type == SensorType::kImu)
    track->accel.push_back({t_ns, b_a, Eigen::Vector3d::Constant(n.AccelBiasSigma(dt))});
}

template <class Sample>
bool BiasRowAt(const std::vector<Sample>& samples, std::size_t i, int every) {
  return i % static_cast<std::size_t>(std::max(every, 1)) == 0 || i + 1 == samples.size();
}

void Imu(const CalibrationState& state, const SensorState& s, const std::vector<ImuSample>& samples,
         const TrajectoryEvaluator& trajectory, int bias_every, const Biases& biases,
         report::ReportData* out) {
  const Eigen::Vector3d g_W = state.gravity();
  const Eigen::Matrix3d M = s.R_B_S().transpose();
  const Eigen::Vector3d r = s.p_B_S();
  const double offset = s.is_base ? 0.0 : s.time_offset;
  auto& gyro = out->gyro[s.name()];
  auto& accel = out->accel[s.name()];
  auto& bias = out->bias[s.name()];
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const ImuSample& z = samples[i];
    const Se3Kinematics<double> kin = trajectory(Shifted(z.t_ns, offset), 2);
    const Eigen::Vector3d f_B = kin.SpecificForce(g_W);
    Eigen::Vector3d w_S = kin.w_B, a_S = f_B;
    if (!s.is_base) {
      w_S = M * kin.w_B;
      a_S = M * (f_B + kin.alpha_B.cross(r) + kin.w_B.cross(kin.w_B.cross(r)));
    }
    Eigen::Vector3d b_g, b_a, w_pred, a_pred;
    biases.At(z.t_ns, &b_g, &b_a);
    s.imu->RawFromTrue(w_S, a_S, b_g, b_a, &w_pred, &a_pred);
    gyro.push_back({z.t_ns, z.w_m, w_pred});
    accel.push_back({z.t_ns, z.a_m, a_pred});
    if (BiasRowAt(samples, i, bias_every))
      AddBiasRow(s, z.t_ns, samples.front().t_ns, b_g, b_a, &bias);
  }
}

void Gyro(const SensorState& s, const std::vector<GyroSample>& samples,
          const TrajectoryEvaluator& trajectory, int bias_every, const Biases& biases,
          report::ReportData* out) {
  const Eigen::Matrix3d M = s.R_B_S().transpose();
  auto& gyro = out->gyro[s.name()];
  auto& bias = out->bias[s.name()];
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const GyroSample& z = samples[i];
    const Se3Kinematics<double> kin = trajectory(Shifted(z.t_ns, s.time_offset), 1);
    Eigen::Vector3d b_g, b_a;
    biases.At(z.t_ns, &b_g, &b_a);
    const Eigen::Vector3d w_pred =
        GyroRawFromTrue<double>(s.gyro->model(), s.gyro->Dw(), Eigen::Vector3d(M * kin.w_B), b_g);
    gyro.push_back({z.t_ns, z.w_m, w_pred});
    if (BiasRowAt(samples, i, bias_every))
      AddBiasRow(s, z.t_ns, samples.front().t_ns, b_g, b_a, &bias);
  }
}

}  // namespace

report::Correlation CorrelationFromCovariance(const Eigen::MatrixXd& covariance,
                                              const std::vector<std::string>& names,
                                              const std::vector<bool>& undetermined) {
  if (covariance.rows() != covariance.cols() ||
      static_cast<std::size_t>(covariance.rows()) != names.size())
    throw std::invalid_argument("correlation: a " + std::to_string(covariance.rows()) + "x" +
                                std::to_string(covariance.cols()) + " covariance for " +
                                std::to_string(names.size()) + " names");
  const Eigen::Index n = covariance.rows();
  Eigen::VectorXd inv_sigma(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double v = covariance(i, i);
    const bool bad = (static_cast<std::size_t>(i) < undetermined.size() &&
                      undetermined[static_cast<std::size_t>(i)]) ||
                     !std::isfinite(v) || !(v > 0.0);
    inv_sigma(i) = bad ? std::numeric_limits<double>::quiet_NaN() : 1.0 / std::sqrt(v);
  }
  report::Correlation c;
  c.names = names;
  c.values = inv_sigma.asDiagonal() * covariance * inv_sigma.asDiagonal();
  for (Eigen::Index i = 0; i < n; ++i) {
    if (std::isfinite(inv_sigma(i)))
      c.values(i, i) = 1.0;  // exactly, whatever the rounding
  }
  return c;
}

report::RunInfo LibraryVersions() {
  const auto v3 = [](int a, int b, int c) {
    return std::to_string(a) + "." + std::to_string(b) + "." + std::to_string(c);
  };
  return {{"version.ceres", CERES_VERSION_STRING},
          {"version.eigen", v3(EIGEN_WORLD_VERSION, EIGEN_MAJOR_VERSION, EIGEN_MINOR_VERSION)},
          {"version.suitesparse",
           v3(SUITESPARSE_MAIN_VERSION, SUITESPARSE_SUB_VERSION, SUITESPARSE_SUBSUB_VERSION)},
          {"version.opencv", CV_VERSION}};
}

report::ReportData BuildReportData(const CalibrationState& state, const ReportInputs& inputs,
                                   const TrajectoryEvaluator& trajectory) {
  // Every sensor's rows (and the trajectory's) are one job on the hardware's threads, each into
  // its own part, merged in order: every row is computed alone, so the result does not depend on
  // the schedule. The evaluators only read (the spline's blocks, the keyframes).
  std::vector<std::function<void(report::ReportData*)>> jobs;
  for (const auto& [name, corners] : inputs.corners) {
    const SensorState& s = StateOf(state, name);
    if (!s.camera)
      throw std::runtime_error("report data: sensors." + name + " has corners but no camera model");
    jobs.emplace_back([&, &name = name, &corners = corners, &sensor = s](report::ReportData* part) {
      part->corners[name] = Corners(sensor, corners, trajectory);
    });
  }
  for (const auto& [name, samples] : inputs.imu) {
    const SensorState& s = StateOf(state, name);
    if (!s.imu)
      throw std::runtime_error("report data: sensors." + name + " has IMU samples but is no IMU");
    jobs.emplace_back([&, &name = name, &samples = samples, &sensor = s](report::ReportData* part) {
      Imu(state, sensor, samples, trajectory, inputs.bias_every,
          Biases{sensor, BiasOverride(inputs, name)}, part);
    });
  }
  for (const auto& [name, samples] : inputs.gyro) {
    const SensorState& s = StateOf(state, name);
    if (!s.gyro)
      throw std::runtime_error("report data: sensors." + name +
                               " has gyroscope samples but is no gyroscope");
    jobs.emplace_back([&, &name = name, &samples = samples, &sensor = s](report::ReportData* part) {
      Gyro(sensor, samples, trajectory, inputs.bias_every,
           Biases{sensor, BiasOverride(inputs, name)}, part);
    });
  }
  if (inputs.t1_ns > inputs.t0_ns && inputs.trajectory_rate_hz > 0.0) {
    jobs.emplace_back([&](report::ReportData* part) {
      const auto step = std::max<std::int64_t>(1, std::llround(1e9 / inputs.trajectory_rate_hz));
      for (std::int64_t t = inputs.t0_ns; t <= inputs.t1_ns; t += step) {
        const Se3Kinematics<double> kin = trajectory(t, 0);
        part->trajectory.push_back({t, kin.p_W_B, Eigen::Quaterniond(kin.R_W_B).normalized()});
      }
    });
  }
  std::vector<report::ReportData> parts(jobs.size());
  ParallelFor(static_cast<int>(std::thread::hardware_concurrency()), jobs.size(),
              [&](std::size_t i) { jobs[i](&parts[i]); });
  report::ReportData out;
  for (report::ReportData& part : parts) {
    out.corners.merge(part.corners);
    out.gyro.merge(part.gyro);
    out.accel.merge(part.accel);
    out.bias.merge(part.bias);
    if (!part.trajectory.empty())
      out.trajectory = std::move(part.trajectory);
  }
  return out;
}

}  // namespace ctcal
