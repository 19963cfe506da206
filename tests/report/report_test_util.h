// A synthetic calibration folder OUT with known content for the report tests: the default truth
// rig as result (with residuals, sigma, observability), corner residuals for cam0, inertial
// samples and biases for imu0, a trajectory, a correlation matrix and run info. Other sensors
// get no data so that their sections must be omitted with a note.
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <stdexcept>
#include <string>

#include "ctcal/report/report_data.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal::report::test {

inline std::string MakeTempDir(const std::string& stem) {
  namespace fs = std::filesystem;
  std::string tmpl = (fs::temp_directory_path() / (stem + "_XXXXXX")).string();
  if (!mkdtemp(tmpl.data()))
    throw std::runtime_error("mkdtemp failed");
  return tmpl;
}

// Standard deviation of the grey values of an image: 0 for a blank page.
inline double PixelStdDev(const cv::Mat& img) {
  cv::Mat grey;
  img.convertTo(grey, CV_64F);
  cv::Scalar mean, stddev;
  cv::meanStdDev(grey.reshape(1), mean, stddev);
  return stddev[0];
}

struct SyntheticOut {
  std::string dir;
  RigConfig rig;
  int frames = 40;
  int outliers = 0;
  int corners = 0;
};

inline SyntheticOut MakeSyntheticOut(const std::string& dir) {
  SyntheticOut s;
  s.dir = dir;
  std::vector<std::string> ignored;
  s.rig = LoadRig(std::string(CTCAL_SOURCE_DIR) + "/configs/default_rig_truth.yaml", &ignored);
  RigConfig& rig = s.rig;
  rig.gravity_W = Eigen::Vector3d(0, 0, -9.81);
  rig.sigma_gravity_W = Eigen::Vector3d(1e-3, 1e-3, 2e-3);
  rig.solver = SolverSummary{"spline", 12, 3456.5, 4.2};
  SensorConfig* cam = rig.Find("cam0");
  cam->sigma.values["intrinsics"] = {0.3, 0.3, 0.2, 0.2};
  for (const auto& sensor : rig.sensors) {
    SensorResiduals r;
    r.count = 1000;
    r.rms_whitened = sensor.name == "cam0" ? 1.05 : sensor.name == "imu0" ? 1.6 : 0.97;
    if (sensor.IsInertial()) {
      r.rms_gyro = 1e-3;
      if (sensor.type == SensorType::kImu)
        r.rms_accel = 2e-2;
    } else {
      r.rms_px = 0.31;
    }
    rig.residuals[sensor.name] = r;
  }
  Observability obs;
  obs.weak = {"cam0.time_offset"};
  obs.predicted_unobservable = {"imu0.Tg[0]"};
  MotionPrimitive m;
  m.primitive = "constant_velocity";
  m.sensor = "imu0";
  m.axis = Eigen::Vector3d::UnitZ();
  m.t0 = 1.0;
  m.t1 = 1.8;
  obs.motion.push_back(m);
  rig.observability = obs;
  std::filesystem::create_directories(dir);
  SaveRig(rig, dir + "/result.yaml");

  std::mt19937 rng(7);
  std::normal_distribution<double> n01(0.0, 1.0);
  const std::int64_t t0 = 1'000'000'000'000;
  // cam0: a 7x5 grid of corners wandering over the image, 0.3 px noise, a few outliers.
  std::vector<CornerResidual> corners;
  for (int f = 0; f < s.frames; ++f) {
    const double ox = 40 + 600.0 * f / s.frames, oy = 30 + 200 * std::sin(0.3 * f) + 150;
    for (int k = 0; k < 35; ++k) {
      CornerResidual c;
      c.t_ns = t0 + f * 100'000'000LL;
      c.frame = f;
      c.corner_id = k;
      c.u = std::fmod(ox + 20 * (k % 7) + 3 * f, 752.0);
      c.v = std::fmod(oy + 20 * (k / 7) + 200 * (f % 3), 480.0);
      c.du = 0.3 * n01(rng);
      c.dv = 0.3 * n01(rng);
      c.outlier = (f * 35 + k) % 97 == 0;
      if (c.outlier) {
        c.du *= 20;
        ++s.outliers;
      }
      c.whitened = std::hypot(c.du, c.dv) / 0.3;
      corners.push_back(c);
    }
  }
  s.corners = static_cast<int>(corners.size());
  WriteCornerResiduals(dir, "cam0", corners);

  // imu0: 4 s at 250 Hz; measured = predicted + white noise of the sample sigma.
  const SensorConfig& imu = *rig.Find("imu0");
  std::vector<InertialSample> gyro, accel;
  for (int i = 0; i < 1000; ++i) {
    const double t = i / 250.0;
    InertialSample g, a;
    g.t_ns = a.t_ns = t0 + static_cast<std::int64_t>(std::llround(t * 1e9)) + (i == 500 ? 2e6 : 0);
    g.pred = Eigen::Vector3d(std::sin(2 * t), 0.5 * std::cos(3 * t), 0.2 * std::sin(t));
    a.pred = Eigen::Vector3d(std::cos(1.5 * t), std::sin(2.5 * t), 9.81 + 0.3 * std::sin(t));
    for (int k = 0; k < 3; ++k) {
      g.meas[k] = g.pred[k] + imu.noise.GyroSampleSigma() * n01(rng);
      a.meas[k] = a.pred[k] + imu.noise.AccelSampleSigma() * n01(rng);
    }
    gyro.push_back(g);
    accel.push_back(a);
  }
  WriteGyroSamples(dir, "imu0", gyro);
  WriteAccelSamples(dir, "imu0", accel);
  BiasTrack bias;
  for (int i = 0; i <= 40; ++i) {
    BiasSample b;
    b.t_ns = t0 + i * 100'000'000LL;
    b.b = Eigen::Vector3d(1e-3 + 1e-4 * std::sin(0.2 * i), -2e-3, 5e-4 * std::cos(0.1 * i));
    b.sigma = Eigen::Vector3d::Constant(2e-4);
    bias.gyro.push_back(b);
    b.b *= 10;
    b.sigma *= 10;
    bias.accel.push_back(b);
  }
  WriteBiasTrack(dir, "imu0", bias);

  std::vector<PoseSample> traj;
  for (int i = 0; i < 400; ++i) {
    const double t = i / 100.0;
    PoseSample p;
    p.t_ns = t0 + i * 10'000'000LL;
    p.p_W_B = Eigen::Vector3d(0.5 * std::cos(t), 0.4 * std::sin(t), 1.0 + 0.1 * std::sin(3 * t));
    p.q_W_B = Eigen::Quaterniond(Eigen::AngleAxisd(t, Eigen::Vector3d::UnitZ()) *
                                 Eigen::AngleAxisd(0.3 * std::sin(t), Eigen::Vector3d::UnitX()));
    traj.push_back(p);
  }
  WriteTrajectory(dir, traj);

  Correlation corr;
  corr.names = {"cam0.intrinsics[0]", "cam0.intrinsics[1]", "cam0.intrinsics[2]",
                "cam0.intrinsics[3]", "cam0.time_offset",   "imu0.Dw[0]",
                "imu0.Dw[1]",         "gravity_W[0]"};
  Eigen::MatrixXd a = Eigen::MatrixXd::Random(8, 8);
  Eigen::MatrixXd cov = a * a.transpose() + 0.5 * Eigen::MatrixXd::Identity(8, 8);
  const Eigen::VectorXd d = cov.diagonal().cwiseSqrt().cwiseInverse();
  corr.values = d.asDiagonal() * cov * d.asDiagonal();
  WriteCorrelation(dir, corr);

  WriteRunInfo(dir, {{"ctcal version", "0.1.0"},
                     {"command", "ctcal calibrate --rig rig.yaml --data DATA --out OUT"},
                     {"Ceres", "2.1.0"}});
  return s;
}

}  // namespace ctcal::report::test
