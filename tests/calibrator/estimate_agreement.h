// Two calibrations of the same data agree: every scalar with a sigma differs from the reference
// by less than `tolerance` of its sigma in `result` (CompareRigs with the reference as the truth).
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "ctcal/sensors/compare.h"

namespace ctcal {

struct Agreement {
  int compared = 0;    // scalars with a sigma
  double worst = 0.0;  // largest |result - reference| / sigma
};

// One gtest failure per scalar beyond the tolerance, naming it.
inline Agreement ExpectAgreement(const RigConfig& reference, const RigConfig& result,
                                 double tolerance) {
  Agreement a;
  for (const ComparisonRow& row : CompareRigs(reference, result).rows) {
    if (!row.error_over_sigma.has_value())
      continue;
    ++a.compared;
    a.worst = std::max(a.worst, std::abs(*row.error_over_sigma));
    EXPECT_LT(std::abs(*row.error_over_sigma), tolerance) << row.name << ": " << row.error;
  }
  return a;
}

}  // namespace ctcal
