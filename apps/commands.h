// One function per `ctcal` subcommand (SPEC section 8), each in its own cmd_<name>.cpp. argv[0]
// is the subcommand name. Each returns 0 on success, 1 on a failed run, 2 on bad usage/input, and
// prints exactly one clear line on stderr for bad input.
#pragma once

namespace ctcal::app {

int RunSimulate(int argc, char** argv);
int RunDetect(int argc, char** argv);
int RunCalibrate(int argc, char** argv);
int RunCompare(int argc, char** argv);
int RunCrossval(int argc, char** argv);
// `ctcal compare --projection ...` (cmd_compare_projection.cpp): two lens fits' projection
// difference; RunCompare hands over when argv holds --projection.
int RunCompareProjection(int argc, char** argv);
int RunReport(int argc, char** argv);
int RunMonteCarlo(int argc, char** argv);
int RunTarget(int argc, char** argv);
int RunImportKalibr(int argc, char** argv);

}  // namespace ctcal::app
