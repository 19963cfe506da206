// Subcommands whose issue has not landed yet say so and exit 2. Each moves to its own
// cmd_<name>.cpp when implemented (and is removed from here).
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

int RunSimulate(int argc, char** argv) {
  return NotYet("simulate", argc, argv);
}
int RunDetect(int argc, char** argv) {
  return NotYet("detect", argc, argv);
}
int RunCalibrate(int argc, char** argv) {
  return NotYet("calibrate", argc, argv);
}
int RunCompare(int argc, char** argv) {
  return NotYet("compare", argc, argv);
}
int RunReport(int argc, char** argv) {
  return NotYet("report", argc, argv);
}
int RunMonteCarlo(int argc, char** argv) {
  return NotYet("montecarlo", argc, argv);
}
int RunTarget(int argc, char** argv) {
  return NotYet("target", argc, argv);
}

}  // namespace ctcal::app
