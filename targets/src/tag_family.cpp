#include "tag_family.h"

extern "C" {
#include <apriltag/tag36h11.h>
}

namespace ctcal::internal {

void TagFamilyDeleter::operator()(apriltag_family_t* family) const {
  if (family != nullptr)
    tag36h11_destroy(family);
}

TagFamilyPtr CreateTag36h11(int black_border) {
  TagFamilyPtr family(tag36h11_create());
  // The stock family has a 1-bit border: width_at_border = 6 + 2, data bits at 1..6. A wider
  // border shifts every data bit inwards and widens the decoded square; the white ring outside
  // (total_width) stays one cell wide. bit_x/bit_y are heap copies owned by this family.
  const int shift = black_border - 1;
  for (uint32_t i = 0; i < family->nbits; ++i) {
    family->bit_x[i] += static_cast<uint32_t>(shift);
    family->bit_y[i] += static_cast<uint32_t>(shift);
  }
  family->width_at_border += 2 * shift;
  family->total_width += 2 * shift;
  return family;
}

const std::vector<uint64_t>& Tag36h11RowMajorCodes() {
  static const std::vector<uint64_t> codes = [] {
    TagFamilyPtr family(tag36h11_create());
    const int n = family->width_at_border - 2;  // data cells per side
    std::vector<uint64_t> out(family->ncodes, 0);
    for (uint32_t id = 0; id < family->ncodes; ++id) {
      for (uint32_t i = 0; i < family->nbits; ++i) {
        const uint64_t bit = (family->codes[id] >> (family->nbits - 1 - i)) & 1u;
        const int cell =
            static_cast<int>(family->bit_y[i] - 1) * n + static_cast<int>(family->bit_x[i] - 1);
        out[id] |= bit << (family->nbits - 1 - static_cast<uint32_t>(cell));
      }
    }
    return out;
  }();
  return codes;
}

}  // namespace ctcal::internal
