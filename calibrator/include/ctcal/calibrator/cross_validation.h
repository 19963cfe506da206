// Cross-validation inside `ctcal calibrate` (docs/cross_validation.md): the recording's camera
// frames cut into K interleaved subsets of blocks (block b -> subset b mod K, so each subset sees
// the same kinds of motion); subsets 1 .. K-1 calibrated from the full calibration's values and
// compared with it (CrossValidateNested, sensors/crossval.h: the K-th subset is what the full
// calibration holds beyond them, so one subset solve gives K = 2's pair); their disagreement turned
// into a model-error term of the full calibration's sigma.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "ctcal/calibrator/spline_calibrator.h"
#include "ctcal/sensors/crossval.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig.h"

namespace ctcal {

struct CrossValidationOptions {
  bool enabled = false;        // `--cross-validate`; off by default until validated (issue 20)
  int subsets = 2;             // K >= 2
  double block_seconds = 4.0;  // length of one interleaved block of camera frames
  int min_blocks_per_subset = 2;
};

// Subsets 1 .. K-1's data: every camera's corners of the frames in the subset's blocks; the
// inertial data whole (they bridge the trajectory between a subset's blocks). Every one of the K
// subsets must hold enough frames of each camera, or the recording is not split.
struct SubsetSplit {
  std::vector<std::map<std::string, SensorData>> subsets;
  int blocks = 0;
  double block_seconds = 0.0;
  std::string why_not;  // non-empty: the recording cannot be split (then `subsets` is empty)
};

SubsetSplit SplitIntoSubsets(const RigConfig& rig, const std::map<std::string, SensorData>& data,
                             const CrossValidationOptions& options, int min_views);

struct CalibrationCrossValidation {
  bool ran = false;
  std::string why_not;  // when !ran
  int blocks = 0;
  double block_seconds = 0.0;
  std::vector<RigConfig> subsets;  // the results of subsets 1 .. K-1
  CrossValidation versus_full;     // CrossValidateNested(full, subsets)
  double seconds = 0.0;
};

// Calibrates each subset of `split` from `full` (its values, estimate sets and priors; no coarse
// initialisation; its sigmas must be the formal ones). A subset that fails leaves the
// cross-validation not run, with why.
CalibrationCrossValidation CrossValidateSubsets(const RigConfig& full, const SubsetSplit& split,
                                                const SplineCalibratorOptions& options,
                                                const CalibrationLog& log);

// The model error of each group whose test failed, added to `full`'s sigma: for parameter i of a
// group with model-error ratio lambda, sigma_i^2 = sigma_formal_i^2 + lambda * mean_k s_ik^2
// (s_ik the subsets' sigmas, CrossValRow::subset_variance: the model error of one calibration,
// which more data does not shrink).
// The formal sigma is kept in `sigma_formal` of every sensor with an inflated parameter. Returns
// the number of inflated parameters.
int ApplyModelError(const CrossValidation& cv, RigConfig* full);

// The log's lines: the split, the z table, the verdict and what was inflated.
std::string FormatCalibrationCrossValidation(const CalibrationCrossValidation& xv);

}  // namespace ctcal
