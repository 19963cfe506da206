// `ctcal montecarlo` end to end with two very short runs per method (the real study is in
// docs/consistency.md): the files it writes, the NEES bands recomputed from Boost.Math, and bad
// usage as one line with exit code 2.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <boost/math/distributions/chi_squared.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include "cli_test_util.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;

using test::Lines;
using test::RunCtcal;
using test::Slurp;
using Result = test::CliRun;

std::string TempDir(const std::string& what) {
  return ::testing::TempDir() + "/ctcal_montecarlo_" + std::to_string(getpid()) + "_" + what;
}

class MonteCarlo : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::is_regular_file(CTCAL_BINARY))
      GTEST_SKIP() << CTCAL_BINARY << " is not built";
  }
};

// runs.csv: one row per run and estimated scalar of the default rig (98, test_spline_calibrator.cpp
// counts them), every seed of the run.
void ExpectRunsCsv(const std::string& dir, const std::set<std::string>& expected_seeds) {
  std::ifstream csv(dir + "/runs.csv");
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "#run,seed,parameter,truth,estimate,error,sigma");
  std::set<std::string> seeds;
  int rows = 0;
  while (std::getline(csv, line)) {
    ++rows;
    std::stringstream ss(line);
    std::string run, seed;
    std::getline(ss, run, ',');
    std::getline(ss, seed, ',');
    seeds.insert(seed);
  }
  EXPECT_EQ(seeds, expected_seeds);
  EXPECT_EQ(rows, static_cast<int>(expected_seeds.size()) * 98);
}

// A NEES test's band must be the chi-square quantiles of its summed degrees of freedom over the
// runs, and `inside` must say whether the mean lies in it.
void ExpectBand(const YAML::Node& g, double confidence, int runs) {
  const int dof = g["dof"].as<int>();
  ASSERT_GT(dof, 0);
  EXPECT_GE(dof, g["dimension"].as<int>());
  EXPECT_DOUBLE_EQ(g["confidence"].as<double>(), confidence);
  const boost::math::chi_squared chi2(dof);
  const double a = 0.5 * (1.0 - confidence);
  const double dim = g["dimension"].as<double>();
  EXPECT_NEAR(g["band"][0].as<double>(), boost::math::quantile(chi2, a) / runs, 1e-4 * dim);
  EXPECT_NEAR(g["band"][1].as<double>(), boost::math::quantile(chi2, 1 - a) / runs, 1e-4 * dim);
  const double mean = g["mean_nees"].as<double>();
  EXPECT_GE(mean, 0.0);
  EXPECT_EQ(g["inside"].as<bool>(),
            mean >= g["band"][0].as<double>() && mean <= g["band"][1].as<double>());
}

// summary.yaml of `runs` runs of the default rig on `full`: per-parameter statistics, one NEES
// group per sensor and gravity at 99.5 %, the pooled NEES at 95 %, and the with-priors NEES over
// every estimated scalar (the determined ones plus those only their priors hold).
YAML::Node ExpectSummary(const std::string& dir, int runs) {
  const YAML::Node s = YAML::LoadFile(dir + "/summary.yaml");
  EXPECT_EQ(s["scenario"].as<std::string>(), "full");
  EXPECT_EQ(s["succeeded"].as<int>(), runs);
  EXPECT_EQ(s["parameters"].size(), 98u);
  const YAML::Node p = s["parameters"]["cam0.intrinsics[0]"];
  EXPECT_TRUE(p.IsMap());
  if (p.IsMap()) {
    EXPECT_GE(p["rms_error"].as<double>(), std::abs(p["mean_error"].as<double>()));
    EXPECT_GT(p["mean_sigma"].as<double>(), 0.0);
    EXPECT_LT(p["mean_sigma"].as<double>(), 5.0);  // px: a short recording still pins the focal
  }
  const YAML::Node groups = s["nees"]["groups"];
  std::set<std::string> names;
  for (const auto& g : groups)
    names.insert(g.first.as<std::string>());
  EXPECT_EQ(names, (std::set<std::string>{"cam0", "cam1", "gravity_W", "gyro0", "imu0", "imu1"}));
  for (const auto& g : groups)
    ExpectBand(g.second, 0.995, runs);
  const YAML::Node pooled = s["nees"]["pooled"]["overall"];
  ExpectBand(pooled, 0.95, runs);
  // The joint NEES of ~95 scalars cannot be small unless the errors are tiny against sigma; a
  // broken covariance (e.g. sigmas 1000x too large or small) lands orders of magnitude away.
  const double per_dim = pooled["mean_nees_per_dimension"].as<double>();
  EXPECT_GT(per_dim, 0.3);
  EXPECT_LT(per_dim, 3.0);

  // With the priors: every scalar of the covariance (gravity as its 2 tangent directions: 97),
  // split into the determined (the pooled test's) and the undetermined ones.
  const YAML::Node with = s["nees"]["with_priors"];
  ExpectBand(with["overall"], 0.95, runs);
  EXPECT_EQ(with["overall"]["dof"].as<int>(), runs * 97);
  EXPECT_EQ(with["overall"]["dof"].as<int>(),
            pooled["dof"].as<int>() + with["undetermined"]["dof"].as<int>());
  bool every_test_inside = pooled["inside"].as<bool>();
  for (const auto& g : groups)
    every_test_inside = every_test_inside && g.second["inside"].as<bool>();
  EXPECT_EQ(s["consistent"].as<bool>(), every_test_inside);
  return s;
}

TEST_F(MonteCarlo, TwoShortRunsWriteRunsSummaryAndPlots) {
  const std::string dir = TempDir("full");
  const Result r = RunCtcal(
      "montecarlo --scenario full --runs 2 --duration 3 --seed0 5 --threads 2 --out " + dir, dir);
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("[  2/2]"), std::string::npos) << r.out;  // progress per run
  ExpectRunsCsv(dir, {"5", "6"});
  const YAML::Node s = ExpectSummary(dir, 2);
  EXPECT_EQ(s["method"].as<std::string>(), "spline");
  EXPECT_FALSE(s["aux_velocity"]);
  for (const char* plot : {"imu0.Dw", "imu1.R_B_S", "cam0.intrinsics", "gyro0.time_offset"})
    EXPECT_GT(fs::file_size(dir + "/plots/" + plot + ".png"), 1000u) << plot;
  EXPECT_TRUE(fs::exists(dir + "/logs/seed_5.txt"));
}

// The discrete (MVIS keyframe) calibrator through the same statistics, with the auxiliary
// velocity model recorded.
TEST_F(MonteCarlo, DiscreteTwoShortRuns) {
  const std::string dir = TempDir("discrete");
  const Result r = RunCtcal(
      "montecarlo --scenario full --runs 2 --duration 2.5 --seed0 8 --threads 2 --method "
      "discrete --aux-velocity state --out " +
          dir,
      dir);
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("method discrete"), std::string::npos) << r.out;
  ExpectRunsCsv(dir, {"8", "9"});
  const YAML::Node s = ExpectSummary(dir, 2);
  EXPECT_EQ(s["method"].as<std::string>(), "discrete");
  EXPECT_EQ(s["aux_velocity"].as<std::string>(), "state");
  // The log is the discrete calibrator's.
  EXPECT_NE(Slurp(dir + "/logs/seed_8.txt").find("keyframe"), std::string::npos);
}

TEST_F(MonteCarlo, BadUsageIsOneLineAndExitTwo) {
  const std::string dir = TempDir("bad");
  for (const std::string& args :
       {std::string("--scenario full --runs 0 --out ") + dir,
        std::string("--scenario sideways --runs 2 --out ") + dir,
        std::string("--scenario full --runs 2 --method both --out ") + dir,
        std::string("--scenario full --runs 2 --aux-velocity state --out ") + dir,
        std::string("--scenario full --runs 2 --method spline --aux-velocity rigid --out ") + dir,
        std::string("--scenario full --runs 2 --method discrete --aux-velocity fast --out ") + dir,
        std::string("--scenario full --runs 2 --duration 0.5 --out ") + dir,
        std::string("--scenario full --runs 2 --quiet-gyro cam0 --out ") + dir,
        std::string("--scenario full --runs 2 --seed0 -3 --out ") + dir}) {
    const Result r = RunCtcal("montecarlo " + args, dir);
    EXPECT_EQ(r.code, 2) << args << ": " << r.err;
    EXPECT_EQ(Lines(r.err), 1) << args << ": " << r.err;
    EXPECT_EQ(r.err.rfind("ctcal montecarlo: error: ", 0), 0u) << r.err;
  }
}

}  // namespace
}  // namespace ctcal
