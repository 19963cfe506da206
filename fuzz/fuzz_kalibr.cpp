// Kalibr's files (camchain.yaml, imu.yaml, target.yaml) on any bytes. The input is split at its
// first "\n...\n" line: the camchain before, the imu.yaml after (none: a camera-only camchain);
// the whole input is also read as a target file.
#include <stdexcept>

#include "ctcal/sensors/kalibr_files.h"
#include "ctcal/targets/target_config.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::size_t split = text.find("\n...\n");
  const std::string cam = text.substr(0, split);
  const std::string imu = split == std::string::npos ? "" : text.substr(split + 5);
  const std::string cam_path = ctcal::fuzz::WriteInput(
      "camchain.yaml", reinterpret_cast<const std::uint8_t*>(cam.data()), cam.size());
  const std::string imu_path = ctcal::fuzz::WriteInput(
      "imu.yaml", reinterpret_cast<const std::uint8_t*>(imu.data()), imu.size());
  const ctcal::TargetConfig target;  // Kalibr's 6x6 AprilGrid
  try {
    ctcal::RigFromKalibr(cam_path, split == std::string::npos ? "" : imu_path, target);
  } catch (const std::runtime_error&) {
  }
  try {
    ctcal::LoadTargetConfig(cam_path);
  } catch (const std::runtime_error&) {
  }
  return 0;
}
