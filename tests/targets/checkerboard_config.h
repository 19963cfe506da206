// A checkerboard target of rows x cols inner corners (SPEC section 5), for the targets' tests.
#pragma once

#include "ctcal/targets/target_config.h"

namespace ctcal::test {

inline TargetConfig Checkerboard(int rows, int cols, double row_spacing, double col_spacing) {
  TargetConfig t;
  t.type = TargetType::kCheckerboard;
  t.target_rows = rows;
  t.target_cols = cols;
  t.row_spacing_m = row_spacing;
  t.col_spacing_m = col_spacing;
  return t;
}

}  // namespace ctcal::test
