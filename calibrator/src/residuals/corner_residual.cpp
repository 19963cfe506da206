// The corner residual's factories for the supported orders and representations, compiled once
// here (every camera model of each) instead of in every user's translation unit.
#include "ctcal/calibrator/residuals/corner_residual.h"

namespace ctcal {

#define CTCAL_CORNER_RESIDUAL_INSTANTIATE(N, REP)                              \
  template ceres::CostFunction* MakeCornerResidual<N, Se3Representation::REP>( \
      bool, CameraModelType, const CornerMeasurement&, const SegmentClock&);
CTCAL_CORNER_RESIDUAL_INSTANTIATE(4, kSplit)
CTCAL_CORNER_RESIDUAL_INSTANTIATE(5, kSplit)
CTCAL_CORNER_RESIDUAL_INSTANTIATE(6, kSplit)
CTCAL_CORNER_RESIDUAL_INSTANTIATE(4, kJoint)
CTCAL_CORNER_RESIDUAL_INSTANTIATE(5, kJoint)
CTCAL_CORNER_RESIDUAL_INSTANTIATE(6, kJoint)
#undef CTCAL_CORNER_RESIDUAL_INSTANTIATE

}  // namespace ctcal
