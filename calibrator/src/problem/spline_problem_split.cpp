// Instantiations of the pipeline for the split SO(3) x R^3 trajectory (one translation unit per
// representation so that the two compile in parallel).
#include "spline_problem_impl.h"

namespace ctcal::spline_internal {

template void RunPipeline<4, Se3Representation::kSplit>(Prepared*, const SplineCalibratorOptions&,
                                                        const CalibrationLog&,
                                                        SplineCalibrationResult*);
template void RunPipeline<5, Se3Representation::kSplit>(Prepared*, const SplineCalibratorOptions&,
                                                        const CalibrationLog&,
                                                        SplineCalibrationResult*);
template void RunPipeline<6, Se3Representation::kSplit>(Prepared*, const SplineCalibratorOptions&,
                                                        const CalibrationLog&,
                                                        SplineCalibrationResult*);

}  // namespace ctcal::spline_internal
