// Folders as EuRoC and TUM-VI publish them (`mav0/`): every sensor folder (`cam0/`, `imu0/`, ...)
// holds a `sensor.yaml` with its pose in the body frame (`T_BS: {rows: 4, cols: 4, data: [16
// numbers row-major]}`) and its model: cameras `camera_model`, `intrinsics`, `distortion_model`
// (`radial-tangential` = our radtan, `equidistant`, `none`), `distortion_coefficients`,
// `resolution`, `rate_hz`; IMUs `sensor_type: imu`, Kalibr's four noise keys and `rate_hz`.
// Folders of other sensor types (`leica0`, `state_groundtruth_estimate0`, ...) are skipped.
#pragma once

#include <string>
#include <vector>

#include "ctcal/sensors/rig.h"

namespace ctcal {

// Whether `data_dir` has at least one `<sensor>/sensor.yaml` of a camera or an IMU.
bool HasEurocSensorYamls(const std::string& data_dir);

// A rig with initial guesses from the folder's sensor.yaml files: the IMUs (model none, as the
// datasets publish calibrated IMUs; the first in name order is the base, T_B_S = T_BS_base^-1
// T_BS_imu) and the cameras (T_B_S the same way; intrinsics, extrinsics and time offset
// estimated). Sensors are named by their folders. Throws std::runtime_error "<file>:<line>: ..."
// for a malformed sensor.yaml, and when there is no IMU or camera.
RigConfig RigFromEurocFolder(const std::string& data_dir, const TargetConfig& target,
                             std::vector<std::string>* warnings);

// The folder's sensor.yaml guesses against a given rig's: one warning per sensor whose pose
// differs by more than 2 deg or 2 cm, or whose focal length or centre by more than 5 %, and per
// rig sensor without a sensor.yaml. The rig is used as given.
std::vector<std::string> CrossCheckEurocFolder(const std::string& data_dir, const RigConfig& rig);

}  // namespace ctcal
