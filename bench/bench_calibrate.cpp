// End-to-end speed of `ctcal calibrate --method spline` (CalibrateSpline, covariance included) on
// the default rig: compressed per-frame camera blocks vs one block per corner, analytic vs
// autodiff Jacobians, 1 vs 2 threads; and of `--method discrete` against it (BM_Methods). Counters:
// LM iterations, seconds per iteration (wall), initialisation (coarse init, board views, data
// selection), solve, covariance and total seconds (wall); the benchmark's
// own time is wall time (UseRealTime) and process CPU time over all threads
// (MeasureProcessCPUTime).
//
// Data: CTCAL_BENCH_DATA=<folder written by `ctcal simulate`> (e.g. the demo's 60 s rig), else
// a `full` scenario of CTCAL_BENCH_DURATION seconds (default 20, seed 2024, table4 guesses) is
// simulated into a temporary folder first. BM_LongRecordingMemory: peak memory and CPU of 10 min of
// 1 kHz IMU and 2 cameras (run it alone; docs/performance.md, step 7).
#include <benchmark/benchmark.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <string>

#include "ctcal/calibrator/discrete_calibrator.h"
#include "ctcal/calibrator/memory_usage.h"
#include "ctcal/calibrator/spline_calibrator.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig_yaml.h"
#include "ctcal/sim/dataset_writer.h"
#include "ctcal/sim/default_rig.h"
#include "ctcal/sim/perturb.h"
#include "ctcal/sim/scenario.h"
#include "ctcal/sim/simulator.h"

namespace {

using namespace ctcal;

struct BenchData {
  RigConfig rig;
  std::map<std::string, SensorData> data;
};

// `ctcal simulate --rig <truth> --scenario full --seed <seed> --duration <duration> --perturb
// table4 --out <dir>`.
void SimulateInto(const std::string& dir, const RigConfig& truth, double duration, int seed) {
  std::filesystem::remove_all(dir);
  const auto motion = sim::MakeTrajectory(sim::Scenario::kFull, sim::SceneFor(truth.target));
  const sim::RotatedTrajectory traj(*motion, sim::ScenarioMount(truth));
  sim::SimOptions options;
  options.duration = duration;
  options.seed = static_cast<std::uint64_t>(seed);
  const sim::SimulatedDataset sim_data = sim::Simulate(truth, traj, options);
  sim::Random rng = sim::Random(static_cast<std::uint64_t>(seed)).Fork(sim::kPerturbationStream);
  sim::WriteDataset(sim_data, sim::PerturbRig(truth, sim::Perturbation::kTable4, rng), dir,
                    sim::WriteOptions());
  std::fprintf(stderr, "bench_calibrate: simulated %.0f s into %s\n", duration, dir.c_str());
}

const BenchData& Data() {
  static const std::unique_ptr<BenchData> data = [] {
    std::string dir;
    if (const char* env = std::getenv("CTCAL_BENCH_DATA")) {
      dir = env;
    } else {
      const char* d = std::getenv("CTCAL_BENCH_DURATION");
      dir = (std::filesystem::temp_directory_path() / "ctcal_bench_calibrate").string();
      SimulateInto(dir, sim::DefaultRig(), d != nullptr ? std::atof(d) : 20.0, 2024);
    }
    auto out = std::make_unique<BenchData>();
    out->rig = LoadRig(dir + "/rig.yaml");
    out->data = LoadDataset(dir, out->rig);
    return out;
  }();
  return *data;
}

// The calibrator's log on stderr when CTCAL_BENCH_LOG is set (the per-stage times), else silent.
CalibrationLog BenchLog() {
  if (std::getenv("CTCAL_BENCH_LOG") == nullptr)
    return [](const std::string&) {};
  return [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
}

// The run's LM iterations, stage times (wall) and knots as counters.
void SetRunCounters(const SplineCalibrationResult& result, benchmark::State* state) {
  state->counters["iterations"] = result.iterations;
  state->counters["s_per_iteration"] = result.seconds_per_iteration;
  state->counters["init_s"] = result.init_seconds;
  state->counters["solve_s"] = result.solve_seconds;
  state->counters["covariance_s"] = result.covariance_seconds;
  state->counters["total_s"] = result.total_seconds;
  state->counters["knots"] = result.num_knots;
}

// args: threads, compressed (0/1), analytic (0/1), inertial run length K (0: the sensor-rate
// rule of InertialBlockSegments, -1: one block per sample, K > 0: compressed runs of K segments),
// stacked: the run length of the uncompressed inertial blocks where the rule does not compress
// (0: one block per sample there; SplineCalibratorOptions::stacked_inertial_segments),
// robust_stop: SplineCalibratorOptions::robust_early_stop (0/1).
void BM_Calibrate(benchmark::State& state) {
  const BenchData& d = Data();
  SplineCalibratorOptions options;
  options.threads = static_cast<int>(state.range(0));
  options.compress_frames = state.range(1) != 0;
  options.analytic = state.range(2) != 0;
  options.compress_inertial = state.range(3) >= 0;
  options.inertial_block_segments = static_cast<int>(std::max<std::int64_t>(0, state.range(3)));
  options.stacked_inertial_segments = static_cast<int>(state.range(4));
  options.robust_early_stop = state.range(5) != 0;
  SplineCalibrationResult result;
  for (auto _ : state) {
    result = CalibrateSpline(d.rig, d.data, options, BenchLog());
    benchmark::DoNotOptimize(result.result.solver);
  }
  SetRunCounters(result, &state);
}
BENCHMARK(BM_Calibrate)
    ->ArgNames({"threads", "per_frame", "analytic", "inertial_K", "stacked", "robust_stop"})
    ->Args({2, 1, 1, 0, 1, 1})
    ->Args({2, 1, 1, 0, 0, 0})
    ->Args({2, 1, 1, 0, 1, 0})
    ->Args({2, 1, 1, 0, 2, 1})
    ->Args({2, 1, 1, 1, 1, 1})
    ->Args({2, 1, 1, 4, 1, 1})
    ->Args({1, 1, 1, 0, 1, 1})
    ->Args({2, 0, 1, 0, 1, 1})
    ->Args({1, 0, 1, 0, 1, 1})
    ->Args({2, 0, 0, 0, 1, 1})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime()
    ->MeasureProcessCPUTime();

// Peak memory and CPU of a long recording: the default rig with the base IMU at 1 kHz and the
// auxiliary IMU and gyroscope removed, 2 cameras, 600 s (CTCAL_BENCH_LONG_DURATION), seed 7,
// table4 guesses; calibrated as `ctcal calibrate` does (data loaded, then taken over by
// CalibrateSpline, report data included; the report's rendering is not). The data are simulated
// by a child process (its memory is not this process') into a temporary folder, unless
// CTCAL_BENCH_LONG_DATA names a folder `ctcal simulate` wrote. peak_rss_mb is the process' peak
// (getrusage), so run each case alone (one --benchmark_filter per process):
//   build/bench/bench_calibrate
//   --benchmark_filter='BM_LongRecordingMemory/inertial_K:0/row_groups:1'
// arg inertial_K: the base IMU's run length (0: the rule of InertialBlockSegments); row_groups:
// SplineCalibratorOptions::split_inertial_rows (docs/performance.md step 7g).
void BM_LongRecordingMemory(benchmark::State& state) {
  std::string dir;
  if (const char* env = std::getenv("CTCAL_BENCH_LONG_DATA")) {
    dir = env;
  } else {
    const char* d = std::getenv("CTCAL_BENCH_LONG_DURATION");
    const double duration = d != nullptr ? std::atof(d) : 600.0;
    dir = (std::filesystem::temp_directory_path() /
           ("ctcal_bench_long_" + std::to_string(static_cast<int>(duration))))
              .string();
    RigConfig truth = sim::DefaultRig();
    truth.Find(truth.base_imu)->noise.update_rate = 1000.0;
    truth.sensors.erase(std::remove_if(truth.sensors.begin(), truth.sensors.end(),
                                       [&](const SensorConfig& s) {
                                         return s.IsInertial() && s.name != truth.base_imu;
                                       }),
                        truth.sensors.end());
    const pid_t child = fork();
    if (child == 0) {
      SimulateInto(dir, truth, duration, 7);
      std::_Exit(0);
    }
    int status = 0;
    if (child < 0 || waitpid(child, &status, 0) != child || !WIFEXITED(status) ||
        WEXITSTATUS(status) != 0) {
      state.SkipWithError("simulating the long recording failed");
      return;
    }
  }
  SplineCalibratorOptions options;
  options.threads = 2;
  options.inertial_block_segments = static_cast<int>(state.range(0));
  options.split_inertial_rows = state.range(1) != 0;
  SplineCalibrationResult result;
  for (auto _ : state) {
    const RigConfig rig = LoadRig(dir + "/rig.yaml");
    result = CalibrateSpline(rig, LoadDataset(dir, rig), options, BenchLog());
    benchmark::DoNotOptimize(result.result.solver);
  }
  state.counters["peak_rss_mb"] = CurrentMemoryUsage().peak_mb;
  SetRunCounters(result, &state);
}
BENCHMARK(BM_LongRecordingMemory)
    ->ArgNames({"inertial_K", "row_groups"})
    ->Args({0, 1})
    ->Args({0, 0})
    ->Args({5, 1})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime()
    ->MeasureProcessCPUTime();

// The discrete method (CalibrateDiscrete, covariance included) against the spline method on the
// same data, with the inertial sensors' intrinsics estimated as the rig file says (the base IMU's
// factor then re-integrates its samples at every evaluation, eq. 37) or fixed at the rig file's
// values (`estimate:` without intrinsics on every imu and gyro: bias-linearised factor, eq. 36).
// args: method (0 spline, 1 discrete), imu_intrinsics (0/1), threads.
void BM_Methods(benchmark::State& state) {
  const BenchData& d = Data();
  RigConfig rig = d.rig;
  if (state.range(1) == 0) {
    for (SensorConfig& s : rig.sensors) {
      if (s.type != SensorType::kCamera)
        s.estimate.erase(EstimateItem::kIntrinsics);
    }
  }
  const int threads = static_cast<int>(state.range(2));
  SplineCalibrationResult result;
  for (auto _ : state) {
    if (state.range(0) == 0) {
      SplineCalibratorOptions options;
      options.threads = threads;
      result = CalibrateSpline(rig, d.data, options, BenchLog());
    } else {
      DiscreteCalibratorOptions options;
      options.threads = threads;
      result = CalibrateDiscrete(rig, d.data, options, BenchLog());
    }
    benchmark::DoNotOptimize(result.result.solver);
  }
  state.counters["iterations"] = result.iterations;
  state.counters["s_per_iteration"] = result.seconds_per_iteration;
  state.counters["solve_s"] = result.solve_seconds;
  state.counters["covariance_s"] = result.covariance_seconds;
  state.counters["total_s"] = result.total_seconds;
}
BENCHMARK(BM_Methods)
    ->ArgNames({"discrete", "imu_intrinsics", "threads"})
    ->Args({0, 1, 2})
    ->Args({1, 1, 2})
    ->Args({0, 0, 2})
    ->Args({1, 0, 2})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime()
    ->MeasureProcessCPUTime();

}  // namespace

BENCHMARK_MAIN();
