// ROS1 bags on any bytes: first byte even, the rest is a bag file read as `calibrate` reads it;
// odd, one serialized message through the ROS1 decoders.
#include "fuzz_bag_common.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0)
    return 0;
  if (data[0] % 2)
    ctcal::fuzz::DecodeMessage(data + 1, size - 1, ctcal::RosWire::kRos1);
  else
    ctcal::fuzz::LoadBag(ctcal::fuzz::WriteInput("input.bag", data + 1, size - 1));
  return 0;
}
