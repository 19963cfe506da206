// Speed of the simulator: a 60 s default rig (MVIS Table 4: three inertial sensors, two cameras,
// no images) in memory, and with every file written. The budget is 2 s for the whole
// command.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>

#include "ctcal/sim/dataset_writer.h"
#include "ctcal/sim/default_rig.h"
#include "ctcal/sim/perturb.h"
#include "ctcal/sim/scenario.h"
#include "ctcal/sim/simulator.h"

namespace {

using namespace ctcal;

void BM_SimulateDefaultRig60s(benchmark::State& state) {
  const RigConfig rig = sim::DefaultRig();
  const auto traj = sim::MakeTrajectory(sim::Scenario::kFull, sim::SceneFor(rig.target));
  sim::SimOptions options;
  options.duration = 60.0;
  for (auto _ : state) {
    options.seed += 1;
    const sim::SimulatedDataset data = sim::Simulate(rig, *traj, options);
    benchmark::DoNotOptimize(data.cameras.back().corners.size());
  }
}
BENCHMARK(BM_SimulateDefaultRig60s)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_SimulateAndWriteDefaultRig60s(benchmark::State& state) {
  const RigConfig rig = sim::DefaultRig();
  const auto traj = sim::MakeTrajectory(sim::Scenario::kFull, sim::SceneFor(rig.target));
  const std::string dir =
      (std::filesystem::temp_directory_path() / "ctcal_bench_simulate").string();
  sim::SimOptions options;
  options.duration = 60.0;
  for (auto _ : state) {
    options.seed += 1;
    const sim::SimulatedDataset data = sim::Simulate(rig, *traj, options);
    sim::Random rng(options.seed);
    const RigConfig guess = sim::PerturbRig(rig, sim::Perturbation::kTable4, rng);
    sim::WriteDataset(data, guess, dir);
  }
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_SimulateAndWriteDefaultRig60s)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
