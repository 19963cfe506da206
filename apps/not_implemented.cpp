// Subcommands whose issue has not landed yet say so and exit 2. The definitions are weak so that a
// cmd_<name>.cpp implementing one replaces it without touching this file while issues land in
// parallel; a stub is deleted here once its command exists. `--help` prints the SPEC section 8
// synopsis and exits 0, like every implemented subcommand.
#include <cstdio>
#include <cstring>

#include "cli_common.h"
#include "commands.h"

namespace ctcal::app {
namespace {

int NotYet(const char* name, const char* synopsis, int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--help") == 0 || std::strcmp(argv[i], "-h") == 0) {
      std::printf("usage: ctcal %s %s\n\nnot implemented yet in this version\n", name, synopsis);
      return kExitOk;
    }
  }
  std::fprintf(stderr, "ctcal %s: error: not implemented yet in this version\n", name);
  return kExitBadInput;
}

}  // namespace

#define CTCAL_STUB __attribute__((weak))

CTCAL_STUB int RunMonteCarlo(int argc, char** argv) {
  return NotYet("montecarlo", "--scenario NAME --runs N --out DIR", argc, argv);
}

}  // namespace ctcal::app
