// Cross-validation of calibrations of one rig (`ctcal crossval`, and the subsets of
// `ctcal calibrate`; docs/cross_validation.md): K >= 2 results from disjoint data, each with its
// own sigma, compared parameter by parameter and per group of parameters.
//
// Per estimated scalar i (the first result's `estimate:` sets; gravity_W is left out: it is the
// board's placement, not the rig's) with values x_ik and sigmas s_ik, k = 1..K:
//   r_i = sample variance of x_ik over k / mean over k of s_ik^2,
// which is chi-square(K-1) / (K-1) distributed (mean 1) when the sigmas are right. For K = 2 it
// is z_i^2 with z_i = (x_i2 - x_i1) / sqrt(s_i1^2 + s_i2^2); for K > 2 the table's z is the
// unsigned sqrt(r_i). A rotation R_X_Y is compared as a whole: its values are the components of
// Log(R_k * R_1^T) (the left perturbation in frame X, as `sigma:`).
//
// Groups (each camera's intrinsics with its distortion and line delay, each inertial sensor's
// intrinsics, each sensor's R_B_S, t_B_S, time_offset): (K-1) sum_i r_i against the chi-square
// quantile of (K-1) n dof at 1 % false alarm over all groups (1 % / the number of tested groups
// each: Bonferroni). A group that fails gets the model-error ratio
// lambda = mean_i r_i - 1: the subsets disagree as if each one's variance were (1 + lambda) times
// its formal one (calibrator/cross_validation.h turns that into the full calibration's sigma).
//
// Nested (CrossValidateNested, inside `ctcal calibrate`): the full calibration F and calibrations
// of subsets k of its data, each holding 1/K of the camera frames and all the inertial samples.
// A subset's data is part of F's, so (Hausman) Var(x_k - x_F) = s_k^2 - s_F^2, shared inertial
// samples included, and r_ik = (x_k - x_F)^2 / (s_k^2 - s_F^2) has mean 1 when the sigmas are
// right; for K = 2, x_1 - x_F is half the difference between subset 1 and its complement, so
// z = (x_1 - x_F) / sqrt(s_1^2 - s_F^2) is the complement pair's z with one subset solved.
// A parameter whose subset sigma is hardly larger than F's (s_k^2 < 1.2 s_F^2: the frames left
// out hardly inform it) has no ratio.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ctcal/sensors/rig.h"

namespace ctcal {

struct CrossValRow {
  std::string name;   // SPEC section 7 parameter name
  std::string group;  // "cam0.intrinsics", "cam1.t_B_S", ...
  std::string sensor;
  bool rotation = false;
  std::vector<double> values;  // per result (a rotation: Log(R_k R_1^T) component)
  std::vector<double> sigmas;  // per result; .inf / .nan as the files give them
  // K = 2: x_2 - x_1. K > 2: the sample standard deviation over the results. Nested: the rms of
  // x_k - x_F over the subsets.
  double difference = 0.0;
  // The mean over the subsets (all results; nested: all but F) of s_k^2: the scale of the model
  // error a group's lambda gives this parameter.
  double subset_variance = 0.0;
  // r_i (see above) and the table's z: nullopt when a sigma is absent, zero or not finite.
  std::optional<double> ratio;
  std::optional<double> z;
};

struct CrossValGroup {
  std::string name;        // "cam0.intrinsics"
  int count = 0;           // rows with a ratio
  double statistic = 0.0;  // (K-1) sum r_i
  int dof = 0;             // (K-1) count
  double threshold = 0.0;  // chi-square(dof) quantile at 1 - kCrossValFalseAlarm / tested groups
  bool passed = true;
  double mean_ratio = 0.0;  // mean r_i
  // lambda: max(0, mean r_i - 1) when this group's test or the rig's fails (CrossValSummary), else
  // 0
  double model_ratio = 0.0;
};

inline constexpr double kCrossValFalseAlarm = 0.01;

struct CrossValSummary {
  int count = 0;   // rows
  int with_z = 0;  // rows with a z
  int within_3_sigma = 0;
  std::optional<double> fraction_within_3_sigma;
  std::optional<double> rms_z;  // sqrt(mean r_i)
  std::optional<std::string> worst_name;
  std::optional<double> worst_z;
  int groups_failed = 0;
  // The rig's test: every group's statistic summed against the chi-square quantile of all their
  // dof at 1 - kCrossValFalseAlarm. A model error spread over many groups, none of them
  // significant alone (a 1-dof group needs r > 11.6 under the Bonferroni limit), fails it.
  double rig_statistic = 0.0;
  int rig_dof = 0;
  double rig_threshold = 0.0;
  bool rig_passed = true;
  bool passed = true;  // every group's test and the rig's passed
};

struct CrossValidation {
  int num_results = 0;
  bool nested = false;  // CrossValidateNested: results[0] is F
  int row_dof = 1;      // chi-square dof of one row's (K-1) r_i, or of its nested sum
  std::vector<CrossValRow> rows;
  std::vector<CrossValGroup> groups;  // in the rows' order
  CrossValSummary summary;
};

// The group of one parameter name's sensor and key ("cam0", "distortion_coeffs" ->
// "cam0.intrinsics").
std::string CrossValGroupName(const std::string& sensor, const std::string& key);

// Throws std::runtime_error naming the result (by `labels`, e.g. the file names) and parameter
// when a result lacks a parameter the first one estimates, or the results have different bases.
CrossValidation CrossValidate(const std::vector<RigConfig>& results,
                              const std::vector<std::string>& labels);

// `full` (F) and calibrations of `subsets` of its data (see above); the labels name the subsets.
CrossValidation CrossValidateNested(const RigConfig& full, const std::vector<RigConfig>& subsets,
                                    const std::vector<std::string>& subset_labels);

// The table (one row per parameter), the groups' tests and the verdict.
std::string FormatCrossValidation(const CrossValidation& cv);
// {"results": K, "parameters": [{name, group, values, sigmas, difference, z}], "groups": [...],
//  "summary": {...}}; non-finite numbers are null.
std::string CrossValidationJson(const CrossValidation& cv);

}  // namespace ctcal
