// The rules of the rig file (SPEC section 7) shared by its reader (rig_yaml_read.cpp), writer
// (rig_yaml_write.cpp) and validation (rig_yaml_check.cpp): time units, names, the sizes of the
// stored inertial matrices. Private to sensors/.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "ctcal/sensors/rig.h"

namespace ctcal::internal {

// Line of `key` under `where` ("sensors.cam0", "base_imu", ...) in the file a rig came from; 0
// when unknown.
using LineOf = std::function<int(const std::string& where, const std::string& key)>;

// Motion windows are seconds in memory and integer nanoseconds in files (SPEC section 2). The
// division is correctly rounded, so whole and half seconds read back exactly.
double SecondsFromNs(std::int64_t ns);
std::int64_t NsFromSeconds(double s);

// "sensors.<sensor>": where a sensor's keys sit in the file.
std::string Where(const std::string& sensor);

// A sensor name is a dataset folder (SPEC section 6) and the prefix of parameter names
// (`cam0.intrinsics[2]`), so it keeps to characters that are safe in both.
constexpr char kNameRule[] = "use letters, digits, '_' and '-' (it names a folder and parameters)";
bool ValidSensorName(const std::string& name);

// Numbers stored for Dw, Da, Tg of a sensor (0: not estimated), and how 6 or 9 are laid out.
int DwCount(const SensorConfig& s);
int DaCount(const SensorConfig& s);
int TgCount(const SensorConfig& s);
const char* StoredForm(int count);

// ValidateRig, with the line of each offending key when the rig came from a file (`line_of`
// may be empty).
void ValidateRigAt(const RigConfig& rig, const std::string& context, const LineOf& line_of);

}  // namespace ctcal::internal
