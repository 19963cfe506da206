// mrcal `.cameramodel` exports of a result (issue 22; docs/files.md "Exports"), one per camera.
#include <Eigen/Geometry>
#include <filesystem>
#include <stdexcept>

#include "ctcal/sensors/mrcal_model.h"
#include "ctcal/sensors/rig.h"

namespace ctcal {

std::vector<std::string> SaveMrcalCameraModels(const RigConfig& rig, const std::string& dir,
                                               std::vector<std::string>* notes) {
  std::vector<std::string> written;
  const SensorConfig* reference = nullptr;
  for (const SensorConfig& s : rig.sensors) {
    if (s.type != SensorType::kCamera)
      continue;
    // mrcal's reference frame is its first camera's (identity extrinsics there), so that two of
    // the files give the cameras' relative pose as mrcal's tools expect it:
    //   T_cam_ref = T_C_B T_B_C0 = T_B_C^-1 T_B_C0.
    if (!reference)
      reference = &s;
    const std::string path = (std::filesystem::path(dir) / (s.name + ".cameramodel")).string();
    try {
      const CameraModel camera =
          CameraModel::Create(s.camera_model, s.intrinsics, s.distortion_model, s.distortion_coeffs,
                              Eigen::Vector2i(s.width, s.height));
      const Eigen::Isometry3d T_B_C(s.T_B_S), T_B_C0(reference->T_B_S);
      SaveMrcalCameraModel(path, camera, MrcalRtFromTransform(T_B_C.inverse() * T_B_C0));
      written.push_back(path);
    } catch (const std::invalid_argument& e) {
      if (notes)
        notes->push_back(s.name + ".cameramodel not written: " + e.what());
    }
  }
  return written;
}

}  // namespace ctcal
