// `ctcal import-kalibr --target target.yaml [--camchain camchain.yaml] [--imu imu.yaml ...]
// --out RIG.yaml` (SPEC section 8): Kalibr's own configuration files become a rig file with
// initial guesses, so that a Kalibr user's files run unchanged (kalibr_files.h has the mapping).
#include <cstdio>
#include <string>
#include <vector>

#include "cli_common.h"
#include "commands.h"
#include "ctcal/sensors/kalibr_files.h"
#include "ctcal/sensors/model_names.h"
#include "ctcal/sensors/rig_yaml.h"
#include "ctcal/targets/target_config.h"

namespace ctcal::app {

int RunImportKalibr(int argc, char** argv) {
  namespace po = boost::program_options;
  CommandLine cli("import-kalibr",
                  "--target target.yaml [--camchain camchain.yaml] [--imu imu.yaml ...] "
                  "--out RIG.yaml",
                  "Turn Kalibr's camchain.yaml / camchain-imucam.yaml, imu.yaml files (the first "
                  "is the base IMU) and target yaml into a rig file for ctcal calibrate. What "
                  "the files leave open (T_cam_imu, time shifts) starts at the identity / 0 and "
                  "is found by ctcal calibrate's initialisation.");
  std::string target_path, camchain_path, out_path, calibrated_model, g_sensitivity;
  std::vector<std::string> imu_paths;
  bool fix_intrinsics = false;
  cli.options().add_options()("target", po::value(&target_path)->required(),
                              "Kalibr target yaml (aprilgrid or checkerboard)")(
      "camchain", po::value(&camchain_path), "Kalibr camchain.yaml or camchain-imucam.yaml")(
      "imu", po::value(&imu_paths)->multitoken()->composing(),
      "Kalibr imu.yaml, one per IMU (the first is the base; a file may hold imu0, imu1, ...)")(
      "imu-model", po::value(&calibrated_model)->default_value("none"),
      "model for IMUs Kalibr takes as calibrated: none (Kalibr's assumption) or imu1..imu4 "
      "(estimated from the identity)")("g-sensitivity",
                                       po::value(&g_sensitivity)->default_value("full"),
                                       "g-sensitivity of IMUs given a model (none, upper, full)")(
      "fix-intrinsics", po::bool_switch(&fix_intrinsics),
      "keep the camchain's camera intrinsics (Kalibr's camera-IMU step); default: refine them")(
      "out", po::value(&out_path)->required(), "the rig file to write");
  if (const auto exit_code = cli.Parse(argc, argv))
    return *exit_code;
  if (camchain_path.empty() && imu_paths.empty())
    return cli.UsageError("give --camchain, --imu or both (ctcal import-kalibr --help)");
  KalibrImportOptions options;
  options.estimate_camera_intrinsics = !fix_intrinsics;
  std::vector<std::string> warnings;
  RigConfig rig;
  try {
    options.calibrated_imu_model = ParseImuModel(calibrated_model);
    options.g_sensitivity = ParseGSensitivity(g_sensitivity);
  } catch (const std::exception& e) {
    return cli.UsageError(e.what());
  }
  try {
    const TargetConfig target = LoadTargetConfig(target_path);
    rig = RigFromKalibr(camchain_path, imu_paths, target, options, &warnings);
  } catch (const std::exception& e) {
    return cli.InputError(e.what());
  }
  for (const std::string& w : warnings)
    std::fprintf(stderr, "ctcal import-kalibr: warning: %s\n", w.c_str());
  try {
    SaveRig(rig, out_path);
  } catch (const std::exception& e) {
    return cli.RunFailed(e.what());
  }
  int cameras = 0;
  for (const SensorConfig& s : rig.sensors)
    cameras += s.type == SensorType::kCamera ? 1 : 0;
  std::printf("wrote %s: %d camera(s), %d inertial sensor(s), base %s\n", out_path.c_str(), cameras,
              static_cast<int>(rig.sensors.size()) - cameras, rig.base_imu.c_str());
  return kExitOk;
}

}  // namespace ctcal::app
