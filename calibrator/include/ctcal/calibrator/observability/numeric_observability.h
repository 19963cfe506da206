// The numeric half of the observability report (issue 9, SPEC section 7 `observability:`), shared
// by every calibrator that marginalises its trajectory into a MarginalInformation (the spline
// calibrator's FinishResult; the discrete one's keyframe states likewise):
//
//   unobservable  the information WITHOUT priors, each parameter scaled by its physical unit
//                 (1 deg, 1 cm, 1 ms, 1 px, 1e-3 for scale factors; marginal_covariance.h),
//                 eigen-decomposed: an eigenvalue below 1e-9 of the largest is null, and a
//                 parameter loading more than 0.1 on a null direction is unobservable
//                 (InvertInformation's rule, applied to the data-only information);
//   directions    every null direction: its eigenvalue as a fraction of the largest, and the
//                 parameters loading more than 0.1 on it, largest first;
//   weak          a determined parameter whose data-only sigma exceeds 10x the reference: the
//                 sigma the fully excited default rig (`ctcal simulate --scenario full`) gives
//                 for that kind of parameter over the same duration (the table in
//                 numeric_observability.cpp, docs/observability.md).
// The motion half (motion, predicted_unobservable) is AnalyseMotion's (motion_prediction.h);
// ReportObservability prints both side by side as the terminal's warning block.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "ctcal/calibrator/marginal_covariance.h"
#include "ctcal/sensors/rig.h"

namespace ctcal {

// Data-only sigma above this multiple of the reference sigma is `weak`.
inline constexpr double kWeakFactor = 10.0;

// The reference kind of a SPEC section 7 parameter name, e.g. "imu.Dw", "camera.focal",
// "camera.equidistant.k[2]", "gravity_W.direction"; "" for a name the rig does not have.
std::string ParameterKind(const RigConfig& rig, const std::string& name);

// The fully excited default rig's sigma of `name`'s kind for a recording of `duration_s`
// seconds (information grows linearly with time: reference(1 s) / sqrt(duration_s)), in the
// parameter's own unit (rotations in rad). std::nullopt when the default rig has no parameter of
// that kind (e.g. an omni camera's xi, a line delay): such a parameter is never called weak.
std::optional<double> ReferenceSigma(const RigConfig& rig, const std::string& name,
                                     double duration_s);

// Unobservable, weak and directions from the data-only information and its inverse
// (InvertInformation(information, {1e-9, 0.1})), for a recording of `duration_s` seconds. The
// gravity direction's two tangent names map to `gravity_W` in the lists.
Observability NumericObservability(const MarginalInformation& information,
                                   const CalibrationCovariance& covariance, const RigConfig& rig,
                                   double duration_s, double weak_factor = kWeakFactor);

// A symmetry the motion tables predict holds for the true motion, but the estimated trajectory
// also fits the sensors' noise, and that fit lends the symmetric direction a sliver of
// information (1e-8..1e-6 of the largest eigenvalue, above the null rule): such a parameter comes
// out `weak`, not null (docs/observability.md). When the motion analysis has found the primitive
// (its statistical test says the motion is the degenerate one within the sensor noise) and the
// numeric analysis finds the parameter weak, its information is the noise's, not the motion's:
// the parameter moves from `weak` to `unobservable` and its sigma in `result` becomes .inf (SPEC
// section 7: a quantity the data do not determine; as for the numerically null ones, a prior
// does not make it determined). Returns the names moved.
std::vector<std::string> MergePredictedWeakIntoUnobservable(Observability* observability,
                                                            RigConfig* result);

// The terminal's observability block: the numeric and the analytic lists side by side, then
// one warning line per unobservable or weak estimated parameter with the motion that would fix
// it (warnings.h). Each warning is also appended to *warnings when it is not null.
void ReportObservability(const RigConfig& result, const Observability& observability,
                         const std::function<void(const std::string&)>& log,
                         std::vector<std::string>* warnings);

}  // namespace ctcal
