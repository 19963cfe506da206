// The compressed frame residual's factories for the supported orders and representations,
// compiled once here (every camera model of each).
#include "ctcal/calibrator/residuals/frame_corners_residual.h"

namespace ctcal {

#define CTCAL_FRAME_CORNERS_RESIDUAL_INSTANTIATE(N, REP)                                    \
  template ceres::CostFunction* MakeFrameCornersResidual<N, Se3Representation::REP>(        \
      CameraModelType, std::vector<CornerMeasurement>, const SegmentClock&, double);        \
  template ceres::CostFunction* MakeFrameCornersResidual<N, Se3Representation::REP>(        \
      CameraModelType, const HeldCorner*, int, const Eigen::Vector3d*, const SegmentClock&, \
      double, FrameRows, const std::vector<double*>&);
CTCAL_FRAME_CORNERS_RESIDUAL_INSTANTIATE(4, kSplit)
CTCAL_FRAME_CORNERS_RESIDUAL_INSTANTIATE(5, kSplit)
CTCAL_FRAME_CORNERS_RESIDUAL_INSTANTIATE(6, kSplit)
CTCAL_FRAME_CORNERS_RESIDUAL_INSTANTIATE(4, kJoint)
CTCAL_FRAME_CORNERS_RESIDUAL_INSTANTIATE(5, kJoint)
CTCAL_FRAME_CORNERS_RESIDUAL_INSTANTIATE(6, kJoint)
#undef CTCAL_FRAME_CORNERS_RESIDUAL_INSTANTIATE

}  // namespace ctcal
