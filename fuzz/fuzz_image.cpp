// The PNG / JPEG reader (image_file.h) on any bytes: it returns an image or throws
// std::runtime_error naming the data; anything else (a crash, a sanitizer report, a hang, another
// exception) is a finding. The first byte picks the path: even, DecodeImage on the bytes in memory;
// odd, ReadImageFile on them written to a file.
#include <stdexcept>

#include "ctcal/targets/image_file.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0)
    return 0;
  try {
    cv::Mat image;
    if (data[0] % 2 == 0) {
      image = ctcal::DecodeImage(data + 1, size - 1, "input");
    } else {
      image = ctcal::ReadImageFile(ctcal::fuzz::WriteInput("image", data + 1, size - 1));
    }
    if (image.empty())
      __builtin_trap();  // success is never an empty image
  } catch (const std::runtime_error&) {
  }
  return 0;
}
