// basalt's calibration.json and OpenVINS's kalibr_*_chain.yaml (ecosystem_exports.h): each file is
// read back here by a small reader written from the program's own definitions (basalt-headers'
// camera models and CalibAccelBias / CalibGyroBias, OpenVINS's IMU model in its propagation
// docs), not from ctcal's, and must reproduce our model's numbers: the raw IMU readings of a
// motion, the pixels of points, the extrinsics. A transposed rotation, an inverted T, a frame
// mix-up or a parameter in the wrong slot shows up as a wrong reading or pixel.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <string>

#include "ctcal/sensors/camera_model.h"
#include "ctcal/sensors/ecosystem_exports.h"
#include "ctcal/sensors/imu_intrinsics.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal {
namespace {

Eigen::Matrix3d SmallRotation(std::mt19937& rng, double sigma) {
  std::normal_distribution<double> n(0.0, sigma);
  return Eigen::AngleAxisd(Eigen::Vector3d(n(rng), n(rng), n(rng)).norm(),
                           Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized())
      .toRotationMatrix();
}

Eigen::Matrix4d Pose(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() =
      Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized().toRotationMatrix();
  T.topRightCorner<3, 1>() = 0.1 * Eigen::Vector3d(n(rng), n(rng), n(rng));
  return T;
}

// A D matrix of the model's form: identity plus a few per cent, upper-triangular or full.
Eigen::Matrix3d RandomD(std::mt19937& rng, bool full) {
  std::normal_distribution<double> n(0.0, 0.02);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = full ? 0 : r; c < 3; ++c)
      D(r, c) += n(rng);
  return D;
}

// The base IMU of `rig` given `model` with random intrinsics (full T_g unless `no_tg`).
void SetRandomImu(SensorConfig& imu, ImuModel model, std::mt19937& rng, bool no_tg) {
  const GSensitivity g = no_tg ? GSensitivity::kNone : GSensitivity::kFull;
  ImuIntrinsics in(model, g);
  if (model != ImuModel::kNone) {
    in.SetD_w(RandomD(rng, model == ImuModel::kImu3));
    in.SetD_a(RandomD(rng, model == ImuModel::kImu4));
    if (!no_tg)
      in.SetT_g(Eigen::Matrix3d::Random() * 1e-3);
    if (model == ImuModel::kImu1 || model == ImuModel::kImu2)
      in.SetRotation(SmallRotation(rng, 0.01));
  }
  const StoredImuIntrinsics s = in.ToStored();
  imu.imu_model = model;
  imu.g_sensitivity = g;
  imu.D_w = s.Dw;
  imu.D_a = s.Da;
  imu.T_g = s.Tg;
  imu.R_I_w = model == ImuModel::kImu1 ? *s.rotation : Eigen::Matrix3d::Identity();
  imu.R_I_a = model == ImuModel::kImu2 ? *s.rotation : Eigen::Matrix3d::Identity();
}

ImuIntrinsics Intrinsics(const SensorConfig& imu) {
  StoredImuIntrinsics s;
  s.Dw = imu.D_w;
  s.Da = imu.D_a;
  s.Tg = imu.T_g;
  if (imu.imu_model == ImuModel::kImu1)
    s.rotation = imu.R_I_w;
  if (imu.imu_model == ImuModel::kImu2)
    s.rotation = imu.R_I_a;
  return ImuIntrinsics::FromStored(imu.imu_model, imu.g_sensitivity, s);
}

SensorConfig Camera(const std::string& name, const std::string& model, std::vector<double> k,
                    const std::string& distortion, std::vector<double> d, std::mt19937& rng) {
  SensorConfig c;
  c.name = name;
  c.type = SensorType::kCamera;
  c.camera_model = model;
  c.intrinsics = std::move(k);
  c.distortion_model = distortion;
  c.distortion_coeffs = std::move(d);
  c.width = 752;
  c.height = 480;
  c.T_B_S = Pose(rng);
  c.time_offset = 0.0042;
  c.estimate = {EstimateItem::kExtrinsics, EstimateItem::kTimeOffset};
  return c;
}

// An imu (the base) and one camera of each model basalt has.
RigConfig BasaltRig(ImuModel model, std::mt19937& rng, bool no_tg) {
  RigConfig rig;
  rig.base_imu = "imu0";
  SensorConfig imu;
  imu.name = "imu0";
  imu.type = SensorType::kImu;
  imu.noise = {1.6e-4, 2e-6, 2e-3, 3e-5, 200.0};
  SetRandomImu(imu, model, rng, no_tg);
  rig.sensors.push_back(imu);
  rig.sensors.push_back(Camera("cam0", "pinhole", {458.6, 457.3, 367.2, 248.4}, "radtan",
                               {-0.283, 0.074, 1.9e-4, -1.8e-4}, rng));
  rig.sensors.push_back(Camera("cam1", "pinhole", {190.9, 190.8, 254.9, 256.8}, "equidistant",
                               {2.9e-3, 7.5e-3, -1.1e-2, 4.8e-3}, rng));
  rig.sensors.push_back(
      Camera("cam2", "ds", {-0.2, 0.58, 156.0, 155.9, 254.9, 256.8}, "none", {}, rng));
  rig.sensors.push_back(
      Camera("cam3", "eucm", {0.6, 1.1, 300.0, 301.0, 376.0, 240.0}, "none", {}, rng));
  rig.sensors.push_back(Camera("cam4", "omni", {0.9, 700.0, 701.0, 376.0, 240.0}, "none", {}, rng));
  rig.sensors.push_back(Camera("cam5", "pinhole", {458.6, 457.3, 367.2, 248.4}, "none", {}, rng));
  return rig;
}

// basalt-headers' projections of a camera-frame point (camera_type and its intrinsics).
Eigen::Vector2d BasaltProject(const YAML::Node& cam, const Eigen::Vector3d& p) {
  const std::string type = cam["camera_type"].as<std::string>();
  const YAML::Node k = cam["intrinsics"];
  auto v = [&](const char* key) { return k[key].as<double>(); };
  const double x = p.x(), y = p.y(), z = p.z();
  double mx = 0.0, my = 0.0;  // the point on the normalised plane basalt scales by fx, fy
  if (type == "pinhole") {
    mx = x / z;
    my = y / z;
  } else if (type == "pinhole-radtan8") {
    const double xp = x / z, yp = y / z, r2 = xp * xp + yp * yp;
    const double radial = (1 + v("k1") * r2 + v("k2") * r2 * r2 + v("k3") * r2 * r2 * r2) /
                          (1 + v("k4") * r2 + v("k5") * r2 * r2 + v("k6") * r2 * r2 * r2);
    mx = xp * radial + 2 * v("p1") * xp * yp + v("p2") * (r2 + 2 * xp * xp);
    my = yp * radial + 2 * v("p2") * xp * yp + v("p1") * (r2 + 2 * yp * yp);
  } else if (type == "kb4") {
    const double r = std::hypot(x, y), th = std::atan2(r, z), t2 = th * th;
    const double d = th * (1 + t2 * (v("k1") + t2 * (v("k2") + t2 * (v("k3") + t2 * v("k4")))));
    mx = d * x / r;
    my = d * y / r;
  } else if (type == "ucm") {
    const double den = v("alpha") * p.norm() + (1 - v("alpha")) * z;
    mx = x / den;
    my = y / den;
  } else if (type == "ds") {
    const double z2 = v("xi") * p.norm() + z;
    const double den = v("alpha") * std::sqrt(x * x + y * y + z2 * z2) + (1 - v("alpha")) * z2;
    mx = x / den;
    my = y / den;
  } else if (type == "eucm") {
    const double d = std::sqrt(v("beta") * (x * x + y * y) + z * z);
    const double den = v("alpha") * d + (1 - v("alpha")) * z;
    mx = x / den;
    my = y / den;
  } else {
    ADD_FAILURE() << "unknown camera_type " << type;
  }
  return {v("fx") * mx + v("cx"), v("fy") * my + v("cy")};
}

Eigen::Matrix3d Rows3(const YAML::Node& rows) {
  Eigen::Matrix3d M;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      M(r, c) = rows[r][c].as<double>();
  return M;
}

Eigen::Matrix4d Rows4(const YAML::Node& rows) {
  Eigen::Matrix4d M;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      M(r, c) = rows[r][c].as<double>();
  return M;
}

// The cameras see the same points through basalt's file as through our models, and basalt's
// calibrated IMU readings are the true motion in its frame i, the same frame T_imu_cam uses.
void ExpectBasaltFileHoldsRig(const RigConfig& rig) {
  std::string why;
  std::vector<std::string> notes;
  const std::optional<std::string> text = EmitBasaltCalibration(rig, &why, &notes);
  ASSERT_TRUE(text) << why;
  const YAML::Node calib = YAML::Load(*text)["value0"];  // JSON is YAML
  ASSERT_TRUE(calib) << *text;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix3d R_i_B = Eigen::Matrix3d::Zero();
  for (std::size_t n = 1; n < rig.sensors.size(); ++n) {
    const SensorConfig& c = rig.sensors[n];
    const YAML::Node T = calib["T_imu_cam"][n - 1];
    const Eigen::Quaterniond q(T["qw"].as<double>(), T["qx"].as<double>(), T["qy"].as<double>(),
                               T["qz"].as<double>());
    EXPECT_NEAR(q.norm(), 1.0, 1e-12);
    const Eigen::Matrix3d R_i_C = q.toRotationMatrix();
    const Eigen::Vector3d p_i_C(T["px"].as<double>(), T["py"].as<double>(), T["pz"].as<double>());
    // Every camera implies the same R_i_B, and its position rotates with it.
    const Eigen::Matrix3d R = R_i_C * c.T_B_S.topLeftCorner<3, 3>().transpose();
    if (n == 1)
      R_i_B = R;
    EXPECT_LT((R - R_i_B).norm(), 1e-12) << c.name;
    EXPECT_LT((p_i_C - R_i_B * c.T_B_S.topRightCorner<3, 1>()).norm(), 1e-12) << c.name;
    EXPECT_EQ(calib["resolution"][n - 1][0].as<int>(), c.width);
    const CameraModel ours = CameraModel::Create(c.camera_model, c.intrinsics, c.distortion_model,
                                                 c.distortion_coeffs, {c.width, c.height});
    int compared = 0;
    for (int k = 0; k < 200; ++k) {
      const Eigen::Vector3d p(u(rng), u(rng), 1.2 + u(rng));
      Eigen::Vector2d uv;
      if (!ours.Project(p, &uv) || !ours.IsInImage(uv, 0.0))
        continue;
      const Eigen::Vector2d theirs = BasaltProject(calib["intrinsics"][n - 1], p);
      EXPECT_LT((theirs - uv).norm(), 1e-9) << c.name << " " << p.transpose();
      ++compared;
    }
    EXPECT_GT(compared, 20) << c.name;
  }
  // calib_accel_bias: bias, then (I + S_a)'s lower triangle column by column; calib_gyro_bias:
  // bias, then I + S_g column-major (basalt-headers' getBiasAndScale).
  const std::vector<double> a = calib["calib_accel_bias"].as<std::vector<double>>();
  const std::vector<double> g = calib["calib_gyro_bias"].as<std::vector<double>>();
  ASSERT_EQ(a.size(), 9u);
  ASSERT_EQ(g.size(), 12u);
  Eigen::Matrix3d A = Eigen::Matrix3d::Identity(), G = Eigen::Matrix3d::Identity();
  A(0, 0) += a[3];
  A(1, 0) += a[4];
  A(2, 0) += a[5];
  A(1, 1) += a[6];
  A(2, 1) += a[7];
  A(2, 2) += a[8];
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r)
      G(r, c) += g[3 + 3 * c + r];
  const ImuIntrinsics in = Intrinsics(rig.Base());
  for (int k = 0; k < 10; ++k) {
    const Eigen::Vector3d w_I(u(rng), u(rng), u(rng)), a_I(u(rng), u(rng), 9.81 + u(rng));
    Eigen::Vector3d w_m, a_m;
    in.RawFromTrue(w_I, a_I, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), &w_m, &a_m);
    EXPECT_LT((A * a_m - R_i_B * a_I).norm(), 1e-10);
    EXPECT_LT((G * w_m - R_i_B * w_I).norm(), 1e-12);
  }
  const SensorConfig& imu = rig.Base();
  EXPECT_EQ(calib["gyro_noise_std"][0].as<double>(), imu.noise.gyroscope_noise_density);
  EXPECT_EQ(calib["accel_bias_std"][2].as<double>(), imu.noise.accelerometer_random_walk);
  EXPECT_EQ(calib["imu_update_rate"].as<double>(), imu.noise.update_rate);
  EXPECT_EQ(calib["cam_time_offset_ns"].as<long long>(),
            std::llround(rig.sensors[1].time_offset * 1e9));
  EXPECT_EQ(calib["vignette"].size(), 0u);
}

TEST(EcosystemExports, BasaltCalibrationHoldsEveryModelInBasaltsFrame) {
  std::mt19937 rng(1);
  for (ImuModel m :
       {ImuModel::kNone, ImuModel::kImu1, ImuModel::kImu2, ImuModel::kImu3, ImuModel::kImu4}) {
    SCOPED_TRACE(ToString(m));
    const RigConfig rig = BasaltRig(m, rng, /*no_tg=*/true);
    ValidateRig(rig, "test rig");
    ExpectBasaltFileHoldsRig(rig);
  }
}

TEST(EcosystemExports, BasaltNotesWhatItCannotHold) {
  std::mt19937 rng(2);
  RigConfig rig = BasaltRig(ImuModel::kImu2, rng, /*no_tg=*/false);
  rig.sensors[2].time_offset = 0.001;
  std::string why;
  std::vector<std::string> notes;
  ASSERT_TRUE(EmitBasaltCalibration(rig, &why, &notes));
  ASSERT_EQ(notes.size(), 2u);
  EXPECT_NE(notes[0].find("T_g is left out"), std::string::npos) << notes[0];
  EXPECT_NE(notes[1].find("cam1's differs by -3.200 ms"), std::string::npos) << notes[1];
  rig.sensors[5].distortion_model = "radtan";  // omni-radtan: basalt has none
  rig.sensors[5].distortion_coeffs = {0.01, 0.0, 0.0, 0.0};
  EXPECT_FALSE(EmitBasaltCalibration(rig, &why));
  EXPECT_EQ(why, "basalt has no omni-radtan camera (cam4)");
}

// OpenCV's "%YAML:1.0" directive line is not YAML 1.2's; OpenVINS's parser needs it.
YAML::Node LoadOpenCvYaml(const std::string& text) {
  EXPECT_EQ(text.rfind("%YAML:1.0\n", 0), 0u);
  return YAML::Load(text.substr(text.find('\n') + 1));
}

// OpenVINS's model (its propagation docs): w_m = Tw R_IMUtoGYRO w_I + Tg a_I + b_g, a_m = Ta
// R_IMUtoACC a_I + b_a, D = T^-1 of which the rpng model keeps the upper triangle.
TEST(EcosystemExports, OpenVinsChainsHoldEveryModelExactly) {
  std::mt19937 rng(5);
  for (ImuModel m :
       {ImuModel::kNone, ImuModel::kImu1, ImuModel::kImu2, ImuModel::kImu3, ImuModel::kImu4}) {
    SCOPED_TRACE(ToString(m));
    RigConfig rig = BasaltRig(m, rng, /*no_tg=*/m == ImuModel::kNone);
    rig.sensors.resize(3);  // OpenVINS's cameras: pinhole radtan and equidistant
    rig.sensors[0].rostopic = "/imu0";
    std::string why;
    const std::optional<std::string> imu_text = EmitOpenVinsImuChain(rig, &why);
    ASSERT_TRUE(imu_text) << why;
    const YAML::Node imu = LoadOpenCvYaml(*imu_text)["imu0"];
    EXPECT_EQ(imu["model"].as<std::string>(), m == ImuModel::kNone ? "calibrated" : "rpng");
    EXPECT_EQ(imu["rostopic"].as<std::string>(), "/imu0");
    EXPECT_EQ(imu["gyroscope_random_walk"].as<double>(), 2e-6);
    const Eigen::Matrix3d Tw = Rows3(imu["Tw"]), Ta = Rows3(imu["Ta"]), Tg = Rows3(imu["Tg"]);
    const Eigen::Matrix3d R_w = Rows3(imu["R_IMUtoGYRO"]), R_a = Rows3(imu["R_IMUtoACC"]);
    EXPECT_LT((R_w * R_w.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
    EXPECT_LT((R_a * R_a.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
    for (const Eigen::Matrix3d& D : {Eigen::Matrix3d(Tw.inverse()), Eigen::Matrix3d(Ta.inverse())})
      EXPECT_LT(Eigen::Vector3d(D(1, 0), D(2, 0), D(2, 1)).norm(), 1e-12) << D;
    const ImuIntrinsics in = Intrinsics(rig.Base());
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int k = 0; k < 10; ++k) {
      const Eigen::Vector3d w_I(u(rng), u(rng), u(rng)), a_I(u(rng), u(rng), 9.81 + u(rng));
      Eigen::Vector3d w_m, a_m;
      in.RawFromTrue(w_I, a_I, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), &w_m, &a_m);
      EXPECT_LT((Tw * R_w * w_I + Tg * a_I - w_m).norm(), 1e-12);
      EXPECT_LT((Ta * R_a * a_I - a_m).norm(), 1e-10);
    }
    const std::optional<std::string> cam_text = EmitOpenVinsImucamChain(rig, &why);
    ASSERT_TRUE(cam_text) << why;
    const YAML::Node chain = LoadOpenCvYaml(*cam_text);
    for (int n = 0; n < 2; ++n) {
      const SensorConfig& c = rig.sensors[1 + n];
      const YAML::Node cam = chain["cam" + std::to_string(n)];
      // T_imu_cam: the camera's pose in I (OpenVINS's T_CtoI), our T_B_C.
      EXPECT_LT((Rows4(cam["T_imu_cam"]) - c.T_B_S).norm(), 1e-15) << c.name;
      EXPECT_EQ(cam["distortion_model"].as<std::string>(), c.distortion_model);
      EXPECT_EQ(cam["intrinsics"].as<std::vector<double>>(), c.intrinsics);
      EXPECT_EQ(cam["distortion_coeffs"].as<std::vector<double>>(), c.distortion_coeffs);
      EXPECT_EQ(cam["timeshift_cam_imu"].as<double>(), c.time_offset);
    }
  }
}

TEST(EcosystemExports, OpenVinsRefusesWhatItHasNoModelFor) {
  std::mt19937 rng(6);
  RigConfig rig = BasaltRig(ImuModel::kImu2, rng, false);
  std::string why;
  EXPECT_FALSE(EmitOpenVinsImucamChain(rig, &why));
  EXPECT_EQ(why, "OpenVINS has no ds camera (cam2)");
  rig.sensors.resize(2);
  rig.sensors[1].distortion_model = "none";
  rig.sensors[1].distortion_coeffs.clear();
  const std::optional<std::string> text = EmitOpenVinsImucamChain(rig, &why);
  ASSERT_TRUE(text);
  const YAML::Node cam0 = LoadOpenCvYaml(*text)["cam0"];
  EXPECT_EQ(cam0["distortion_model"].as<std::string>(), "radtan");
  EXPECT_EQ(cam0["distortion_coeffs"].as<std::vector<double>>(), std::vector<double>(4, 0.0));
}

}  // namespace
}  // namespace ctcal
