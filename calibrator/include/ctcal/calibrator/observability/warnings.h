// The terminal's observability warning block: one line per estimated parameter that is
// unobservable (numerically or by the motion's prediction) or weak, saying what motion would
// determine it, or to stop estimating it.
#pragma once

#include <string>
#include <vector>

#include "ctcal/sensors/rig.h"

namespace ctcal {

// What motion determines one parameter (by its SPEC section 7 name), e.g. for `imu0.Dw[1]`
// "rotate about imu0's y axis with a varying rate". Unknown names get a generic line.
std::string MotionSuggestion(const RigConfig& rig, const std::string& parameter);

// Lines like
//   "imu0.Dw[1]: unobservable (numeric, predicted by the motion) - rotate about imu0's y axis
//    with a varying rate, or remove `intrinsics` from imu0's estimate"
// in the order unobservable, then predicted only, then weak; each parameter once.
std::vector<std::string> ObservabilityWarnings(const RigConfig& rig,
                                               const Observability& observability);

}  // namespace ctcal
