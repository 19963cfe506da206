// Kalibr's `scale-misalignment` IMU model (imu.yaml: `model: scale-misalignment`,
// `gyroscopes: {M, A, C_gyro_i}`, `accelerometers: {M}`) and its exact map to ours.
//
// Kalibr (kalibr_imu_camera_calibration/IccSensors.py, IccScaledMisalignedImu) predicts, in its
// IMU frame i,
//   a_m = M_a a_i + b_a,
//   w_m = M_g C_gyro_i w_i + A C_gyro_i a_i + b_g,
// with M_a, M_g lower-triangular (its design variables have the pattern [[1,0,0],[1,1,0],[1,1,1]]),
// A full and C_gyro_i a rotation (C_gyro_i = R_gyro_i). Its i is therefore the frame whose x axis
// is the accelerometer's x axis; ours (upper-triangular D) keeps a triad's z axis instead. Both
// parameterisations have 15 + 9 degrees of freedom and describe the same family of sensors, so
// the map is exact up to a rotation R_I_i between Kalibr's frame i and our frame I, which the
// caller must carry into the extrinsics (T_B_S of this IMU = T_B_i * R_i_I; for the base IMU,
// every other sensor's extrinsic changes by R_I_i).
//
// Writing X_a = M_a^-1 and X_w = C_gyro_i^T M_g^-1 (raw -> frame i), and a_I = R_I_i a_i:
//   a_I = R_I_i X_a (a_m - b_a),   w_I = R_I_i X_w (w_m - b_g - T_g a_I),   T_g = A C_gyro_i R_i_I,
// and a QR factorisation (orthogonal times upper-triangular with positive diagonal) splits
// R_I_i X into the rotation and D our model has: imu1/imu3 take R_i_I from X_a = R_i_I D_a;
// imu2/imu4 from X_w = R_i_I D_w; the other triad then gets R_I_w D_w (imu1), R_I_a D_a (imu2) or
// a full D (imu3, imu4). The reverse uses a QL factorisation for Kalibr's lower-triangular M.
//
// Not exact: g_sensitivity upper (our T_g would have to come out upper-triangular; rejected
// unless it does to 1e-12) and none (needs A = 0), model none (needs identity M's and
// C_gyro_i), and Kalibr's `scale-misalignment-size-effect` lever arms (not modelled here).
#pragma once

#include <Eigen/Core>

#include "ctcal/sensors/imu_intrinsics.h"

namespace ctcal {

struct KalibrScaleMisalignment {
  Eigen::Matrix3d M_gyro = Eigen::Matrix3d::Identity();    // gyroscopes.M
  Eigen::Matrix3d A_gyro = Eigen::Matrix3d::Zero();        // gyroscopes.A [(rad/s)/(m/s^2)]
  Eigen::Matrix3d C_gyro_i = Eigen::Matrix3d::Identity();  // gyroscopes.C_gyro_i
  Eigen::Matrix3d M_accel = Eigen::Matrix3d::Identity();   // accelerometers.M
};

struct KalibrImuImport {
  ImuIntrinsics intrinsics;
  Eigen::Matrix3d R_I_i = Eigen::Matrix3d::Identity();  // Kalibr's frame i -> our frame I
};

// Kalibr -> ours for the chosen model (default: imu2 with full g-sensitivity, which every Kalibr
// result fits). Any invertible M with positive determinant is accepted, not only lower-triangular
// ones. Throws std::invalid_argument naming the Kalibr key (gyroscopes.M, gyroscopes.A,
// gyroscopes.C_gyro_i, accelerometers.M) or the target model when the map is not exact.
KalibrImuImport FromKalibrScaleMisalignment(const KalibrScaleMisalignment& kalibr,
                                            ImuModel model = ImuModel::kImu2,
                                            GSensitivity g_sensitivity = GSensitivity::kFull);
KalibrImuImport FromKalibrScaleMisalignment(const Eigen::Matrix3d& M_gyro,
                                            const Eigen::Matrix3d& A_gyro,
                                            const Eigen::Matrix3d& C_gyro_i,
                                            const Eigen::Matrix3d& M_accel,
                                            ImuModel model = ImuModel::kImu2,
                                            GSensitivity g_sensitivity = GSensitivity::kFull);

// Ours -> Kalibr, in Kalibr's canonical form (lower-triangular M's with positive diagonal).
// Exact for every model. R_i_I (optional) receives the rotation from our frame I to Kalibr's i.
KalibrScaleMisalignment ToKalibrScaleMisalignment(const ImuIntrinsics& intrinsics,
                                                  Eigen::Matrix3d* R_i_I = nullptr);

// X = Q U with Q a rotation and U upper-triangular with positive diagonal (unique; needs
// det X > 0), and X = Q L likewise with L lower-triangular. Exposed for tests and the simulator.
void RotationUpperFactor(const Eigen::Matrix3d& X, Eigen::Matrix3d* Q, Eigen::Matrix3d* U);
void RotationLowerFactor(const Eigen::Matrix3d& X, Eigen::Matrix3d* Q, Eigen::Matrix3d* L);

}  // namespace ctcal
