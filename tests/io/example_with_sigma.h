// configs/example_rig.yaml as a result file: sigma `s` on every estimated quantity. Shared by the
// cross-validation tests (io_crossval, calibrator_model_error, apps_crossval).
#pragma once

#include <string>
#include <vector>

#include "ctcal/sensors/parameter_names.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal::test {

inline const std::string kExampleRig = std::string(CTCAL_SOURCE_DIR) + "/configs/example_rig.yaml";

inline RigConfig ExampleWithSigma(double s) {
  std::vector<std::string> warnings;
  RigConfig rig = LoadRig(kExampleRig, &warnings);
  for (SensorConfig& sensor : rig.sensors) {
    for (const ParameterKey& k : SensorParameterKeys(rig, sensor)) {
      if (sensor.Estimates(k.item))
        sensor.sigma.values[k.key] = std::vector<double>(static_cast<std::size_t>(k.size), s);
    }
  }
  return rig;
}

}  // namespace ctcal::test
