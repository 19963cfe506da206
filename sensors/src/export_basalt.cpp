// basalt's calibration.json from a result (ecosystem_exports.h has the mapping and its frames).
#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <sstream>

#include "ctcal/sensors/ecosystem_exports.h"
#include "ctcal/sensors/number_format.h"
#include "export_helpers.h"

namespace ctcal {
namespace {

using internal::ImuIntrinsicsOf;
using internal::KalibrCameraModels;

// M = R L with R a rotation and L lower-triangular with a positive diagonal (M invertible, det >
// 0). With J the reversal permutation, J M J = (J R J)(J L J) is a QR decomposition (J L J is
// upper-triangular), so R and L follow from Householder QR of J M J with the signs fixed.
void QlDecomposition(const Eigen::Matrix3d& M, Eigen::Matrix3d* R, Eigen::Matrix3d* L) {
  Eigen::Matrix3d J = Eigen::Matrix3d::Zero();
  J(0, 2) = J(1, 1) = J(2, 0) = 1.0;
  const Eigen::HouseholderQR<Eigen::Matrix3d> qr(J * M * J);
  Eigen::Matrix3d Q = qr.householderQ();
  Eigen::Matrix3d U = qr.matrixQR().triangularView<Eigen::Upper>();
  const Eigen::Vector3d sign = U.diagonal().array().sign().matrix();
  Q = Q * sign.asDiagonal();
  U = sign.asDiagonal() * U;
  *R = J * Q * J;
  *L = J * U * J;
}

// The radius of the normalised image plane where r (1 + k1 r^2 + k2 r^4) stops growing: the
// derivative 1 + 3 k1 r^2 + 5 k2 r^4 has its first positive root there; 0 when it has none.
double RadtanTurnover(double k1, double k2) {
  // Roots in s = r^2 of 5 k2 s^2 + 3 k1 s + 1 = 0.
  double s = -1.0;
  if (k2 == 0.0) {
    if (k1 < 0.0)
      s = -1.0 / (3.0 * k1);
  } else {
    const double disc = 9.0 * k1 * k1 - 20.0 * k2;
    if (disc >= 0.0) {
      const double a = (-3.0 * k1 - std::sqrt(disc)) / (10.0 * k2);
      const double b = (-3.0 * k1 + std::sqrt(disc)) / (10.0 * k2);
      for (double root : {a, b}) {
        if (root > 0.0 && (s < 0.0 || root < s))
          s = root;
      }
    }
  }
  return s > 0.0 ? std::sqrt(s) : 0.0;
}

std::string Num(double x) {
  return FormatDouble(x);
}

// One camera's "camera_type" and "intrinsics" members; false when basalt has no such model.
bool BasaltCamera(const SensorConfig& c, std::ostringstream& out) {
  const std::vector<double>& k = c.intrinsics;
  const std::vector<double>& d = c.distortion_coeffs;
  auto head = [&](const char* type, double fx, double fy, double cx, double cy) {
    out << "{\"camera_type\": \"" << type << "\", \"intrinsics\": {\"fx\": " << Num(fx)
        << ", \"fy\": " << Num(fy) << ", \"cx\": " << Num(cx) << ", \"cy\": " << Num(cy);
  };
  if (c.camera_model == "pinhole" && c.distortion_model == "none") {
    head("pinhole", k[0], k[1], k[2], k[3]);
  } else if (c.camera_model == "pinhole" && c.distortion_model == "radtan") {
    head("pinhole-radtan8", k[0], k[1], k[2], k[3]);
    out << ", \"k1\": " << Num(d[0]) << ", \"k2\": " << Num(d[1]) << ", \"p1\": " << Num(d[2])
        << ", \"p2\": " << Num(d[3])
        << ", \"k3\": 0.0, \"k4\": 0.0, \"k5\": 0.0, \"k6\": 0.0, \"rpmax\": "
        << Num(RadtanTurnover(d[0], d[1]));
  } else if (c.camera_model == "pinhole" && c.distortion_model == "equidistant") {
    head("kb4", k[0], k[1], k[2], k[3]);
    out << ", \"k1\": " << Num(d[0]) << ", \"k2\": " << Num(d[1]) << ", \"k3\": " << Num(d[2])
        << ", \"k4\": " << Num(d[3]);
  } else if (c.camera_model == "omni" && c.distortion_model == "none") {
    // Mei's u = fx x / (z + xi |p|) + cx is basalt's UCM u = fx' x / (alpha |p| + (1 - alpha) z)
    // + cx with z + xi |p| = (1 + xi) (alpha |p| + (1 - alpha) z), alpha = xi / (1 + xi).
    const double xi = k[0];
    head("ucm", k[1] / (1.0 + xi), k[2] / (1.0 + xi), k[3], k[4]);
    out << ", \"alpha\": " << Num(xi / (1.0 + xi));
  } else if (c.camera_model == "ds") {
    head("ds", k[2], k[3], k[4], k[5]);
    out << ", \"xi\": " << Num(k[0]) << ", \"alpha\": " << Num(k[1]);
  } else if (c.camera_model == "eucm") {
    head("eucm", k[2], k[3], k[4], k[5]);
    out << ", \"alpha\": " << Num(k[0]) << ", \"beta\": " << Num(k[1]);
  } else {
    return false;
  }
  out << "}}";
  return true;
}

void Vector3Json(std::ostringstream& out, double x) {
  out << "[" << Num(x) << ", " << Num(x) << ", " << Num(x) << "]";
}

}  // namespace

std::optional<std::string> EmitBasaltCalibration(const RigConfig& rig, std::string* why,
                                                 std::vector<std::string>* notes) {
  const std::vector<SensorConfig> cams = KalibrCameraModels(rig, "calibration.json", notes);
  // basalt's IMU frame i (see the header): R_i_I and the calibrated matrices.
  Eigen::Matrix3d R_I_i = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d L = Eigen::Matrix3d::Identity(), G = Eigen::Matrix3d::Identity();
  InertialNoise noise;
  if (!rig.IsCameraOnly()) {
    const SensorConfig& imu = rig.Base();
    noise = imu.noise;
    const ImuIntrinsics in = ImuIntrinsicsOf(imu);
    QlDecomposition(in.R_I_a() * in.D_a(), &R_I_i, &L);
    G = R_I_i.transpose() * in.R_I_w() * in.D_w();
    if (notes && in.T_g().norm() > 0.0)
      notes->push_back("calibration.json: basalt has no g-sensitivity: " + imu.name +
                       "'s T_g is left out");
  }
  std::ostringstream cams_out;
  for (std::size_t n = 0; n < cams.size(); ++n) {
    cams_out << (n ? ",\n      " : "");
    if (!BasaltCamera(cams[n], cams_out)) {
      if (why)
        *why = "basalt has no " + cams[n].camera_model + "-" + cams[n].distortion_model +
               " camera (" + cams[n].name + ")";
      return std::nullopt;
    }
  }
  std::ostringstream out;
  out << "{\n  \"value0\": {\n    \"T_imu_cam\": [\n";
  for (std::size_t n = 0; n < cams.size(); ++n) {
    // T_i_C = R_i_I T_B_C (B = I of the base IMU; for a camera-only rig, the reference camera).
    const Eigen::Matrix3d R = R_I_i.transpose() * cams[n].T_B_S.topLeftCorner<3, 3>();
    const Eigen::Vector3d p = R_I_i.transpose() * cams[n].T_B_S.topRightCorner<3, 1>();
    const Eigen::Quaterniond q(R);
    out << "      {\"px\": " << Num(p.x()) << ", \"py\": " << Num(p.y())
        << ", \"pz\": " << Num(p.z()) << ", \"qx\": " << Num(q.x()) << ", \"qy\": " << Num(q.y())
        << ", \"qz\": " << Num(q.z()) << ", \"qw\": " << Num(q.w()) << "}"
        << (n + 1 < cams.size() ? ",\n" : "\n");
  }
  out << "    ],\n    \"intrinsics\": [\n      " << cams_out.str() << "\n    ],\n";
  out << "    \"resolution\": [";
  for (std::size_t n = 0; n < cams.size(); ++n)
    out << (n ? ", " : "") << "[" << cams[n].width << ", " << cams[n].height << "]";
  out << "],\n";
  // Biases are states of the trajectory (basalt estimates its own); the static part is 0.
  const Eigen::Matrix3d S_a = L - Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d S_g = G - Eigen::Matrix3d::Identity();
  out << "    \"calib_accel_bias\": [0.0, 0.0, 0.0, " << Num(S_a(0, 0)) << ", " << Num(S_a(1, 0))
      << ", " << Num(S_a(2, 0)) << ", " << Num(S_a(1, 1)) << ", " << Num(S_a(2, 1)) << ", "
      << Num(S_a(2, 2)) << "],\n";
  out << "    \"calib_gyro_bias\": [0.0, 0.0, 0.0";
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r)
      out << ", " << Num(S_g(r, c));
  out << "],\n";
  out << "    \"imu_update_rate\": " << Num(rig.IsCameraOnly() ? 200.0 : noise.update_rate)
      << ",\n    \"accel_noise_std\": ";
  Vector3Json(out, noise.accelerometer_noise_density);
  out << ",\n    \"gyro_noise_std\": ";
  Vector3Json(out, noise.gyroscope_noise_density);
  out << ",\n    \"accel_bias_std\": ";
  Vector3Json(out, noise.accelerometer_random_walk);
  out << ",\n    \"gyro_bias_std\": ";
  Vector3Json(out, noise.gyroscope_random_walk);
  const double offset = rig.IsCameraOnly() || cams.empty() ? 0.0 : cams[0].time_offset;
  for (const SensorConfig& c : cams) {
    if (notes && !rig.IsCameraOnly() && std::abs(c.time_offset - offset) > 1e-6) {
      char ms[32];
      std::snprintf(ms, sizeof ms, "%+.3f ms", (c.time_offset - offset) * 1e3);
      notes->push_back("calibration.json: basalt has one camera time offset: " + cams[0].name +
                       "'s is written, " + c.name + "'s differs by " + ms);
    }
  }
  out << ",\n    \"cam_time_offset_ns\": " << static_cast<std::int64_t>(std::llround(offset * 1e9))
      << ",\n    \"vignette\": []\n  }\n}\n";
  return out.str();
}

}  // namespace ctcal
