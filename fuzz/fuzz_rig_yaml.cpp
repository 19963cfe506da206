// The rig file reader (SPEC section 7) on any bytes: a rig or one std::runtime_error naming the
// file and the key.
#include <stdexcept>

#include "ctcal/sensors/rig_yaml.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = ctcal::fuzz::WriteInput("rig.yaml", data, size);
  try {
    std::vector<std::string> warnings;
    const ctcal::RigConfig rig = ctcal::LoadRig(path, &warnings);
    // What was read must write and read back (the schema's round trip).
    ctcal::ParseRigString(ctcal::EmitRig(rig));
  } catch (const std::runtime_error&) {
  }
  return 0;
}
