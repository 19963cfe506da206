// Private to sensors/: the inverse of a rigid transform, for the Kalibr files' T_cam_imu, T_i_b
// and T_cn_cnm1 (each the inverse of one of our T_B_S), exact up to rounding.
#pragma once

#include <Eigen/Core>

namespace ctcal::internal {

inline Eigen::Matrix4d Inverse(const Eigen::Matrix4d& T) {
  Eigen::Matrix4d inv = Eigen::Matrix4d::Identity();
  inv.topLeftCorner<3, 3>() = T.topLeftCorner<3, 3>().transpose();
  inv.topRightCorner<3, 1>() = -T.topLeftCorner<3, 3>().transpose() * T.topRightCorner<3, 1>();
  return inv;
}

}  // namespace ctcal::internal
