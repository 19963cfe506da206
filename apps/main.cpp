// `ctcal <subcommand> ...`: dispatches to the subcommands of SPEC section 8.
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>

#include "commands.h"
#include "huge_page_heap.h"

namespace {

struct Command {
  const char* name;
  int (*run)(int, char**);
  const char* summary;
};

constexpr Command kCommands[] = {
    {"simulate", ctcal::app::RunSimulate, "simulate a rig and write a dataset with its truth"},
    {"detect", ctcal::app::RunDetect, "detect board corners in a dataset's images"},
    {"calibrate", ctcal::app::RunCalibrate, "calibrate a rig from a dataset"},
    {"compare", ctcal::app::RunCompare, "compare a result with the truth, parameter by parameter"},
    {"crossval", ctcal::app::RunCrossval,
     "compare two results of one rig from different data against their sigmas"},
    {"report", ctcal::app::RunReport, "re-render the report of a finished calibration"},
    {"montecarlo", ctcal::app::RunMonteCarlo, "simulate and calibrate many seeds, test NEES"},
    {"target", ctcal::app::RunTarget, "write a printable board PDF"},
    {"import-kalibr", ctcal::app::RunImportKalibr,
     "turn Kalibr's camchain, imu and target yamls into a rig file"},
};

void PrintUsage(std::FILE* out) {
  std::fprintf(out, "usage: ctcal <command> [options]   (ctcal <command> --help)\n\ncommands:\n");
  for (const Command& c : kCommands)
    std::fprintf(out, "  %-13s %s\n", c.name, c.summary);
  std::fprintf(out, "\n  --version   print the version\n");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    // Bad usage is one line on stderr, like every subcommand's (apps/cli_common.h).
    std::fprintf(stderr, "ctcal: error: no command given (ctcal --help lists them)\n");
    return 2;
  }
  const std::string cmd = argv[1];
  if (cmd == "--help" || cmd == "-h" || cmd == "help") {
    PrintUsage(stdout);
    return 0;
  }
  if (cmd == "--version") {
    std::printf("ctcal %s\n", CTCAL_VERSION);
    return 0;
  }
  // The calibration's heap on huge pages (huge_page_heap.h): its page faults were ~10 % of its
  // CPU. Before anything is allocated that a re-execution would waste.
  if (cmd == "calibrate")
    ctcal::app::ReexecWithHugePageHeap(argv);
  for (const Command& c : kCommands) {
    if (cmd == c.name) {
      try {
        return c.run(argc - 1, argv + 1);
      } catch (const std::exception& e) {
        // Subcommands report their own errors; this is the last line of defence against a crash.
        std::fprintf(stderr, "ctcal %s: error: %s\n", c.name, e.what());
        return 1;
      }
    }
  }
  std::fprintf(stderr, "ctcal: unknown command '%s' (ctcal --help lists them)\n", cmd.c_str());
  return 2;
}
