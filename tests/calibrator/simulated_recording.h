// Shared by the calibrator tests that start from a recording written by `ctcal simulate` (the
// path users take): simulate once, load the guess, the truth and the data, keep the solver quiet,
// and catch the one error bad input must give.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>

#include "ctcal/calibrator/spline_calibrator.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal::test {

// Runs `ctcal simulate <args> --out DIR` with DIR = <gtest's temp dir>/<name> unless DIR already
// holds a truth.yaml (so once per name); returns DIR.
inline std::string SimulateOnce(const std::string& name, const std::string& args) {
  const std::string dir = (std::filesystem::path(::testing::TempDir()) / name).string();
  if (!std::filesystem::exists(dir + "/truth.yaml")) {
    const std::string cmd =
        std::string(CTCAL_BINARY) + " simulate " + args + " --out " + dir + " > /dev/null";
    EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  }
  return dir;
}

// The arguments of the default rig's `full` scenario with table4 guesses.
inline std::string FullTable4Args(int seed, double duration) {
  return "--scenario full --seed " + std::to_string(seed) + " --duration " +
         std::to_string(duration) + " --perturb table4";
}

// What `ctcal calibrate` reads from a simulated recording, and the truth it is checked against.
struct Recording {
  RigConfig rig;  // the initial guess
  RigConfig truth;
  std::map<std::string, SensorData> data;
};

inline Recording LoadRecording(const std::string& dir) {
  Recording r;
  std::vector<std::string> warnings;
  r.rig = LoadRig(dir + "/rig.yaml", &warnings);
  r.truth = LoadRig(dir + "/truth.yaml", &warnings);
  r.data = LoadDataset(dir, r.rig, &warnings);
  return r;
}

inline CalibrationLog Quiet() {
  return [](const std::string&) {};
}

// The message of the CalibrationInputError that f() throws; "" when it throws none.
template <class F>
std::string InputErrorOf(F&& f) {
  try {
    f();
  } catch (const CalibrationInputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace ctcal::test
