// `ctcal calibrate --rig RIG.yaml --data DATA --out OUT [--method spline|discrete|both]
// [--threads N]` (SPEC section 8): loads the rig and the dataset, runs the continuous-time
// calibrator (calibrator/spline_calibrator.h), the discrete one (discrete_calibrator.h) or both
// with a cross-check, and writes OUT/result.yaml, the Kalibr files, OUT/log.txt and the report
// (OUT/report_data/, OUT/report.html, OUT/report.pdf; calibrate_report.h; every method).
// `both` writes OUT/spline/, OUT/discrete/ and OUT/crosscheck.yaml. The exit code is the
// report's verdict (SPEC section 8): 3 when one of its checks failed (calibrate_report.h).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "calibrate_report.h"
#include "cli_common.h"
#include "commands.h"
#include "ctcal/calibrator/camera_only/camera_only_calibrator.h"
#include "ctcal/calibrator/cross_validation.h"
#include "ctcal/calibrator/discrete/crosscheck.h"
#include "ctcal/calibrator/discrete_calibrator.h"
#include "ctcal/calibrator/init/bag_detection.h"
#include "ctcal/calibrator/init/board_order.h"
#include "ctcal/calibrator/init/corner_detection.h"
#include "ctcal/calibrator/spline_calibrator.h"
#include "ctcal/report/stage_time.h"
#include "ctcal/sensors/bag_dataset.h"
#include "ctcal/sensors/camera_model.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/ecosystem_exports.h"
#include "ctcal/sensors/euroc_folder.h"
#include "ctcal/sensors/kalibr_files.h"
#include "ctcal/sensors/rig_yaml.h"
#include "ctcal/targets/target_config.h"
#include "huge_page_heap.h"

namespace ctcal::app {

namespace {

// Kalibr's files and the exports for basalt and OpenVINS beside result.yaml (docs/files.md); what
// a format cannot hold is logged, one line each.
void SaveFilesForOtherPrograms(const RigConfig& rig, const std::string& dir,
                               const CalibrationLog& log) {
  std::vector<std::string> notes;
  SaveKalibrFiles(rig, dir, {}, &notes);
  SaveEcosystemExports(rig, dir, &notes);
  for (const std::string& note : notes)
    log("exports: " + note);
}

// The rig: the rig file; or, without one, the guesses of DATA's sensor.yaml files (EuRoC /
// TUM-VI), with the target of --target. A rig file beside sensor.yaml files is cross-checked
// against them (warnings; the rig file wins).
RigConfig LoadRigOrEurocGuess(const std::string& rig_path, const std::string& target_path,
                              const std::string& data_dir, std::vector<std::string>* warnings) {
  if (!rig_path.empty()) {
    if (!target_path.empty())
      throw std::runtime_error(
          "--target is for a DATA folder without --rig (the rig file has "
          "its target)");
    RigConfig rig = LoadRig(rig_path, warnings);
    if (HasEurocSensorYamls(data_dir)) {
      for (const std::string& w : CrossCheckEurocFolder(data_dir, rig))
        warnings->push_back(w);
    }
    return rig;
  }
  if (target_path.empty())
    throw std::runtime_error(
        "give --rig RIG.yaml, or --target TARGET.yaml for a DATA folder "
        "with sensor.yaml files (EuRoC / TUM-VI)");
  if (!HasEurocSensorYamls(data_dir))
    throw std::runtime_error(data_dir +
                             ": no --rig and no <sensor>/sensor.yaml files to take "
                             "the initial guesses from");
  return RigFromEurocFolder(data_dir, LoadTargetConfig(target_path), warnings);
}

// A rig without IMUs is a camera calibration (SPEC section 7): per-frame board poses instead of a
// trajectory spline, and Kalibr's camchain.yaml beside the result.
int RunCameraOnly(CommandLine& cli, const RigConfig& rig,
                  const std::map<std::string, SensorData>& data, const std::string& out_dir,
                  const CalibrationLog& log, std::ofstream& log_file,
                  const report::RunInfo& run_info, int threads, bool per_corner_blocks,
                  report::StageClock* clock, const report::StageTime& detection) {
  CameraOnlyResult result;
  std::ostringstream stages;
  CameraOnlyOptions options;
  options.num_threads = threads;
  options.per_corner_blocks = per_corner_blocks;
  try {
    result = CalibrateCameraOnly(rig, data, options, stages);
  } catch (const std::exception& e) {
    log(stages.str());
    log_file << "error: " << e.what() << '\n';
    return cli.InputError(e.what());
  }
  log(stages.str());
  const report::StageTime calibration = clock->Lap("calibration");
  try {
    SaveRig(result.rig, out_dir + "/result.yaml");
    SaveFilesForOtherPrograms(result.rig, out_dir, log);
  } catch (const std::exception& e) {
    return cli.RunFailed(e.what());
  }
  log(FormatParameterTable(result.rig));
  log("wrote " + out_dir + "/result.yaml, camchain.yaml, log.txt and the exports");
  log("time: " + report::FormatStageTime(detection) + ", " + report::FormatStageTime(calibration) +
      ", " + report::FormatStageTime(clock->Lap("results")));
  return ExitCodeOfChecks(
      {WriteCalibrationReport(out_dir, std::move(result.report_data), run_info, log, threads)},
      log);
}

// Writes one full result (result.yaml, Kalibr files) into `dir` and prints its table.
void WriteResult(const SplineCalibrationResult& result, const std::string& dir,
                 const CalibrationLog& log) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  SaveRig(result.result, dir + "/result.yaml");
  SaveFilesForOtherPrograms(result.result, dir, log);
  log("");
  log(FormatParameterTable(result.result));
  char line[200];
  std::snprintf(line, sizeof line,
                "done: %d iterations, %.2f s solving (%.3f s per iteration), %.2f s covariance, "
                "%.2f s total",
                result.iterations, result.solve_seconds, result.seconds_per_iteration,
                result.covariance_seconds, result.total_seconds);
  log(line);
  log("wrote " + dir + "/result.yaml, camchain-imucam.yaml, imu.yaml and the exports");
}

// Runs a calibration; bad input exits with the input-error code, any other failure with the
// run-failed code, each logged to OUT/log.txt. Returns std::nullopt when `calibrate` succeeded.
template <class F>
std::optional<int> Guarded(CommandLine& cli, std::ofstream& log_file, F&& calibrate) {
  try {
    calibrate();
  } catch (const CalibrationInputError& e) {
    log_file << "error: " << e.what() << '\n';
    return cli.InputError(e.what());
  } catch (const std::exception& e) {
    log_file << "error: " << e.what() << '\n';
    return cli.RunFailed(e.what());
  }
  return std::nullopt;
}

// --method discrete | both (docs/discrete.md): `both` writes OUT/spline/, OUT/discrete/ and
// OUT/crosscheck.yaml. Every result folder gets its report; with `both` each folder also keeps a
// copy of crosscheck.yaml, so that its report (and `ctcal report --out OUT/spline`) shows the
// cross-check table. Returns the exit code.
int RunDiscreteOrBoth(CommandLine& cli, const std::string& method, const RigConfig& rig,
                      const std::map<std::string, SensorData>& data,
                      const SplineCalibratorOptions& spline_options,
                      const DiscreteCalibratorOptions& discrete_options, const std::string& out_dir,
                      const CalibrationLog& log, std::ofstream& log_file,
                      const report::RunInfo& run_info) {
  SplineCalibrationResult spline;
  DiscreteCalibrationResult discrete;
  if (const auto failed = Guarded(cli, log_file, [&] {
        if (method == "both") {
          log("=== spline ===");
          spline = CalibrateSpline(rig, data, spline_options, log);
          log("=== discrete ===");
        }
        discrete = CalibrateDiscrete(rig, data, discrete_options, log);
      }))
    return *failed;
  try {
    if (method == "discrete") {
      WriteResult(discrete, out_dir, log);
      return ExitCodeOfChecks({WriteCalibrationReport(out_dir, std::move(discrete.report_data),
                                                      run_info, log, spline_options.threads)},
                              log);
    }
    WriteResult(spline, out_dir + "/spline", log);
    WriteResult(discrete, out_dir + "/discrete", log);
    const CrossCheck check = MakeCrossCheck(spline.result, discrete.result);
    SaveCrossCheck(check, out_dir + "/crosscheck.yaml");
    log("");
    log("cross-check (discrete - spline; flagged: |difference| > the smaller sigma)");
    log(FormatCrossCheck(check));
    log("wrote " + out_dir + "/crosscheck.yaml");
    for (const char* sub : {"/spline", "/discrete"})
      std::filesystem::copy_file(out_dir + "/crosscheck.yaml", out_dir + sub + "/crosscheck.yaml",
                                 std::filesystem::copy_options::overwrite_existing);
  } catch (const std::exception& e) {
    return cli.RunFailed(e.what());
  }
  std::vector<CalibrationVerdict> verdicts;
  verdicts.push_back(WriteCalibrationReport(out_dir + "/spline", std::move(spline.report_data),
                                            run_info, log, spline_options.threads));
  verdicts.push_back(WriteCalibrationReport(out_dir + "/discrete", std::move(discrete.report_data),
                                            run_info, log, spline_options.threads));
  return ExitCodeOfChecks(verdicts, log);
}

// Cross-validation of a finished spline calibration (docs/cross_validation.md): the subsets
// calibrated, their results kept in OUT/crossval/ for the report, the model error of the groups
// whose subsets disagree added to the result's sigma (sigma_formal keeps the formal one).
void CrossValidateResult(const SubsetSplit& split, const SplineCalibratorOptions& options,
                         const std::string& out_dir, const CalibrationLog& log, RigConfig* result) {
  log("");
  log("=== cross-validation ===");
  const CalibrationCrossValidation xv = CrossValidateSubsets(*result, split, options, log);
  log(FormatCalibrationCrossValidation(xv));
  if (!xv.ran)
    return;
  const std::string dir = out_dir + "/crossval";
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  for (std::size_t k = 0; k < xv.subsets.size(); ++k)
    SaveRig(xv.subsets[k], dir + "/subset_" + std::to_string(k + 1) + ".yaml");
  const int inflated = ApplyModelError(xv.versus_full, result);
  log(inflated == 0
          ? "cross-validation: the subsets agree within their sigmas; sigma is the "
            "formal one"
          : "cross-validation: model error added to the sigma of " + std::to_string(inflated) +
                " parameters (sigma_formal: in result.yaml keeps the formal one)");
  log("wrote " + dir + "/subset_*.yaml");
}

}  // namespace

int RunCalibrate(int argc, char** argv) {
  namespace po = boost::program_options;
  CommandLine cli("calibrate",
                  "--rig RIG.yaml | --target TARGET.yaml --data DATA --out OUT "
                  "[--method spline|discrete|both] [--threads N] [--autodiff]",
                  "Calibrate a visual-inertial rig from a recording of a target board: every "
                  "estimated intrinsic, extrinsic and time offset with its sigma. Exit code 0: "
                  "every check of the report passed; 3: the result and report are written but a "
                  "check failed (each named on stderr); 1: the run failed; 2: bad input.");
  std::string rig_path, target_path, data_dir, out_dir, method, representation, init_policy,
      aux_velocity, split_frame_rows, noise_policy;
  SplineCalibratorOptions options;
  DiscreteCalibratorOptions discrete_options;
  CrossValidationOptions xv_options;
  cli.options().add_options()(
      "rig", po::value(&rig_path),
      "rig file with initial guesses (SPEC section 7); without it, DATA's sensor.yaml files "
      "(EuRoC / TUM-VI mav0/) give them, with --target")(
      "target", po::value(&target_path),
      "Kalibr target yaml, for a DATA folder with sensor.yaml files and no --rig")(
      "data", po::value(&data_dir)->required(),
      "dataset folder (SPEC section 6), or a ROS bag (X.bag, a ROS2 bag's folder or .db3; each "
      "sensor's rostopic: names its topic); a camera with images but no corners.csv is detected "
      "first, its corners written to OUT/<camera>/corners.csv")(
      "out", po::value(&out_dir)->required(), "output folder")(
      "method", po::value(&method)->default_value("spline"),
      "spline, discrete (MVIS keyframes) or both (and a cross-check)")(
      "aux-velocity", po::value(&aux_velocity)->default_value("state"),
      "discrete: auxiliary IMU velocity as a state or rigid (appendix B)")(
      "keyframe-rate", po::value(&discrete_options.keyframe_rate_hz)->default_value(0.0),
      "discrete: keyframe rate in Hz (0: the camera frame times)")(
      "threads", po::value(&options.threads)->default_value(0), "solver threads (0: all cores)")(
      "no-track", po::bool_switch(),
      "detect the board in every image on its own instead of tracking it through each camera's "
      "images (docs/targets.md)")("autodiff", po::bool_switch(),
                                  "residual Jacobians by automatic differentiation")(
      "per-corner-blocks", po::bool_switch(),
      "one residual block per corner instead of one compressed block per global-shutter frame "
      "(slower; for benchmarks)")(
      "split-frame-rows", po::value(&split_frame_rows)->default_value("auto"),
      ("a compressed frame as two blocks, its pose rows and its intrinsic rows: auto (cameras "
       "with more than " +
       std::to_string(SplineCalibratorOptions::kSplitFrameRowsAbove) +
       " views, where it saves memory), on, off (for benchmarks and tests)")
          .c_str())("order", po::value(&options.order)->default_value(4),
                    "trajectory spline order: 4, 5, 6")(
      "representation", po::value(&representation)->default_value("split"),
      "trajectory spline: split (SO3 x R3) or joint (SE3)")(
      "knot-spacing", po::value(&options.knot_spacing_s)->default_value(0.0),
      "trajectory knot spacing in s (0: from the motion's bandwidth)")(
      "bias-knot-spacing", po::value(&options.bias_knot_spacing_s)->default_value(1.0),
      "bias spline knot spacing in s")(
      "init", po::value(&init_policy)->default_value("beyond-prior"),
      "coarse-guess initialisation (docs/initialisation.md): beyond-prior (replace guesses "
      "without prior_sigma, and those the data contradict), always, off")(
      "max-iterations", po::value(&options.max_iterations)->default_value(50),
      "Levenberg-Marquardt iterations per solve")(
      "noise", po::value(&noise_policy)->default_value("stated"),
      "spline: estimate (every sensor's noise from the data, the stated noise the start; "
      "docs/noise_estimation.md) or stated (the rig file's noise weighs everything)")(
      "frame-weights", po::value(&options.frame_weight_prior)->default_value(10.0),
      "with --noise estimate: each camera frame's own noise level, shrunk toward the camera's "
      "by this many pseudo-residuals (0: one level per camera)")(
      "cross-validate", po::bool_switch(),
      "cross-validate between subsets of the recording (the default where the recording allows; "
      "docs/cross_validation.md): sigma then adds the model error the subsets' disagreement "
      "shows")("no-cross-validate", po::bool_switch(),
               "no cross-validation: sigma is the formal one")(
      "subsets", po::value(&xv_options.subsets)->default_value(2),
      "cross-validation: number of interleaved subsets K >= 2")(
      "subset-block", po::value(&xv_options.block_seconds)->default_value(4.0),
      "cross-validation: length in s of the blocks dealt to the subsets in turn");
  if (const auto exit_code = cli.Parse(argc, argv))
    return *exit_code;
  options.analytic = !cli.vm()["autodiff"].as<bool>();
  if (cli.vm()["cross-validate"].as<bool>() && cli.vm()["no-cross-validate"].as<bool>())
    return cli.UsageError("--cross-validate and --no-cross-validate exclude each other");
  xv_options.enabled = !cli.vm()["no-cross-validate"].as<bool>();
  if (xv_options.subsets < 2)
    return cli.UsageError("--subsets must be >= 2, got " + std::to_string(xv_options.subsets));
  if (!(xv_options.block_seconds >= 0.5 && std::isfinite(xv_options.block_seconds)))
    return cli.UsageError("--subset-block must be >= 0.5 s");
  options.compress_frames = !cli.vm()["per-corner-blocks"].as<bool>();
  if (method != "spline" && method != "discrete" && method != "both")
    return cli.UsageError("--method must be spline, discrete or both, got " + method);
  if (aux_velocity == "state")
    discrete_options.aux_velocity = AuxVelocityModel::kState;
  else if (aux_velocity == "rigid")
    discrete_options.aux_velocity = AuxVelocityModel::kRigid;
  else
    return cli.UsageError("--aux-velocity must be state or rigid, got " + aux_velocity);
  if (discrete_options.keyframe_rate_hz < 0.0)
    return cli.UsageError("--keyframe-rate must be >= 0");
  if (representation == "split")
    options.representation = Se3Representation::kSplit;
  else if (representation == "joint")
    options.representation = Se3Representation::kJoint;
  else
    return cli.UsageError("--representation must be split or joint, got " + representation);
  if (split_frame_rows == "auto" || split_frame_rows == "on" || split_frame_rows == "off")
    options.split_frame_rows = split_frame_rows == "auto" ? -1 : split_frame_rows == "on";
  else
    return cli.UsageError("--split-frame-rows must be auto, on or off, got " + split_frame_rows);
  if (options.threads < 0)
    return cli.UsageError("--threads must be >= 0");
  const bool track = !cli.vm()["no-track"].as<bool>();
  if (noise_policy != "estimate" && noise_policy != "stated")
    return cli.UsageError("--noise must be estimate or stated, got " + noise_policy);
  options.estimate_noise = noise_policy == "estimate";
  if (!(options.frame_weight_prior >= 0.0))
    return cli.UsageError("--frame-weights must be >= 0");
  // The knot rule by fit belongs to the noise estimation (docs/noise_estimation.md).
  options.knot_spacing_by_fit = options.estimate_noise;
  try {
    CheckOptions(options);  // before any data are read
  } catch (const CalibrationInputError& e) {
    return cli.UsageError(e.what());
  }
  if (init_policy == "beyond-prior")
    options.coarse_init.policy = GuessPolicy::kBeyondPrior;
  else if (init_policy == "always")
    options.coarse_init.policy = GuessPolicy::kAlways;
  else if (init_policy == "off")
    options.coarse_init.policy = GuessPolicy::kOff;
  else
    return cli.UsageError("--init must be beyond-prior, always or off, got " + init_policy);

  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  // A previous run's subsets are not this run's (the report would show them).
  std::filesystem::remove_all(out_dir + "/crossval", ec);
  std::ofstream log_file(out_dir + "/log.txt");
  if (!log_file)
    return cli.RunFailed(out_dir + "/log.txt: cannot write the log");
  const CalibrationLog log = [&](const std::string& line) {
    std::cout << line << std::endl;
    log_file << line << '\n';
  };

  // The command's stages outside the calibration (docs/performance.md step 7d): the log's `time:`
  // lines.
  report::StageClock clock;
  RigConfig rig;
  std::map<std::string, SensorData> data;
  try {
    std::vector<std::string> warnings;
    rig = LoadRigOrEurocGuess(rig_path, target_path, data_dir, &warnings);
    for (const std::string& w : warnings)
      log("warning: " + w);
    // The camera models' own domain (a positive focal length, omni's xi, ...), which the rig
    // reader leaves to them (it reads results of any value back exactly): bad input, before the
    // calibration builds the cameras.
    for (const SensorConfig& s : rig.sensors) {
      if (s.type != SensorType::kCamera)
        continue;
      try {
        CameraModel::Create(s.camera_model, s.intrinsics, s.distortion_model, s.distortion_coeffs,
                            Eigen::Vector2i(s.width, s.height));
      } catch (const std::invalid_argument& e) {
        throw std::runtime_error(rig_path + ": sensors." + s.name + ".intrinsics: " + e.what());
      }
    }
    warnings.clear();
    // A ROS bag is read once, its images detected as they stream (never all in memory), so its
    // cameras arrive with their corners and DetectMissingCorners leaves them alone.
    if (IsRosBag(data_dir))
      data =
          LoadBagAndDetect(rig, data_dir, out_dir, options.threads, &warnings, nullptr, log, track);
    else
      data = LoadDataset(data_dir, rig, &warnings);
    for (const std::string& w : warnings)
      log("warning: " + w);
  } catch (const std::exception& e) {
    return cli.InputError(e.what());
  }
  log("time: " + report::FormatStageTime(clock.Lap("load")));
  if (HeapOnHugePages())
    log("heap: on transparent huge pages (GLIBC_TUNABLES glibc.malloc.hugetlb=1)");
  // Cameras given as images only are detected first; their corners go to OUT/<camera>/.
  if (const auto failed = Guarded(cli, log_file, [&] {
        DetectMissingCorners(rig, data_dir, out_dir, options.threads, &data, log, track);
      }))
    return *failed;
  // A board that looks the same turned (a checkerboard with rows + cols even): each view's corner
  // order is settled by consistency across cameras and along time before any calibrator reads
  // the corners (calibrator/init/board_order.h); views it cannot settle are dropped with a
  // warning.
  if (const auto failed = Guarded(cli, log_file, [&] {
        BoardOrderOptions order;
        order.threads = options.threads > 0
                            ? options.threads
                            : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
        const BoardOrderResult resolved = ResolveBoardOrder(
            rig, &data, order, [&](const std::string& line) { log("[init] " + line); });
        for (const std::string& w : resolved.warnings)
          log("warning: " + w);
      }))
    return *failed;
  const report::StageTime detection = clock.Lap("detection");

  // The configuration of the run, for the report.
  report::RunInfo run_info = CalibrateRunInfo(argc, argv);
  for (const auto& [key, value] : std::vector<std::pair<std::string, std::string>>{
           {"config.rig", rig_path},
           {"config.data", data_dir},
           {"config.out", out_dir},
           {"config.method", method},
           {"config.order", std::to_string(options.order)},
           {"config.representation", representation},
           {"config.jacobians", options.analytic ? "analytic" : "autodiff"},
           {"config.bias_knot_spacing_s", std::to_string(options.bias_knot_spacing_s)},
           {"config.max_iterations", std::to_string(options.max_iterations)}})
    run_info.emplace_back(key, value);

  // The noise estimation is part of the spline method only (the discrete calibrator turns it
  // off): say so instead of ignoring the option.
  if (options.estimate_noise && (rig.IsCameraOnly() || method != "spline"))
    log(std::string("note: --noise estimate is not supported ") +
        (rig.IsCameraOnly() ? "for a rig without IMUs" : "by the discrete method") +
        ": the stated noise weighs its residuals (docs/noise_estimation.md)");
  if (rig.IsCameraOnly()) {
    log("cross-validation not run: it is part of the visual-inertial calibration (--method "
        "spline)");
    // SPEC section 7: a rig without IMUs is a camera calibration (per-frame board poses); the
    // spline and the discrete trajectory models do not apply, so say that --method is unused.
    if (method != "spline") {
      log("note: --method " + method +
          " does not apply to a rig without IMUs: calibrating the cameras alone (one result, "
          "solver.method camera_only)");
    }
    return RunCameraOnly(cli, rig, data, out_dir, log, log_file, run_info, options.threads,
                         !options.compress_frames, &clock, detection);
  }
  if (method != "spline") {
    log("cross-validation not run: it is part of --method spline");
    discrete_options.threads = options.threads;
    discrete_options.max_iterations = options.max_iterations;
    return RunDiscreteOrBoth(cli, method, rig, data, options, discrete_options, out_dir, log,
                             log_file, run_info);
  }

  // The subsets are cut before the full calibration takes the data over.
  SubsetSplit split;
  if (xv_options.enabled)
    split = SplitIntoSubsets(rig, data, xv_options, options.min_views);
  SplineCalibrationResult result;
  if (const auto failed = Guarded(
          cli, log_file, [&] { result = CalibrateSpline(rig, std::move(data), options, log); }))
    return *failed;
  run_info.emplace_back("result.knot_spacing_s", std::to_string(result.knot_spacing_s));
  run_info.emplace_back("result.num_knots", std::to_string(result.num_knots));
  std::optional<PendingCalibrationReport> report;
  if (xv_options.enabled) {
    // The report data hold the full calibration's residuals, trajectory and formal correlation,
    // which the cross-validation does not change: written beside it, on the core its subsets'
    // solves leave idle about half of the time.
    if (!split.subsets.empty())
      report.emplace(out_dir, std::move(result.report_data), run_info, log, options.threads);
    // The subsets' trajectories on the full calibration's knot spacing: the same trajectory
    // model, compared on other data (the rule's answer on a subset's time range could differ,
    // and is not measured again).
    SplineCalibratorOptions subset_options = options;
    subset_options.knot_spacing_s = result.knot_spacing_s;
    CrossValidateResult(split, subset_options, out_dir, log, &result.result);
  } else
    log("cross-validation off (--no-cross-validate): sigma is the formal one");

  const report::StageTime calibration = clock.Lap("calibration");
  try {
    WriteResult(result, out_dir, log);
  } catch (const std::exception& e) {
    return cli.RunFailed(e.what());
  }
  log("time: " + report::FormatStageTime(detection) + ", " + report::FormatStageTime(calibration) +
      ", " + report::FormatStageTime(clock.Lap("results")));
  return ExitCodeOfChecks({report ? report->Finish()
                                  : WriteCalibrationReport(out_dir, std::move(result.report_data),
                                                           run_info, log, options.threads)},
                          log);
}

}  // namespace ctcal::app
