// A simulated recording of the default rig with table4 guesses, in memory: the measurements,
// truth and guess that `ctcal simulate --scenario S --seed N --duration D --perturb table4`
// writes (the same perturbation stream), for calibration tests that need no files.
#pragma once

#include <cstdint>
#include <map>
#include <string>

#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig.h"
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

inline SimulatedRecording SimulateTable4(sim::Scenario scenario, double duration,
                                         std::uint64_t seed) {
  const RigConfig rig = sim::DefaultRig();
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
