// Private to sensors/: what the writers of other programs' files (Kalibr, basalt, OpenVINS) take
// from a rig: an IMU's full intrinsic matrices, the cameras in the files' order, and the YAML
// emitters of their number lists and matrices (one flow sequence per row, as Kalibr writes them).
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "ctcal/sensors/imu_intrinsics.h"
#include "ctcal/sensors/kalibr_camera.h"
#include "ctcal/sensors/number_format.h"
#include "ctcal/sensors/rig.h"

namespace ctcal::internal {

inline ImuIntrinsics ImuIntrinsicsOf(const SensorConfig& s) {
  StoredImuIntrinsics stored;
  stored.Dw = s.D_w;
  stored.Da = s.D_a;
  stored.Tg = s.T_g;
  const std::string rot = RotationKey(s.imu_model);
  if (rot == "R_I_a")
    stored.rotation = s.R_I_a;
  else if (rot == "R_I_w")
    stored.rotation = s.R_I_w;
  return ImuIntrinsics::FromStored(s.imu_model, s.g_sensitivity, stored);
}

// The cameras in Kalibr's order (cam0, cam1, ...): rig order, the base camera first in a
// camera-only rig.
inline std::vector<const SensorConfig*> KalibrCameras(const RigConfig& rig) {
  std::vector<const SensorConfig*> cams;
  if (rig.IsCameraOnly())
    cams.push_back(&rig.Base());
  for (const SensorConfig& s : rig.sensors) {
    if (s.type == SensorType::kCamera && !(rig.IsCameraOnly() && s.name == rig.base_imu))
      cams.push_back(&s);
  }
  return cams;
}

// KalibrCameras as the other programs' files can hold them (kalibr_camera.h): an mrcal lens as
// pinhole-radtan. `notes` (may be null) gets one line per fitted lens, naming `file`.
inline std::vector<SensorConfig> KalibrCameraModels(const RigConfig& rig, const std::string& file,
                                                    std::vector<std::string>* notes) {
  std::vector<SensorConfig> out;
  for (const SensorConfig* c : KalibrCameras(rig)) {
    KalibrCamera k = AsKalibrCamera(*c);
    if (notes && !k.exact)
      notes->push_back(KalibrCameraNote(file, k));
    out.push_back(std::move(k.camera));
  }
  return out;
}

template <typename Derived>
void EmitMatrix(YAML::Emitter& out, const Eigen::MatrixBase<Derived>& m) {
  out << YAML::BeginSeq;
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    out << YAML::Flow << YAML::BeginSeq;
    for (Eigen::Index c = 0; c < m.cols(); ++c)
      out << FormatDouble(m(r, c));
    out << YAML::EndSeq;
  }
  out << YAML::EndSeq;
}

inline void EmitNumbers(YAML::Emitter& out, const std::vector<double>& v) {
  out << YAML::Flow << YAML::BeginSeq;
  for (double x : v)
    out << FormatDouble(x);
  out << YAML::EndSeq;
}

}  // namespace ctcal::internal
