// The dataset's CSV readers (SPEC section 6) on any bytes: a reader returns rows or throws
// std::runtime_error naming the file and line; anything else (a crash, a hang, another exception)
// is a finding. The first byte picks the reader.
#include <set>
#include <stdexcept>

#include "ctcal/sensors/dataset.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0)
    return 0;
  const std::string path = ctcal::fuzz::WriteInput("data.csv", data + 1, size - 1);
  ctcal::Warnings warnings;
  const ctcal::InertialRange range;
  const std::set<std::int64_t> stamps{0, 1000, 2000};
  const ctcal::CornerImage image{752, 480, 1.0};
  try {
    switch (data[0] % 8) {
      case 0:
        ctcal::ReadImuCsv(path, &warnings, &range);
        break;
      case 1:
        ctcal::ReadGyroCsv(path, &warnings, &range);
        break;
      case 2:
        ctcal::ReadImageCsv(path, false, &warnings);
        break;
      case 3:
        ctcal::ReadCornersCsv(path, 144);
        break;
      case 4:
        ctcal::ReadCornersCsv(path, 144, &stamps, &image);
        break;
      case 5:
        ctcal::ReadGroundTruthCsv(path);
        break;
      case 6:
        ctcal::ReadBiasesCsv(path, true);
        break;
      default:
        ctcal::ReadBiasesCsv(path, false);
        break;
    }
  } catch (const std::runtime_error&) {
    // The reader's one clear error: what bad input must give.
  }
  return 0;
}
