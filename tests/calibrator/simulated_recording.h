// Simulated recordings of the default rig for the calibration tests: in memory
// (SimulateTable4, the measurements, truth and guess that `ctcal simulate --scenario S --seed N
// --duration D --perturb table4` writes, for tests that need no files), or written by `ctcal
// simulate` itself (the path users take) and loaded back, with a quiet log and the one error bad
// input must give.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>

#include "ctcal/calibrator/spline_calibrator.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig.h"
#include "ctcal/sensors/rig_yaml.h"
#include "ctcal/sim/dataset_writer.h"
#include "ctcal/sim/default_rig.h"
#include "ctcal/sim/perturb.h"
#include "ctcal/sim/scenario.h"
#include "ctcal/sim/simulator.h"

namespace ctcal {

struct SimulatedRecording {
  RigConfig truth;
  RigConfig guess;  // table4, with its prior_sigma
  std::map<std::string, SensorData> data;
};

// `rig` (the truth's parameters) simulated, with table4 guesses; the default rig unless given.
inline SimulatedRecording SimulateTable4(sim::Scenario scenario, double duration,
                                         std::uint64_t seed,
                                         const RigConfig& rig = sim::DefaultRig()) {
  const auto motion = sim::MakeTrajectory(scenario, sim::SceneFor(rig.target));
  const sim::RotatedTrajectory traj(*motion, sim::ScenarioMount(rig));
  sim::SimOptions options;
  options.duration = duration;
  options.seed = seed;
  const sim::SimulatedDataset data = sim::Simulate(rig, traj, options);
  sim::Random rng = sim::Random(seed).Fork(sim::kPerturbationStream);
  return {data.truth, sim::PerturbRig(rig, sim::Perturbation::kTable4, rng),
          sim::ToSensorData(data)};
}

}  // namespace ctcal

namespace ctcal::test {

// Runs `ctcal simulate <args> --out DIR` with DIR = <gtest's temp dir>/<name> unless DIR already
// holds a truth.yaml (so once per name); returns DIR. The recording is simulated into a folder of
// this process' own and renamed to DIR, which is atomic: tests that ask for the same name at once
// (ctest runs each test as a process, two at a time) never read a recording another is still
// writing (one read a camera's 40 of 320 frames); the one whose rename finds DIR there removes its
// copy.
inline std::string SimulateOnce(const std::string& name, const std::string& args) {
  namespace fs = std::filesystem;
  const std::string dir = (fs::path(::testing::TempDir()) / name).string();
  if (!fs::exists(dir + "/truth.yaml")) {
    const std::string part = dir + ".part" + std::to_string(::getpid());
    fs::remove_all(part);
    const std::string cmd =
        std::string(CTCAL_BINARY) + " simulate " + args + " --out " + part + " > /dev/null";
    EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
    std::error_code ec;
    fs::rename(part, dir, ec);
    if (ec)
      fs::remove_all(part);
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
