// `ctcal montecarlo --scenario S --runs N [--method spline|discrete] [--aux-velocity state|rigid]
//  [--duration D] [--seed0 K] [--threads T] [--quiet-gyro SENSOR] --out DIR` (issue 9): N seeds of
//  simulate + calibrate
// of the default rig, in-process and in parallel, and the consistency of the reported
// uncertainty with the actual errors.
//
// Run k simulates seed K + k exactly as `ctcal simulate --scenario S --seed K+k --perturb table4`
// does (same measurements, same initial guesses and priors) and calibrates it with one solver
// thread. Per run, the error of every estimated scalar is CompareRigs' (estimate - truth; a
// rotation's left perturbation Log(R_est R_true^T), the convention of `sigma:`), gravity's error
// is taken into its 2-dof sphere tangent, and
//   NEES_g = e_g^T P_g^-1 e_g
// for each sensor group g (every estimated scalar of the sensor with a finite sigma; gravity is a
// group of its own) and for the whole vector, with P the tangent-space covariance the calibrator
// reports (priors included: the table4 priors are centred on the perturbed guesses with the
// perturbation's sigmas, so they are a correct Bayesian prior). For a consistent estimator,
// sum over runs of NEES_g ~ chi2(sum of dims): the mean NEES must fall in
// [q((1-c)/2), q((1+c)/2)] / N, c = 99.5 % per group (Bonferroni over ~10 groups) and 95 % for
// the pooled (joint) NEES (Boost.Math quantiles).
//
// With the table4 priors every estimated scalar has a finite prior-included covariance, also
// those the data leave undetermined (sigma .inf in the result, so left out of the tests above):
// summary.yaml's `with_priors` tests their NEES and that of every scalar at 95 %, which is where
// an estimator that takes information the data do not carry (e.g. a noisy reading used as exact)
// shows on degenerate motion.
//
// Writes DIR/runs.csv (run, seed, parameter, truth, estimate, error, sigma), DIR/summary.yaml
// (per parameter mean error, RMS error, mean sigma; NEES per group and overall, bands, inside),
// DIR/plots/<sensor>.<key>.png (error and +-3 sigma per run, one panel per component, as the
// reports' Figs. 2-4) and DIR/logs/seed_<K>.txt (each calibration's log). runs.csv and
// summary.yaml are rewritten after every finished run (`finished:` counts them), the plots at the
// end.
#include <ceres/sphere_manifold.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <atomic>
#include <boost/math/distributions/chi_squared.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "cli_common.h"
#include "commands.h"
#include "ctcal/calibrator/discrete_calibrator.h"
#include "ctcal/calibrator/spline_calibrator.h"
#include "ctcal/report/plot.h"
#include "ctcal/sensors/compare.h"
#include "ctcal/sim/dataset_writer.h"
#include "ctcal/sim/default_rig.h"
#include "ctcal/sim/perturb.h"
#include "ctcal/sim/scenario.h"
#include "ctcal/sim/simulator.h"

namespace ctcal::app {
namespace {

namespace fs = std::filesystem;

constexpr double kGroupConfidence = 0.995;  // per sensor group (Bonferroni)
constexpr double kPooledConfidence = 0.95;  // the joint NEES over every parameter

struct Settings {
  sim::Scenario scenario = sim::Scenario::kFull;
  std::string method = "spline";
  std::string aux_velocity;  // discrete only
  double duration = 10.0;
  std::uint64_t seed0 = 1;
  int runs = 0;
  // Study knob: these sensors' gyroscopes are simulated without white noise while the calibrator
  // still assumes their stated noise (isolates what an estimator does with those readings).
  std::vector<std::string> quiet_gyros;
};

// What one calibration returns, whichever method made it.
struct Calibrated {
  RigConfig result;
  std::vector<std::string> covariance_names;
  Eigen::MatrixXd covariance;
};

// The one place a method is chosen: the spline calibrator, or the discrete (MVIS keyframe) one
// with `aux_velocity` selecting its auxiliary-IMU velocity model (state by default).
Calibrated Calibrate(const Settings& s, const RigConfig& guess,
                     const std::map<std::string, SensorData>& data, const CalibrationLog& log) {
  const auto take = [](SplineCalibrationResult&& r) {
    return Calibrated{std::move(r.result), std::move(r.covariance_names), std::move(r.covariance)};
  };
  if (s.method == "discrete") {
    DiscreteCalibratorOptions options;
    options.threads = 1;  // the runs are the parallelism
    options.aux_velocity =
        s.aux_velocity == "rigid" ? AuxVelocityModel::kRigid : AuxVelocityModel::kState;
    return take(CalibrateDiscrete(guess, data, options, log));
  }
  SplineCalibratorOptions options;
  options.threads = 1;
  return take(CalibrateSpline(guess, data, options, log));
}

struct RunRecord {
  int run = 0;
  std::uint64_t seed = 0;
  bool ok = false;
  std::string failure;
  double seconds = 0.0;
  Comparison comparison;
  std::map<std::string, double> nees;  // per group and "overall": the determined scalars
  std::map<std::string, int> dims;
  // With the priors: "undetermined" (the scalars the data leave undetermined, sigma .inf in the
  // result, held by their priors alone) and "overall" (every estimated scalar).
  std::map<std::string, double> nees_priors;
  std::map<std::string, int> dims_priors;
};

std::string GroupOf(const std::string& name) {
  if (name.rfind("gravity_W", 0) == 0)
    return "gravity_W";
  return name.substr(0, name.find('.'));
}

// Sensor and key of a scalar's name: the plot it goes to ("imu1.R_B_S", "gravity_W").
std::string PlotGroupOf(const std::string& name) {
  const std::size_t bracket = name.find('[');
  return bracket == std::string::npos ? name : name.substr(0, bracket);
}

// e^T P^-1 e on P's range (a pseudo-inverse guards against a numerically singular block).
double Nees(const Eigen::VectorXd& e, const Eigen::MatrixXd& P) {
  const Eigen::LLT<Eigen::MatrixXd> llt(P);
  if (llt.info() == Eigen::Success)
    return e.dot(llt.solve(e));
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(P);
  const double tol = 1e-12 * eig.eigenvalues().cwiseAbs().maxCoeff();
  double nees = 0.0;
  for (Eigen::Index k = 0; k < P.rows(); ++k) {
    const double l = eig.eigenvalues()(k);
    if (l > tol)
      nees += std::pow(eig.eigenvectors().col(k).dot(e), 2) / l;
  }
  return nees;
}

struct TangentError {
  double error = 0.0;
  bool determined = false;  // a finite sigma in the result (else only its prior holds it)
};

// The error vector in the covariance's tangent space, per name; gravity through its sphere
// tangent at the estimate (est [+] delta = truth, error = -delta).
std::map<std::string, TangentError> TangentErrors(const RigConfig& truth, const Calibrated& c,
                                                  const Comparison& cmp) {
  std::map<std::string, TangentError> e;
  for (const ComparisonRow& row : cmp.rows)
    e[row.name] = {row.error, row.sigma && std::isfinite(*row.sigma)};
  if (truth.gravity_W && c.result.gravity_W) {
    const ceres::SphereManifold<3> sphere;
    double delta[2];
    sphere.Minus(truth.gravity_W->data(), c.result.gravity_W->data(), delta);
    const bool determined = c.result.sigma_gravity_W && c.result.sigma_gravity_W->allFinite();
    e["gravity_W.direction[0]"] = {-delta[0], determined};
    e["gravity_W.direction[1]"] = {-delta[1], determined};
  }
  return e;
}

// NEES of every group of covariance indices.
void GroupNees(const std::map<std::string, std::vector<int>>& groups,
               const std::map<std::string, TangentError>& e, const Calibrated& c,
               std::map<std::string, double>* nees, std::map<std::string, int>* dims) {
  for (const auto& [g, idx] : groups) {
    const auto m = static_cast<Eigen::Index>(idx.size());
    Eigen::VectorXd err(m);
    Eigen::MatrixXd P(m, m);
    for (Eigen::Index a = 0; a < m; ++a) {
      err(a) = e.at(c.covariance_names[static_cast<std::size_t>(idx[a])]).error;
      for (Eigen::Index b = 0; b < m; ++b)
        P(a, b) = c.covariance(idx[a], idx[b]);
    }
    (*nees)[g] = m > 0 ? Nees(err, P) : 0.0;
    (*dims)[g] = static_cast<int>(m);
  }
}

// Whether the guess holds a prior on the scalar `sensor.key[i]` (gravity_W has none).
bool HasPrior(const RigConfig& guess, const std::string& name) {
  const std::size_t dot = name.find('.');
  if (dot == std::string::npos)
    return false;
  const SensorConfig* s = guess.Find(name.substr(0, dot));
  return s != nullptr &&
         s->prior_sigma.values.count(name.substr(dot + 1, name.find('[') - dot - 1));
}

// An undetermined scalar enters the with-priors tests only when it has a prior: without one its
// covariance holds no information at all (on `no-rotation` gravity's tilt trades against the
// accelerometer biases, which have no prior either), and its NEES means nothing.
void ComputeNees(const RigConfig& truth, const RigConfig& guess, const Calibrated& c,
                 RunRecord* r) {
  const std::map<std::string, TangentError> e = TangentErrors(truth, c, r->comparison);
  std::map<std::string, std::vector<int>> groups, with_priors;
  for (std::size_t i = 0; i < c.covariance_names.size(); ++i) {
    const std::string& n = c.covariance_names[i];
    const auto k = static_cast<Eigen::Index>(i);
    const auto it = e.find(n);
    if (it == e.end() || !std::isfinite(c.covariance(k, k)) || !(c.covariance(k, k) > 0.0))
      continue;
    if (!it->second.determined && !HasPrior(guess, n))
      continue;
    with_priors["overall"].push_back(static_cast<int>(i));
    if (!it->second.determined) {
      with_priors["undetermined"].push_back(static_cast<int>(i));
      continue;
    }
    groups[GroupOf(n)].push_back(static_cast<int>(i));
    groups["overall"].push_back(static_cast<int>(i));
  }
  groups["overall"];  // present (dimension 0) even when nothing is determined
  with_priors["undetermined"];
  with_priors["overall"];
  GroupNees(groups, e, c, &r->nees, &r->dims);
  GroupNees(with_priors, e, c, &r->nees_priors, &r->dims_priors);
}

// Two-sided band of the mean NEES over `runs` runs with `dof` degrees of freedom in total.
std::pair<double, double> Band(int dof, int runs, double confidence) {
  if (dof <= 0 || runs <= 0)
    return {0.0, 0.0};
  const boost::math::chi_squared chi2(dof);
  const double a = 0.5 * (1.0 - confidence);
  return {boost::math::quantile(chi2, a) / runs, boost::math::quantile(chi2, 1.0 - a) / runs};
}

std::string Num(double v) {
  if (std::isnan(v))
    return ".nan";
  if (std::isinf(v))
    return v > 0 ? ".inf" : "-.inf";
  char b[40];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

RunRecord RunOne(const Settings& s, int run, const fs::path& log_dir) {
  RunRecord r;
  r.run = run;
  r.seed = s.seed0 + static_cast<std::uint64_t>(run);
  const auto start = std::chrono::steady_clock::now();
  std::ofstream log_file(log_dir / ("seed_" + std::to_string(r.seed) + ".txt"));
  const CalibrationLog log = [&](const std::string& line) { log_file << line << '\n'; };
  try {
    const RigConfig rig = sim::DefaultRig();
    const auto motion = sim::MakeTrajectory(s.scenario, sim::SceneFor(rig.target));
    const sim::RotatedTrajectory traj(*motion, sim::ScenarioMount(rig));
    sim::SimOptions options;
    options.duration = s.duration;
    options.seed = r.seed;
    RigConfig simulated = rig;
    for (const std::string& name : s.quiet_gyros)
      simulated.Find(name)->noise.gyroscope_noise_density = 0.0;
    const sim::SimulatedDataset data = sim::Simulate(simulated, traj, options);
    sim::Random rng = sim::Random(r.seed).Fork(sim::kPerturbationStream);
    const RigConfig guess = sim::PerturbRig(rig, sim::Perturbation::kTable4, rng);
    const Calibrated c = Calibrate(s, guess, sim::ToSensorData(data), log);
    r.comparison = CompareRigs(data.truth, c.result);
    ComputeNees(data.truth, guess, c, &r);
    r.ok = true;
  } catch (const std::exception& e) {
    r.failure = e.what();
    log_file << "error: " << e.what() << '\n';
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

void WriteRunsCsv(const std::vector<RunRecord>& runs, const fs::path& path) {
  std::ofstream f(path);
  f << "#run,seed,parameter,truth,estimate,error,sigma\n";
  for (const RunRecord& r : runs) {
    if (!r.ok)
      continue;
    for (const ComparisonRow& row : r.comparison.rows) {
      char line[300];
      std::snprintf(line, sizeof line, "%d,%llu,%s,%.17g,%.17g,%.17g,%s\n", r.run,
                    static_cast<unsigned long long>(r.seed), row.name.c_str(), row.truth,
                    row.estimate, row.error, row.sigma ? Num(*row.sigma).c_str() : "");
      f << line;
    }
  }
  if (!f)
    throw std::runtime_error(path.string() + ": cannot write");
}

struct GroupTest {
  double mean = 0.0;
  int dof = 0;
  std::pair<double, double> band;
  bool inside = false;
};

GroupTest TestGroup(const std::vector<RunRecord>& runs, const std::string& g, double confidence,
                    bool with_priors) {
  GroupTest t;
  int n = 0;
  for (const RunRecord& r : runs) {
    const auto& nees = with_priors ? r.nees_priors : r.nees;
    const auto& dims = with_priors ? r.dims_priors : r.dims;
    if (!r.ok || !nees.count(g))
      continue;
    t.mean += nees.at(g);
    t.dof += dims.at(g);
    ++n;
  }
  if (n == 0 || t.dof == 0)
    return t;
  t.mean /= n;
  t.band = Band(t.dof, n, confidence);
  t.inside = t.mean >= t.band.first && t.mean <= t.band.second;
  return t;
}

// Writes summary.yaml; returns whether every test passed.
bool WriteSummary(const Settings& s, const std::vector<RunRecord>& runs, const fs::path& path,
                  std::vector<std::string>* lines) {
  std::ofstream f(path);
  int ok = 0;
  for (const RunRecord& r : runs)
    ok += r.ok ? 1 : 0;
  f << "scenario: " << sim::ToString(s.scenario) << "\nmethod: " << s.method;
  if (s.method == "discrete")
    f << "\naux_velocity: " << (s.aux_velocity.empty() ? "state" : s.aux_velocity);
  if (!s.quiet_gyros.empty()) {
    f << "\nquiet_gyros: [";
    for (std::size_t i = 0; i < s.quiet_gyros.size(); ++i)
      f << (i ? ", " : "") << s.quiet_gyros[i];
    f << "]";
  }
  f << "\nduration: " << Num(s.duration) << "\nseed0: " << s.seed0 << "\nruns: " << s.runs
    << "\nfinished: " << runs.size() << "\nsucceeded: " << ok << "\n";
  f << "failed:\n";
  for (const RunRecord& r : runs)
    if (!r.ok)
      f << "  - {seed: " << r.seed << ", error: \"" << r.failure << "\"}\n";

  // Per parameter, over the runs where it has a finite sigma.
  struct Acc {
    double sum = 0.0, sum_sq = 0.0, sum_sigma = 0.0;
    int n = 0, undetermined = 0;
  };
  std::vector<std::string> order;
  std::map<std::string, Acc> acc;
  for (const RunRecord& r : runs) {
    if (!r.ok)
      continue;
    for (const ComparisonRow& row : r.comparison.rows) {
      if (!acc.count(row.name))
        order.push_back(row.name);
      Acc& a = acc[row.name];
      if (!row.sigma || !std::isfinite(*row.sigma)) {
        ++a.undetermined;
        continue;
      }
      a.sum += row.error;
      a.sum_sq += row.error * row.error;
      a.sum_sigma += *row.sigma;
      ++a.n;
    }
  }
  f << "parameters:\n";
  for (const std::string& name : order) {
    const Acc& a = acc[name];
    const double n = std::max(a.n, 1);
    f << "  " << name << ": {mean_error: " << Num(a.n ? a.sum / n : NAN)
      << ", rms_error: " << Num(a.n ? std::sqrt(a.sum_sq / n) : NAN)
      << ", mean_sigma: " << Num(a.n ? a.sum_sigma / n : NAN) << ", runs: " << a.n
      << ", undetermined_runs: " << a.undetermined << "}\n";
  }

  std::set<std::string> groups;
  for (const RunRecord& r : runs)
    for (const auto& [g, v] : r.nees)
      if (g != "overall")
        groups.insert(g);
  bool all_inside = ok > 0, all_inside_priors = ok > 0;
  // A test with no degrees of freedom (nothing undetermined) passes and says so.
  const auto emit = [&](const std::string& g, double confidence, bool with_priors,
                        const char* indent) {
    const GroupTest t = TestGroup(runs, g, confidence, with_priors);
    const bool inside = t.inside || t.dof == 0;
    const int dim = ok > 0 ? t.dof / ok : 0;
    f << indent << g << ": {dimension: " << dim << ", dof: " << t.dof
      << ", mean_nees: " << Num(t.mean)
      << ", mean_nees_per_dimension: " << Num(dim > 0 ? t.mean / dim : NAN)
      << ", confidence: " << Num(confidence) << ", band: [" << Num(t.band.first) << ", "
      << Num(t.band.second) << "], inside: " << (inside ? "true" : "false") << "}\n";
    char line[240];
    std::snprintf(line, sizeof line,
                  "  NEES %-12s dim %3d  mean %9.3f  (%.1f %% band [%8.3f, %8.3f])  %s%s",
                  g.c_str(), dim, t.mean, 100.0 * confidence, t.band.first, t.band.second,
                  t.dof == 0 ? "(none)" : (inside ? "inside" : "OUTSIDE"),
                  with_priors ? "  [priors included]" : "");
    lines->push_back(line);
    (with_priors ? all_inside_priors : all_inside) &= inside;
  };
  f << "nees:\n  groups:\n";
  for (const std::string& g : groups)
    emit(g, kGroupConfidence, false, "    ");
  f << "  pooled:\n";
  emit("overall", kPooledConfidence, false, "    ");
  // What the priors hold: NEES with the prior-included covariance of the scalars the data leave
  // undetermined (sigma .inf in the result) and of every estimated scalar.
  f << "  with_priors:\n";
  emit("undetermined", kPooledConfidence, true, "    ");
  emit("overall", kPooledConfidence, true, "    ");
  f << "consistent: " << (all_inside ? "true" : "false") << "\n";
  f << "consistent_with_priors: " << (all_inside_priors ? "true" : "false") << "\n";
  if (!f)
    throw std::runtime_error(path.string() + ": cannot write");
  return all_inside;
}

// One figure per sensor key: a panel per component with each run's error and its +-3 sigma
// (rotations in degrees), like the seed reports' Figs. 2-4.
void WritePlots(const std::vector<RunRecord>& runs, const fs::path& dir) {
  std::vector<std::string> group_order;
  std::map<std::string, std::vector<std::string>> components;
  std::map<std::string, bool> rotation;
  for (const RunRecord& r : runs) {
    if (!r.ok)
      continue;
    for (const ComparisonRow& row : r.comparison.rows) {
      const std::string g = PlotGroupOf(row.name);
      if (!components.count(g))
        group_order.push_back(g);
      auto& c = components[g];
      if (std::find(c.begin(), c.end(), row.name) == c.end())
        c.push_back(row.name);
      rotation[row.name] = row.rotation;
    }
  }
  for (const std::string& g : group_order) {
    const auto& names = components[g];
    const int n = static_cast<int>(names.size());
    const int cols = n >= 3 ? 3 : n;
    const int rows = (n + cols - 1) / cols;
    report::Figure fig(rows, cols, 330.0 * cols, 230.0 * rows + 40.0);
    fig.title = g + ": error per run (dots) and +-3 sigma (lines)";
    for (const std::string& name : names) {
      const double scale = rotation[name] ? 180.0 / M_PI : 1.0;
      std::vector<double> x, err, lo, hi;
      for (const RunRecord& r : runs) {
        if (!r.ok)
          continue;
        for (const ComparisonRow& row : r.comparison.rows) {
          if (row.name != name)
            continue;
          x.push_back(r.run);
          err.push_back(row.error * scale);
          const double s = row.sigma && std::isfinite(*row.sigma) ? 3.0 * *row.sigma * scale : NAN;
          lo.push_back(-s);
          hi.push_back(s);
        }
      }
      auto& p = fig.Add<report::XYPlot>();
      p.title = name + (rotation[name] ? " (deg)" : "");
      p.x_label = "run";
      p.legend = false;
      p.Line(x, hi, "+3 sigma", report::kFail, 1.2);
      p.Line(x, lo, "-3 sigma", report::kFail, 1.2);
      p.Scatter(x, err, "error", report::PaletteColor(0), 2.5);
      p.HLine(0.0, "", report::Color{0.5, 0.5, 0.5, 1.0});
    }
    report::SavePng(fig, (dir / (g + ".png")).string());
  }
}

}  // namespace

int RunMonteCarlo(int argc, char** argv) {
  namespace po = boost::program_options;
  CommandLine cli("montecarlo",
                  "--scenario NAME --runs N --out DIR [--method spline|discrete] "
                  "[--aux-velocity state|rigid] [--duration S] [--seed0 K] [--threads T] "
                  "[--quiet-gyro SENSOR]",
                  "Simulate and calibrate the default rig for N seeds in parallel (table4 "
                  "guesses and priors) and test whether the reported uncertainties match the "
                  "errors: NEES per sensor and overall against chi-square bands.");
  Settings s;
  std::string scenario_name, out;
  std::string seed_text = "1";
  int threads = 0;
  cli.options().add_options()                                                          //
      ("scenario", po::value(&scenario_name)->required(), "full, yaw, planar, ...")    //
      ("runs", po::value(&s.runs)->required(), "number of seeds")                      //
      ("out", po::value(&out)->required(), "output folder")                            //
      ("method", po::value(&s.method)->default_value("spline"), "spline or discrete")  //
      ("aux-velocity", po::value(&s.aux_velocity),
       "discrete method: auxiliary IMU velocity as a state or from the rigid-body model")  //
      ("duration", po::value(&s.duration)->default_value(10.0), "seconds per recording")   //
      ("seed0", po::value(&seed_text)->default_value("1"), "seed of the first run")        //
      ("threads", po::value(&threads)->default_value(0), "parallel runs (0: every core)")  //
      ("quiet-gyro", po::value(&s.quiet_gyros)->composing(),
       "study: simulate this inertial sensor's gyroscope without white noise (the calibrator "
       "still assumes its stated noise); repeatable");
  if (const auto exit_code = cli.Parse(argc, argv))
    return *exit_code;
  try {
    s.scenario = sim::ParseScenario(scenario_name);
  } catch (const std::exception& e) {
    return cli.UsageError(e.what());
  }
  if (s.runs < 1 || s.runs > 100000)
    return cli.UsageError("--runs must be a positive number of seeds, got " +
                          std::to_string(s.runs));
  if (!(s.duration >= 2.0) || !std::isfinite(s.duration) || s.duration > 3600.0)
    return cli.UsageError("--duration must be between 2 and 3600 seconds, got " +
                          std::to_string(s.duration));
  if (threads < 0)
    return cli.UsageError("--threads must be >= 0");
  try {
    std::size_t used = 0;
    s.seed0 = std::stoull(seed_text, &used);
    if (used != seed_text.size() || seed_text[0] == '-')
      throw std::invalid_argument("");
  } catch (const std::exception&) {
    return cli.UsageError("--seed0 must be an integer in [0, 2^64), got '" + seed_text + "'");
  }
  if (s.method != "spline" && s.method != "discrete")
    return cli.UsageError("--method must be spline or discrete, got " + s.method);
  if (!s.aux_velocity.empty() && s.aux_velocity != "state" && s.aux_velocity != "rigid")
    return cli.UsageError("--aux-velocity must be state or rigid, got " + s.aux_velocity);
  if (!s.aux_velocity.empty() && s.method != "discrete")
    return cli.UsageError("--aux-velocity applies to --method discrete only");
  {
    const RigConfig rig = sim::DefaultRig();
    for (const std::string& name : s.quiet_gyros) {
      const SensorConfig* sensor = rig.Find(name);
      if (sensor == nullptr || !sensor->IsInertial())
        return cli.UsageError("--quiet-gyro " + name +
                              ": not an inertial sensor of the default rig");
    }
  }

  std::error_code ec;
  fs::create_directories(fs::path(out) / "logs", ec);
  fs::create_directories(fs::path(out) / "plots", ec);
  if (ec || !fs::is_directory(fs::path(out) / "plots"))
    return cli.InputError("cannot create the output folder '" + out + "'" +
                          (ec ? ": " + ec.message() : ""));
  if (threads == 0)
    threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  threads = std::min(threads, s.runs);

  std::printf(
      "ctcal montecarlo: %d runs of %s, %g s each, seeds %llu..%llu, method %s, %d in parallel "
      "-> %s\n",
      s.runs, scenario_name.c_str(), s.duration, static_cast<unsigned long long>(s.seed0),
      static_cast<unsigned long long>(s.seed0 + static_cast<std::uint64_t>(s.runs) - 1),
      s.method.c_str(), threads, out.c_str());
  std::fflush(stdout);
  const auto start = std::chrono::steady_clock::now();
  std::vector<RunRecord> runs(static_cast<std::size_t>(s.runs));
  std::atomic<int> next{0};
  std::mutex print;
  int done = 0;
  std::vector<int> finished;  // runs done, guarded by `print`
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    pool.emplace_back([&] {
      for (int k = next++; k < s.runs; k = next++) {
        RunRecord r = RunOne(s, k, fs::path(out) / "logs");
        std::lock_guard<std::mutex> lock(print);
        ++done;
        if (r.ok) {
          const ComparisonSummary& c = r.comparison.summary;
          const double dim = std::max(1, r.dims["overall"]);
          const double dim_u = std::max(1, r.dims_priors["undetermined"]);
          std::printf(
              "  [%3d/%d] seed %llu: %.1f s, %d/%d within 3 sigma, %d undetermined, "
              "NEES/dim %.2f (undetermined, with priors: %.2f)\n",
              done, s.runs, static_cast<unsigned long long>(r.seed), r.seconds, c.within_3_sigma,
              c.with_sigma, c.undetermined, r.nees["overall"] / dim,
              r.nees_priors["undetermined"] / dim_u);
        } else {
          std::printf("  [%3d/%d] seed %llu: FAILED after %.1f s: %s\n", done, s.runs,
                      static_cast<unsigned long long>(r.seed), r.seconds, r.failure.c_str());
        }
        std::fflush(stdout);
        runs[static_cast<std::size_t>(k)] = std::move(r);
        finished.push_back(k);
        // The files so far after every run: a long study can be read (or stopped) before its end.
        std::sort(finished.begin(), finished.end());
        std::vector<RunRecord> so_far;
        for (const int i : finished)
          so_far.push_back(runs[static_cast<std::size_t>(i)]);
        try {
          std::vector<std::string> ignored;
          WriteRunsCsv(so_far, fs::path(out) / "runs.csv");
          WriteSummary(s, so_far, fs::path(out) / "summary.yaml", &ignored);
        } catch (const std::exception& e) {
          std::printf("  warning: %s\n", e.what());
        }
      }
    });
  }
  for (std::thread& t : pool)
    t.join();

  bool consistent = false;
  std::vector<std::string> lines;
  try {
    WriteRunsCsv(runs, fs::path(out) / "runs.csv");
    consistent = WriteSummary(s, runs, fs::path(out) / "summary.yaml", &lines);
    WritePlots(runs, fs::path(out) / "plots");
  } catch (const std::exception& e) {
    return cli.RunFailed(e.what());
  }
  for (const std::string& l : lines)
    std::printf("%s\n", l.c_str());
  int ok = 0;
  for (const RunRecord& r : runs)
    ok += r.ok ? 1 : 0;
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf(
      "%d of %d runs succeeded; NEES %s; %.1f s; wrote %s/runs.csv, summary.yaml, "
      "plots/, logs/\n",
      ok, s.runs, consistent ? "consistent" : "NOT consistent", seconds, out.c_str());
  if (ok == 0)
    return cli.RunFailed("every run failed (see " + out + "/logs/)");
  return kExitOk;
}

}  // namespace ctcal::app
