// Shared by the CSV readers (dataset.cpp) and the bag reader (bag_dataset.cpp).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "ctcal/sensors/dataset.h"

namespace ctcal {

// A warning "<where>: N gap(s): ..." when some intervals of the increasing stamps `t` are longer
// than 1.5x their median (dropped samples or frames: usable, but the user should know).
void WarnGaps(const std::string& where, const std::vector<std::int64_t>& t, Warnings* warnings);

}  // namespace ctcal
