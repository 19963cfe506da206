// Reading and writing the rig / result / truth YAML of SPEC section 7 (the data is in rig.h).
//
// Reading is strict: a key not listed for a sensor's type or model, a missing required key, a
// count that does not fit the model, a non-rigid T_B_S, a sigma of the wrong shape, an `estimate`
// the rig cannot honour: each throws std::runtime_error "<file>:<line>: sensors.<name>: <what>".
// Absent optional keys take the SPEC defaults; a non-base sensor without T_B_S is a warning.
// Writing then reading gives back an identical RigConfig (every double is written as the shortest
// decimal that reads back exactly; .inf / -.inf / .nan as YAML writes them).
#pragma once

#include <string>
#include <vector>

#include "ctcal/sensors/rig.h"

namespace YAML {
class Node;
}  // namespace YAML

namespace ctcal {

// `file` names the source in messages. Warnings go to *warnings, or to stderr when it is null.
RigConfig ParseRig(const YAML::Node& root, const std::string& file,
                   std::vector<std::string>* warnings = nullptr);
RigConfig LoadRig(const std::string& path, std::vector<std::string>* warnings = nullptr);
RigConfig ParseRigString(const std::string& yaml, const std::string& file = "<string>",
                         std::vector<std::string>* warnings = nullptr);

// The checks of ParseRig on an in-memory rig (what a program builds before writing it); throws
// std::runtime_error "<context>: sensors.<name>: <what>".
void ValidateRig(const RigConfig& rig, const std::string& context);

// Validates, then writes. Throws std::runtime_error when the file cannot be written.
std::string EmitRig(const RigConfig& rig);
void SaveRig(const RigConfig& rig, const std::string& path);

// Counts fixed by SPEC section 4: intrinsics of a camera_model (pinhole 4, omni 5, ds 6,
// eucm 6) and coefficients of a distortion_model (radtan 4, equidistant 4, none 0); -1 when the
// name is unknown.
int IntrinsicsCount(const std::string& camera_model);
int DistortionCount(const std::string& distortion_model);

}  // namespace ctcal
