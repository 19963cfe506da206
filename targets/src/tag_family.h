// Private: tag36h11 as Kalibr prints it. libapriltag (AprilTag 3) stores each tag36h11 code word in
// the order of its bit_x/bit_y tables (a spiral from the border inwards); Kalibr's generator and
// the AprilTag 2 papers use row-major order from the top-left data cell. Re-ordering AprilTag 3's
// words row-major gives Kalibr's words exactly (id 0: 0xd5d628584), so the ids agree; what
// differs is the border: Kalibr prints 2 black bits around the data, AprilTag 3 expects 1.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

extern "C" {
#include <apriltag/apriltag.h>
}

namespace ctcal::internal {

struct TagFamilyDeleter {
  void operator()(apriltag_family_t* family) const;
};
using TagFamilyPtr = std::unique_ptr<apriltag_family_t, TagFamilyDeleter>;

// tag36h11 with `black_border` (1 or 2) black bits around the 6x6 data: the quad libapriltag
// finds is the outer edge of the black border, so the data cells sit `black_border` cells in.
TagFamilyPtr CreateTag36h11(int black_border);

// All tag36h11 code words, row-major from the top-left data cell, MSB first, 1 = white.
const std::vector<uint64_t>& Tag36h11RowMajorCodes();

}  // namespace ctcal::internal
