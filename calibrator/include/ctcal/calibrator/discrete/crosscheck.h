// The cross-check of `ctcal calibrate --method both`: the spline and the discrete estimates of
// every estimated scalar side by side. Both use the same data, so their errors are strongly
// correlated and their difference is far smaller than either sigma; a difference beyond the
// smaller sigma means the two models disagree, and the parameter is flagged.
#pragma once

#include <string>
#include <vector>

#include "ctcal/sensors/rig.h"

namespace ctcal {

struct CrossCheckRow {
  std::string parameter;  // SPEC name ("cam0.intrinsics[2]"); rotations in rad
  double spline = 0.0, sigma_spline = 0.0;
  double discrete = 0.0, sigma_discrete = 0.0;
  double difference = 0.0;  // discrete - spline (rotations: the perturbation between the two)
  double ratio = 0.0;       // |difference| / min(sigma_spline, sigma_discrete)
  bool flagged = false;     // ratio > 1
  bool rotation = false;    // a rotation's perturbation component
};

struct CrossCheck {
  std::vector<CrossCheckRow> rows;
  std::vector<std::string> flagged;
};

// Rows for every scalar both results estimate with a finite sigma (throws std::runtime_error
// naming the parameter when a result lacks a value the other has).
CrossCheck MakeCrossCheck(const RigConfig& spline, const RigConfig& discrete);

// OUT/crosscheck.yaml: `flagged:` (names) and `rows:` (a sequence of maps {parameter, spline,
// sigma_spline, discrete, sigma_discrete, difference, ratio}). Throws std::runtime_error naming
// the path when it cannot be written.
void SaveCrossCheck(const CrossCheck& check, const std::string& path);

// The same as a terminal table (rotations in degrees).
std::string FormatCrossCheck(const CrossCheck& check);

}  // namespace ctcal
