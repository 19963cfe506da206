// `ctcal calibrate --method both` end to end on a short simulated recording of the default rig
// (full scenario, table4 guesses): the discrete estimates are honest against the truth, both
// results and the cross-check are written in their documented forms, and bad options stop with a
// usage error.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "../calibrator/simulated_recording.h"
#include "ctcal/sensors/compare.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal {
namespace {

std::string Simulated(int seed, double duration) {
  return test::SimulateOnce("ctcal_methods_" + std::to_string(seed),
                            test::FullTable4Args(seed, duration));
}

TEST(CalibrateMethods, BothWritesTwoHonestResultsAndTheCrossCheck) {
  const std::string data = Simulated(23, 8.0);
  const std::string out = ::testing::TempDir() + "/ctcal_methods_both";
  std::filesystem::remove_all(out);
  const std::string cmd = std::string(CTCAL_BINARY) + " calibrate --rig " + data +
                          "/rig.yaml --data " + data + " --out " + out +
                          " --method both --threads 2 > " + out + ".log 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << "see " << out << ".log";
  for (const char* f : {"spline/result.yaml", "spline/camchain-imucam.yaml", "spline/imu.yaml",
                        "discrete/result.yaml", "discrete/camchain-imucam.yaml",
                        "discrete/imu.yaml", "crosscheck.yaml", "log.txt", "spline/report.html",
                        "spline/report.pdf", "discrete/report.html", "discrete/report.pdf"})
    EXPECT_TRUE(std::filesystem::exists(out + "/" + f)) << f;
  // Each report shows the cross-check as a table (the section is not omitted).
  for (const char* sub : {"/spline", "/discrete"}) {
    std::ifstream html(out + sub + "/report.html");
    const std::string text((std::istreambuf_iterator<char>(html)),
                           std::istreambuf_iterator<char>());
    const std::size_t at = text.find("id=\"sec-crosscheck\"");
    ASSERT_NE(at, std::string::npos) << sub;
    const std::size_t end = text.find("</section>", at);
    const std::string section = text.substr(at, end == std::string::npos ? end : end - at);
    EXPECT_NE(section.find("<table"), std::string::npos) << sub << ": " << section.substr(0, 300);
  }

  std::vector<std::string> warnings;
  const RigConfig truth = LoadRig(data + "/truth.yaml", &warnings);
  const RigConfig discrete = LoadRig(out + "/discrete/result.yaml", &warnings);
  ASSERT_TRUE(discrete.solver.has_value());
  EXPECT_EQ(discrete.solver->method, "discrete");
  const Comparison c = CompareRigs(truth, discrete);
  int finite = 0, within3 = 0;
  double sum_sq = 0.0;
  for (const ComparisonRow& row : c.rows) {
    if (!row.error_over_sigma)
      continue;
    ++finite;
    const double e = std::abs(*row.error_over_sigma);
    within3 += e < 3.0 ? 1 : 0;
    sum_sq += e * e;
    EXPECT_LT(e, 5.0) << row.name << ": error " << row.error << ", sigma " << *row.sigma;
  }
  ASSERT_GT(finite, 80);
  const double rms = std::sqrt(sum_sq / finite);
  std::printf("discrete vs truth: %d / %d within 3 sigma, RMS error/sigma %.3f\n", within3, finite,
              rms);
  // The bar (>= 97 %); 94 / 95 measured (RMS 1.07) with the midpoint A.1.
  EXPECT_GE(within3, static_cast<int>(std::ceil(0.97 * finite)));
  EXPECT_GT(rms, 0.6);
  EXPECT_LT(rms, 1.5);
  // Corners: whitened RMS ~1. The preintegration factors' is below 1 by design (each keyframe's
  // pose and velocity absorb most of a 25 ms factor's residual; docs/discrete.md): 0.59 / 0.60 /
  // 0.75 measured for imu0 / imu1 / gyro0.
  for (const auto& [name, res] : discrete.residuals) {
    ASSERT_TRUE(res.rms_whitened.has_value()) << name;
    if (name.rfind("cam", 0) == 0) {
      EXPECT_NEAR(*res.rms_whitened, 1.0, 0.1) << name;
    } else {
      EXPECT_GT(*res.rms_whitened, 0.45) << name;
      EXPECT_LT(*res.rms_whitened, 0.9) << name;
    }
  }

  // crosscheck.yaml: flagged names and rows of the documented keys; the ratio is |difference|
  // over the smaller sigma and a flagged parameter is one with ratio > 1.
  const YAML::Node x = YAML::LoadFile(out + "/crosscheck.yaml");
  ASSERT_TRUE(x["flagged"].IsSequence());
  ASSERT_TRUE(x["rows"].IsSequence());
  EXPECT_EQ(x["rows"].size(), static_cast<std::size_t>(c.rows.size()));
  int flagged = 0;
  for (const YAML::Node& r : x["rows"]) {
    for (const char* key : {"parameter", "spline", "sigma_spline", "discrete", "sigma_discrete",
                            "difference", "ratio"})
      ASSERT_TRUE(r[key]) << key;
    const double smaller =
        std::min(r["sigma_spline"].as<double>(), r["sigma_discrete"].as<double>());
    EXPECT_NEAR(r["ratio"].as<double>(), std::abs(r["difference"].as<double>()) / smaller, 1e-6);
    flagged += r["ratio"].as<double>() > 1.0 ? 1 : 0;
  }
  EXPECT_EQ(static_cast<int>(x["flagged"].size()), flagged);
  std::printf("cross-check: %d of %zu flagged\n", flagged,
              static_cast<std::size_t>(x["rows"].size()));
  // "At most a couple" (issue 8): 0 measured since the midpoint A.1 (3 before, from the
  // constant-reading A.1's bias at the shifted time offsets; docs/discrete.md).
  EXPECT_LE(flagged, 2);
}

TEST(CalibrateMethods, BadMethodOrAuxVelocityIsAUsageError) {
  const std::string base = std::string(CTCAL_BINARY) + " calibrate --rig r.yaml --data d --out " +
                           ::testing::TempDir() + "/ctcal_methods_bad";
  for (const std::string extra : {" --method kalman", " --method discrete --aux-velocity fast"}) {
    const int rc = std::system((base + extra + " > /dev/null 2>&1").c_str());
    EXPECT_NE(rc, 0) << extra;
  }
}

}  // namespace
}  // namespace ctcal
