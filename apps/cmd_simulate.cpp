// `ctcal simulate --scenario NAME --seed N --out DATA [--duration S] [--rig RIG.yaml]
//  [--perturb table4|coarse] [--images] [--bag]` (SPEC section 8, issue 4): wires sim/ to the
//  command
// line. Progress goes to stdout, one error line to stderr.
#include <unistd.h>

#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "cli_common.h"
#include "commands.h"
#include "ctcal/sensors/rig_yaml.h"
#include "ctcal/sim/dataset_bag.h"
#include "ctcal/sim/dataset_writer.h"
#include "ctcal/sim/default_rig.h"
#include "ctcal/sim/image_writer.h"
#include "ctcal/sim/perturb.h"
#include "ctcal/sim/scenario.h"
#include "ctcal/sim/simulator.h"

namespace ctcal::app {
namespace {

std::string ScenarioList() {
  std::string all;
  for (const std::string& n : sim::ScenarioNames())
    all += (all.empty() ? "" : "|") + n;
  return all;
}

// The output folder must exist (or be creatable) and be writable before any work is done.
std::string CheckOutputFolder(const std::string& out) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec || !fs::is_directory(out))
    return "cannot create the output folder '" + out + "'" + (ec ? ": " + ec.message() : "");
  if (::access(out.c_str(), W_OK) != 0)
    return "the output folder '" + out + "' is not writable";
  return "";
}

// A camera file of an earlier run into the same folder that this run would not rewrite, and
// what it would silently do: corners.csv beside rendered images is taken instead of detecting
// them; images and corners_true.csv beside fresh corners.csv belong to another motion. Empty when
// none.
std::string StaleCameraFile(const std::string& out, const RigConfig& rig, bool images) {
  namespace fs = std::filesystem;
  for (const SensorConfig& s : rig.sensors) {
    if (s.type != SensorType::kCamera)
      continue;
    const fs::path dir = fs::path(out) / s.name;
    std::error_code ec;
    if (images && fs::exists(dir / "corners.csv")) {
      return (dir / "corners.csv").string() +
             " is from an earlier run and --images does not rewrite it (calibrate would take it "
             "instead of detecting the new images): remove it or write to a new folder";
    }
    if (!images && (fs::exists(dir / "corners_true.csv") ||
                    (fs::is_directory(dir / "data") && !fs::is_empty(dir / "data", ec)))) {
      return dir.string() +
             " holds an earlier --images run (data/, corners_true.csv) that this run does not "
             "rewrite (detect would use those images): remove them or write to a new folder";
    }
  }
  return "";
}

}  // namespace

int RunSimulate(int argc, char** argv) {
  namespace po = boost::program_options;
  CommandLine cli("simulate",
                  "--scenario NAME --seed N --out DATA [--duration S] [--rig RIG.yaml] "
                  "[--perturb table4|coarse] [--images] [--bag]",
                  "Simulate a visual-inertial rig in front of its board along an analytic "
                  "trajectory and write the dataset (SPEC section 6), its ground truth "
                  "(truth.yaml, groundtruth/, biases.csv) and an initial-guess rig.yaml.");
  std::string scenario_name, out, rig_path, perturb_name;
  std::string seed_text;
  double duration = sim::kDefaultDurationS;
  double dropout = 0.0;
  cli.options().add_options()                                                             //
      ("scenario", po::value(&scenario_name)->required(), ScenarioList().c_str())         //
      ("seed", po::value(&seed_text)->required(), "random seed (same seed, same files)")  //
      ("out", po::value(&out)->required(), "dataset folder to write")                     //
      ("duration", po::value(&duration)->default_value(sim::kDefaultDurationS),           //
       "seconds of base IMU data")                                                        //
      ("rig", po::value(&rig_path),
       "simulate this rig (its values are the truth) "                                //
       "instead of the default MVIS Table 4 rig")                                     //
      ("perturb", po::value(&perturb_name)->default_value("coarse"),                  //
       "initial guesses in rig.yaml: table4 (report's sigmas, with prior_sigma) or "  //
       "coarse (identity intrinsics, 5 deg / 2 cm extrinsics)")                       //
      ("dropout", po::value(&dropout)->default_value(0.0),                            //
       "probability that a visible corner is not detected")                           //
      ("images", po::bool_switch(),
       "render board images (DATA/camN/data/*.png) and write the noise-free corners to "
       "corners_true.csv instead of corners.csv, so that the calibrator detects")(
          "bag", po::bool_switch(),
          "--images, and the same recording as one ROS1 bag DATA/recording.bag (sensor_msgs/Imu, "
          "mono8 sensor_msgs/Image; each sensor's rostopic, /<name> or /<name>/image_raw when the "
          "rig gives none, is written into truth.yaml and rig.yaml)");
  if (const auto exit_code = cli.Parse(argc, argv))
    return *exit_code;

  // Parsed here: Boost would wrap "-1" around to 2^64 - 1.
  std::uint64_t seed = 0;
  const char* seed_end = seed_text.data() + seed_text.size();
  const auto parsed = std::from_chars(seed_text.data(), seed_end, seed);
  if (seed_text.empty() || parsed.ec != std::errc() || parsed.ptr != seed_end)
    return cli.UsageError("--seed must be an integer in [0, 2^64), got '" + seed_text + "'");
  if (!(duration > 0.0) || !std::isfinite(duration) || duration > 24 * 3600.0)
    return cli.UsageError("--duration must be a positive number of seconds (at most a day), got " +
                          std::to_string(duration));
  if (!(dropout >= 0.0 && dropout <= 1.0))
    return cli.UsageError("--dropout must be a probability in [0, 1]");
  sim::Scenario scenario;
  sim::Perturbation perturbation;
  try {
    scenario = sim::ParseScenario(scenario_name);
    perturbation = sim::ParsePerturbation(perturb_name);
  } catch (const std::exception& e) {
    return cli.UsageError(e.what());
  }
  const bool bag = cli.vm()["bag"].as<bool>();
  const bool images = cli.vm()["images"].as<bool>() || bag;

  RigConfig rig;
  try {
    rig = rig_path.empty() ? sim::DefaultRig() : LoadRig(rig_path);
  } catch (const std::exception& e) {
    return cli.InputError(e.what());
  }
  // The bag's topics, in the rig files so that `calibrate --data DATA/recording.bag` finds them.
  for (SensorConfig& s : rig.sensors) {
    if (bag && !s.rostopic)
      s.rostopic = sim::DefaultRosTopic(s);
  }
  if (const std::string why = CheckOutputFolder(out); !why.empty())
    return cli.InputError(why);
  if (const std::string why = StaleCameraFile(out, rig, images); !why.empty())
    return cli.InputError(why);

  const auto start = std::chrono::steady_clock::now();
  std::printf("ctcal simulate: scenario %s, %g s, seed %llu, rig %s -> %s\n", scenario_name.c_str(),
              duration, static_cast<unsigned long long>(seed),
              rig_path.empty() ? "default (MVIS Table 4)" : rig_path.c_str(), out.c_str());
  try {
    const std::unique_ptr<sim::Trajectory> motion =
        sim::MakeTrajectory(scenario, sim::SceneFor(rig.target));
    const sim::RotatedTrajectory traj(*motion, sim::ScenarioMount(rig));

    sim::SimOptions options;
    options.duration = duration;
    options.seed = seed;
    options.corner_dropout = dropout;
    options.progress = [](double fraction, const std::string& what) {
      std::printf("  [%3.0f%%] %s\n", 100.0 * fraction, what.c_str());
      std::fflush(stdout);
    };
    const sim::SimulatedDataset data = sim::Simulate(rig, traj, options);

    sim::Random perturb_rng = sim::Random(seed).Fork(sim::kPerturbationStream);
    const RigConfig guess = sim::PerturbRig(rig, perturbation, perturb_rng);

    sim::WriteOptions write_options;
    write_options.corners_true_only = images;
    sim::WriteDataset(data, guess, out, write_options);
    if (images) {
      std::size_t last_decile = 0;
      sim::RenderImages(data, traj, out, seed, [&](std::size_t done, std::size_t total) {
        const std::size_t decile = 10 * done / total;
        if (decile != last_decile) {
          std::printf("  [%3zu%%] rendered %zu of %zu images\n", 10 * decile, done, total);
          std::fflush(stdout);
          last_decile = decile;
        }
      });
    }
    if (bag) {
      const std::string bag_path = (std::filesystem::path(out) / "recording.bag").string();
      sim::WriteDatasetBag(out, rig, bag_path);
      std::printf("  wrote %s\n", bag_path.c_str());
    }
    for (const sim::InertialData& d : data.inertial)
      std::printf("  %-8s %zu samples\n", d.sensor.c_str(), d.samples.size());
    for (const sim::CameraData& d : data.cameras) {
      std::printf("  %-8s %zu frames, %zu corners (%.1f per frame)\n", d.sensor.c_str(),
                  d.frames_ns.size(), d.corners.size(),
                  d.frames_ns.empty() ? 0.0 : double(d.corners.size()) / d.frames_ns.size());
    }
  } catch (const std::invalid_argument& e) {
    return cli.InputError(e.what());
  } catch (const std::exception& e) {
    return cli.RunFailed(e.what());
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("wrote %s (truth.yaml, rig.yaml with %s guesses, target.yaml) in %.2f s\n",
              out.c_str(), perturb_name.c_str(), seconds);
  return kExitOk;
}

}  // namespace ctcal::app
