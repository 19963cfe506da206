#include "ctcal/calibrator/discrete/frame_corners.h"

// The factory's every camera model is instantiated here once (with Ceres' Jets), not in each file
// that builds a problem: defined inline in the header it cost every includer minutes of compiling.
namespace ctcal::discrete {

ceres::CostFunction* MakeDiscreteFrameCorners(CameraModelType type,
                                              std::vector<CornerMeasurement> corners, double stamp,
                                              const BaseSource& src, const FramePoseIndex& c,
                                              const BlockList& list, double huber_threshold) {
  return VisitCameraModel(type, [&](auto model) -> ceres::CostFunction* {
    using Model = decltype(model);
    return new DiscreteFrameCorners<Model>(std::move(corners), stamp, src, c, list,
                                           huber_threshold);
  });
}

}  // namespace ctcal::discrete
