// `ctcal compare`: a result against the truth, one row per estimated scalar (SPEC sections 7, 8).
//
// The rows are the parameters the RESULT estimates (its `estimate:` sets, plus gravity_W when both
// files carry it), named as SPEC section 7 names them. A vector parameter's error is
// estimate - truth. A rotation R_X_Y is compared as a whole, dtheta = Log(R_est * R_true^T) (the
// left perturbation in frame X, the convention of `sigma:`): its rows show truth 0 and estimate =
// error = the component of dtheta, and the rotation's angle |dtheta| is reported in degrees.
// Sigmas are the result's; `.inf` (or no sigma) leaves error/sigma undetermined.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ctcal/sensors/rig.h"

namespace ctcal {

struct ComparisonRow {
  std::string name;  // SPEC section 7 parameter name
  double truth = 0.0;
  double estimate = 0.0;
  double error = 0.0;                      // estimate - truth (a rotation: dtheta component)
  std::optional<double> sigma;             // the result's 1-sigma; nullopt when it gives none
  std::optional<double> error_over_sigma;  // nullopt when sigma is absent, .inf, .nan or 0
  bool rotation = false;
};

struct RotationComparison {
  std::string name;  // "cam0.R_B_S", "imu0.R_I_a"
  double angle_deg = 0.0;
};

struct ComparisonSummary {
  int count = 0;         // rows
  int with_sigma = 0;    // rows with a finite, positive sigma
  int undetermined = 0;  // rows with sigma .inf: the data does not determine them
  int no_sigma = 0;      // rows whose sigma the result does not give (or gives as .nan or 0)
  int within_3_sigma = 0;
  // within_3_sigma / with_sigma; nullopt when no row has a sigma.
  std::optional<double> fraction_within_3_sigma;
  // The row with the largest |error / sigma|; nullopt when no row has a sigma.
  std::optional<std::string> worst_name;
  std::optional<double> worst_error_over_sigma;
};

struct Comparison {
  std::vector<ComparisonRow> rows;
  std::vector<RotationComparison> rotations;
  ComparisonSummary summary;
};

// Throws std::runtime_error when the truth lacks a sensor or parameter the result estimates.
// A result whose base is another sensor of the truth (e.g. the reference camera of a camera-only
// calibration) is compared with the truth re-expressed in that sensor's frame and clock.
Comparison CompareRigs(const RigConfig& truth, const RigConfig& result);

// The human-readable table with its summary lines.
std::string FormatComparison(const Comparison& c);
// {"parameters": [{"name","truth","estimate","error","sigma","error_over_sigma"}...],
//  "rotations": [{"name","angle_deg"}...], "summary": {...}}; non-finite numbers are null.
std::string ComparisonJson(const Comparison& c);

}  // namespace ctcal
