// The analytic half of the observability report: which estimated parameters the seed reports'
// tables say the motion primitives found over the whole recording make unobservable, as SPEC
// section 7 parameter names of the rig (docs/observability.md lists the rules and the expected
// sets per simulator scenario).
//
//   constant_angular_velocity about raw axis j of S   S.Dw column j           (intrinsic Table I)
//   constant_specific_force along u of S              S.Da and S.Tg column j  (Table I)
//                                                     for every |u_j| > 0.1
//   one_axis_rotation / planar about u of S           S.Dw every column but the one u lies on
//                                                     (only D_w u is seen)
//     ... of the base, u in B                         t_B_S[k] of every IMU and camera, R_B_S[k]
//                                                     of every gyroscope, for |u_k| > 0.1
//   no_rotation of S                                  all of S.Dw             (MVIS Table 2)
//     ... of the base                                 t_B_S of every IMU and camera, R_B_S and
//                                                     time_offset of every gyroscope
// The 0.1 is the loading threshold of the numeric analysis (issue 9): a parameter is listed when
// its loading on the direction the primitive leaves free exceeds it. Parameters a sensor does not
// estimate are not listed.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "ctcal/calibrator/observability/motion_primitives.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig.h"

namespace ctcal {

// Loading above which a parameter is named for a free direction (issue 9's numeric criterion).
inline constexpr double kUnobservableLoading = 0.1;

// `whole_recording`: primitives that hold over the whole recording (MotionDetection::whole of
// every inertial sensor). Names in the canonical order of ScalarParameters, without repeats.
std::vector<std::string> PredictUnobservable(const RigConfig& rig,
                                             const std::vector<MotionPrimitive>& whole_recording);

// The raw readings of an inertial sensor of `rig` from its data, on the base clock (the rig's
// time_offset guess). Throws std::invalid_argument naming the sensor when it is not inertial or
// has no data.
InertialSeries MakeInertialSeries(const RigConfig& rig, const SensorConfig& sensor,
                                  const SensorData& data);

// Fills `observability->motion` (whole-recording primitives, then window segments, sensors in
// file order) and `observability->predicted_unobservable` for every inertial sensor of the rig
// in `data`. A camera-only rig gets no primitives (no inertial readings).
void AnalyseMotion(const RigConfig& rig, const std::map<std::string, SensorData>& data,
                   const MotionOptions& options, Observability* observability);

// The rest of every calibration's observability report once its numeric half is in
// result->observability (the calibrators' FinishResult): AnalyseMotion on the raw data, the
// noise-broken predicted parameters moved from weak to unobservable
// (MergePredictedWeakIntoUnobservable) and the terminal block with its warnings
// (ReportObservability). Does nothing when there is no numeric half (covariance not computed).
void CompleteObservability(const RigConfig& rig, const std::map<std::string, SensorData>& data,
                           RigConfig* result, const std::function<void(const std::string&)>& log,
                           std::vector<std::string>* warnings);

// The same with AnalyseMotion run beforehand into `motion` (its motion and
// predicted_unobservable are taken over): for a calibrator that releases the raw data before it
// finishes (a long recording's memory, docs/performance.md step 7e).
void CompleteObservability(const Observability& motion, RigConfig* result,
                           const std::function<void(const std::string&)>& log,
                           std::vector<std::string>* warnings);

}  // namespace ctcal
