#include "ctcal/calibrator/discrete/preintegration_residual.h"

// The factories' Jet cost functions are instantiated here once, not in every file that includes
// the header (defined inline there, they cost each includer minutes of compiling).
namespace ctcal::discrete {

ceres::CostFunction* PreintegrationFactor::Create(std::shared_ptr<const Preintegration> pre) {
  return new ceres::AutoDiffCostFunction<PreintegrationFactor, 9, 4, 3, 3, 3, 3, 4, 3, 3, 3>(
      new PreintegrationFactor(std::move(pre)));
}

ceres::CostFunction* ReintegrationFactor::Create(std::shared_ptr<const Preintegration> pre,
                                                 const ImuIntrinsics& intrinsics) {
  auto* cost = new ceres::DynamicAutoDiffCostFunction<ReintegrationFactor, kStride>(
      new ReintegrationFactor(std::move(pre), intrinsics));
  for (const int size : BlockSizes(intrinsics))
    cost->AddParameterBlock(size);
  cost->SetNumResiduals(9);
  return cost;
}

}  // namespace ctcal::discrete
