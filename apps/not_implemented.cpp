// Subcommands whose issue has not landed yet say so and exit 2. The definitions are weak so that a
// cmd_<name>.cpp implementing one replaces it without touching this file while issues land in
// parallel; a stub is deleted here once its command exists.
#include <cstdio>
#include <cstring>

#include "commands.h"

namespace ctcal::app {
namespace {

int NotYet(const char* name, int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--help") == 0) {
      std::printf("ctcal %s: not implemented yet in this version\n", name);
      return 0;
    }
  }
  std::fprintf(stderr, "ctcal %s: not implemented yet in this version\n", name);
  return 2;
}

}  // namespace

#define CTCAL_STUB __attribute__((weak))

CTCAL_STUB int RunSimulate(int argc, char** argv) {
  return NotYet("simulate", argc, argv);
}
CTCAL_STUB int RunDetect(int argc, char** argv) {
  return NotYet("detect", argc, argv);
}
CTCAL_STUB int RunCalibrate(int argc, char** argv) {
  return NotYet("calibrate", argc, argv);
}
CTCAL_STUB int RunCompare(int argc, char** argv) {
  return NotYet("compare", argc, argv);
}
CTCAL_STUB int RunReport(int argc, char** argv) {
  return NotYet("report", argc, argv);
}
CTCAL_STUB int RunMonteCarlo(int argc, char** argv) {
  return NotYet("montecarlo", argc, argv);
}
CTCAL_STUB int RunTarget(int argc, char** argv) {
  return NotYet("target", argc, argv);
}

}  // namespace ctcal::app
