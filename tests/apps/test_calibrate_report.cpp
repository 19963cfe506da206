// `ctcal calibrate` writes the report end to end (issue 10): on a short simulated recording it
// leaves OUT/report_data/ and OUT/report.html / OUT/report.pdf with every section and figure of
// the rig's sensors, no empty plot, report data that agree with result.yaml's residual
// statistics (they are evaluated independently, from the final values), and `ctcal report`
// re-renders the same document from the folder alone.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "../report/report_test_util.h"
#include "ctcal/report/report_data.h"
#include "ctcal/sensors/parameter_names.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;

std::string Slurp(const std::string& path) {
  std::ifstream f(path);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// Every `<attr>="<prefix>..."` value in the HTML, in document order.
std::vector<std::string> Ids(const std::string& html, const std::string& prefix) {
  std::vector<std::string> ids;
  const std::string key = "id=\"" + prefix;
  for (auto at = html.find(key); at != std::string::npos; at = html.find(key, at + 1)) {
    const auto begin = at + 4;
    ids.push_back(html.substr(begin, html.find('"', begin) - begin));
  }
  return ids;
}

std::string SectionOf(const std::string& html, const std::string& id) {
  const auto at = html.find("<section id=\"" + id + "\">");
  if (at == std::string::npos)
    return "";
  return html.substr(at, html.find("</section>", at) - at);
}

// The checks below share one simulated recording and its calibration. They run from a single
// test: ctest starts every test case as its own process, which would redo the calibration per case.
struct Calibrated {
  std::string root, out;
  RigConfig result;
};

void WritesEverySectionAndFigureOfTheRig(const Calibrated& run) {
  ASSERT_TRUE(fs::exists(run.out + "/report.html"));
  ASSERT_TRUE(fs::exists(run.out + "/report.pdf"));
  EXPECT_NE(Slurp(run.out + "/log.txt").find("report: "), std::string::npos);
  // The calibration re-executed itself with its heap on huge pages where the kernel advises them
  // (apps/huge_page_heap.h) and glibc has the tunable (2.35 on).
  std::ifstream thp("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string mode;
  std::getline(thp, mode);
#if defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 35))
  if (mode.find("[madvise]") != std::string::npos && std::getenv("GLIBC_TUNABLES") == nullptr) {
    EXPECT_NE(Slurp(run.out + "/log.txt").find("heap: on transparent huge pages"),
              std::string::npos);
  }
#endif
  const std::string html = Slurp(run.out + "/report.html");

  std::vector<std::string> sections = {"sec-summary",       "sec-parameters", "sec-kalibr",
                                       "sec-trajectory",    "sec-histograms", "sec-correlation",
                                       "sec-observability", "sec-config"};
  std::vector<std::string> figures = {"fig-summary",     "fig-parameters", "fig-kalibr-camchain",
                                      "fig-kalibr-imu",  "fig-trajectory", "fig-histograms",
                                      "fig-correlation", "fig-excitation", "fig-config"};
  int cameras = 0, inertial = 0;
  for (const SensorConfig& s : run.result.sensors) {
    if (s.IsInertial()) {
      ++inertial;
      sections.push_back("sec-imu-" + s.name);
      for (const char* f : {"-intervals", "-gyro", "-gyro-error", "-bias"})
        figures.push_back("fig-" + s.name + f);
      if (s.type == SensorType::kImu) {
        figures.push_back("fig-" + s.name + "-accel");
        figures.push_back("fig-" + s.name + "-accel-error");
      }
    } else {
      ++cameras;
      sections.push_back("sec-camera-" + s.name);
      for (const char* f : {"-residuals", "-image"})
        figures.push_back("fig-" + s.name + f);
      if (s.camera_model == "pinhole" && s.distortion_model != "none")
        figures.push_back("fig-" + s.name + "-distortion");
    }
  }
  ASSERT_GE(cameras, 1);
  ASSERT_GE(inertial, 2);
  for (const std::string& id : sections) {
    const std::string sec = SectionOf(html, id);
    ASSERT_FALSE(sec.empty()) << id;
    EXPECT_EQ(sec.find("class=\"omitted\""), std::string::npos) << id << " was omitted";
  }
  const std::vector<std::string> drawn = Ids(html, "fig-");
  for (const std::string& id : figures)
    EXPECT_NE(std::find(drawn.begin(), drawn.end(), id), drawn.end()) << id;
  // The configuration and versions of the run.
  const std::string config = SectionOf(html, "sec-config");
  for (const char* key :
       {"command", "config.rig", "config.method", "version.ctcal", "version.ceres", "version.eigen",
        "version.suitesparse", "version.opencv"})
    EXPECT_NE(config.find(key), std::string::npos) << key;
}

void NoPdfPageIsEmpty(const Calibrated& run) {
  const std::string prefix = run.root + "/page";
  const std::string cmd = "pdftoppm -r 30 -gray -png " + run.out + "/report.pdf " + prefix;
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  int pages = 0;
  for (const auto& e : fs::directory_iterator(run.root)) {
    if (e.path().filename().string().rfind("page", 0) != 0)
      continue;
    ++pages;
    const cv::Mat page = cv::imread(e.path().string(), cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(page.empty()) << e.path();
    const cv::Mat body = page(cv::Rect(0, page.rows / 10, page.cols, page.rows * 8 / 10));
    EXPECT_GT(report::test::PixelStdDev(body), 8.0) << e.path();
  }
  EXPECT_GE(pages, 25);
}

// The report data are the measurement models evaluated afresh at the final values; result.yaml's
// statistics come from the solver's residual blocks. They must agree to rounding.
void ReportDataAgreeWithTheResidualStatistics(const Calibrated& run) {
  for (const SensorConfig& s : run.result.sensors) {
    const auto stats = run.result.residuals.find(s.name);
    ASSERT_NE(stats, run.result.residuals.end()) << s.name;
    if (!s.IsInertial()) {
      const auto rows = report::ReadCornerResiduals(report::CornersPath(run.out, s.name));
      ASSERT_FALSE(rows.empty()) << s.name;
      double sum = 0.0;
      int n = 0, outliers = 0;
      std::set<int> frames;
      for (const auto& r : rows) {
        frames.insert(r.frame);
        if (r.outlier) {
          ++outliers;
          continue;
        }
        sum += r.whitened * r.whitened;
        n += 2;
      }
      EXPECT_EQ(n, stats->second.count) << s.name;
      EXPECT_NEAR(std::sqrt(sum / n), *stats->second.rms_whitened,
                  1e-6 * *stats->second.rms_whitened)
          << s.name;
      EXPECT_GT(frames.size(), 50u) << s.name;
      continue;
    }
    const auto gyro = report::ReadInertialSamples(report::GyroPath(run.out, s.name));
    ASSERT_FALSE(gyro.empty()) << s.name;
    const double sigma_g = s.noise.GyroSampleSigma();
    double sum = 0.0;
    for (const auto& r : gyro)
      sum += ((r.meas - r.pred) / sigma_g).squaredNorm();
    ASSERT_TRUE(stats->second.rms_whitened_gyro) << s.name;
    EXPECT_NEAR(std::sqrt(sum / (3.0 * gyro.size())), *stats->second.rms_whitened_gyro,
                1e-6 * *stats->second.rms_whitened_gyro)
        << s.name;
    if (s.type == SensorType::kImu) {
      const auto accel = report::ReadInertialSamples(report::AccelPath(run.out, s.name));
      ASSERT_EQ(accel.size(), gyro.size()) << s.name;
      const double sigma_a = s.noise.AccelSampleSigma();
      double sa = 0.0;
      for (const auto& r : accel)
        sa += ((r.meas - r.pred) / sigma_a).squaredNorm();
      EXPECT_NEAR(std::sqrt(sa / (3.0 * accel.size())), *stats->second.rms_whitened_accel,
                  1e-6 * *stats->second.rms_whitened_accel)
          << s.name;
    }
    // The random-walk envelope: 0 at the first row, sigma_rw sqrt(t - t_first) after.
    const report::BiasTrack bias = report::ReadBiasTrack(report::BiasPath(run.out, s.name));
    ASSERT_GE(bias.gyro.size(), 10u) << s.name;
    EXPECT_EQ(bias.gyro.front().sigma.norm(), 0.0);
    const auto& last = bias.gyro.back();
    const double dt = 1e-9 * static_cast<double>(last.t_ns - bias.gyro.front().t_ns);
    // Bias rows are written to 7 significant digits (report_data.h).
    EXPECT_NEAR(last.sigma.x(), s.noise.gyroscope_random_walk * std::sqrt(dt),
                1e-6 * last.sigma.x());
    EXPECT_EQ(bias.accel.empty(), s.type != SensorType::kImu) << s.name;
  }
}

void CorrelationIsAValidCorrelationMatrix(const Calibrated& run) {
  const report::Correlation c = report::ReadCorrelation(report::CorrelationPath(run.out));
  // Every estimated scalar except gravity (3 ambient components, 2 tangent directions).
  const std::size_t estimated = ScalarParameters(run.result, true).size();
  ASSERT_EQ(c.names.size(), estimated - 1);
  ASSERT_EQ(c.values.rows(), static_cast<Eigen::Index>(c.names.size()));
  // An undetermined parameter (result.yaml's observability.unobservable) has no correlation: a NaN
  // row and column; every other entry is a correlation.
  ASSERT_TRUE(run.result.observability.has_value());
  const auto& unobservable = run.result.observability->unobservable;
  std::vector<bool> nan(c.names.size());
  for (std::size_t i = 0; i < c.names.size(); ++i)
    nan[i] = std::find(unobservable.begin(), unobservable.end(), c.names[i]) != unobservable.end();
  int strong = 0;
  for (Eigen::Index i = 0; i < c.values.rows(); ++i) {
    const auto ii = static_cast<std::size_t>(i);
    if (nan[ii]) {
      EXPECT_TRUE(c.values.row(i).array().isNaN().all()) << c.names[ii];
      continue;
    }
    EXPECT_EQ(c.values(i, i), 1.0) << c.names[ii];
    for (Eigen::Index j = 0; j < i; ++j) {
      if (nan[static_cast<std::size_t>(j)])
        continue;
      EXPECT_NEAR(c.values(i, j), c.values(j, i), 1e-12);
      EXPECT_LE(std::abs(c.values(i, j)), 1.0 + 1e-9);
      strong += std::abs(c.values(i, j)) > 0.5;
    }
  }
  // Camera focal lengths and board distance, extrinsics and time offsets correlate: a matrix of
  // zeros would mean the covariance was lost on the way.
  EXPECT_GT(strong, 0);
}

void ReportCommandReRendersTheSameDocument(const Calibrated& run) {
  const std::string before = Slurp(run.out + "/report.html");
  fs::remove(run.out + "/report.html");
  fs::remove(run.out + "/report.pdf");
  const std::string cmd = std::string(CTCAL_BINARY) + " report --out " + run.out + " > " +
                          run.root + "/report.log 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << Slurp(run.root + "/report.log");
  ASSERT_TRUE(fs::exists(run.out + "/report.pdf"));
  const std::string after = Slurp(run.out + "/report.html");
  EXPECT_EQ(Ids(after, "sec-"), Ids(before, "sec-"));
  EXPECT_EQ(Ids(after, "fig-"), Ids(before, "fig-"));
}

TEST(CalibrateReport, SimulateCalibrateReport) {
  Calibrated run;
  run.root = report::test::MakeTempDir("ctcal_calibrate_report");
  run.out = run.root + "/out";
  const std::string data = run.root + "/data";
  const std::string bin = CTCAL_BINARY;
  ASSERT_EQ(std::system((bin + " simulate --scenario full --seed 5 --duration 8 --out " + data +
                         " > " + run.root + "/simulate.log 2>&1")
                            .c_str()),
            0)
      << Slurp(run.root + "/simulate.log");
  ASSERT_EQ(std::system((bin + " calibrate --rig " + data + "/rig.yaml --data " + data + " --out " +
                         run.out + " --threads 2 > " + run.root + "/calibrate.log 2>&1")
                            .c_str()),
            0)
      << Slurp(run.root + "/calibrate.log");
  run.result = LoadRig(run.out + "/result.yaml");
  {
    SCOPED_TRACE("sections and figures");
    WritesEverySectionAndFigureOfTheRig(run);
  }
  {
    SCOPED_TRACE("pdf pages");
    NoPdfPageIsEmpty(run);
  }
  {
    SCOPED_TRACE("report data vs residual statistics");
    ReportDataAgreeWithTheResidualStatistics(run);
  }
  {
    SCOPED_TRACE("correlation");
    CorrelationIsAValidCorrelationMatrix(run);
  }
  {
    SCOPED_TRACE("ctcal report");
    ReportCommandReRendersTheSameDocument(run);
  }
  fs::remove_all(run.root);
}

// --method discrete: the discrete estimate gets the full report from its own keyframe states
// (report_data_builder.h, KeyframeTrajectory): every camera and inertial section is drawn, and
// the corners' whitened RMS recomputed from the report data equals result.yaml's (poses are read
// exactly as the discrete corner residuals read them). The inertial rows compare each sample with
// the keyframe states' interpolation, which the discrete problem itself never evaluates: their
// RMS is printed, and must stay that of a sane fit. A 5 s recording: the discrete solve is the
// slowest step of the suite.
TEST(CalibrateReportDiscrete, FullReportFromTheKeyframeStates) {
  const std::string root = report::test::MakeTempDir("ctcal_discrete_report");
  const std::string out = root + "/out", data = root + "/data";
  const std::string bin = CTCAL_BINARY;
  ASSERT_EQ(std::system((bin + " simulate --scenario full --seed 5 --duration 5 --out " + data +
                         " > " + root + "/simulate.log 2>&1")
                            .c_str()),
            0)
      << Slurp(root + "/simulate.log");
  ASSERT_EQ(std::system((bin + " calibrate --rig " + data + "/rig.yaml --data " + data + " --out " +
                         out + " --method discrete --threads 2 > " + root + "/calibrate.log 2>&1")
                            .c_str()),
            0)
      << Slurp(root + "/calibrate.log");
  const RigConfig result = LoadRig(out + "/result.yaml");
  const std::string html = Slurp(out + "/report.html");
  const std::vector<std::string> drawn = Ids(html, "fig-");
  for (const std::string id : {"fig-trajectory", "fig-histograms", "fig-correlation"})
    EXPECT_NE(std::find(drawn.begin(), drawn.end(), id), drawn.end()) << id;
  for (const SensorConfig& s : result.sensors) {
    const std::string sec = SectionOf(html, (s.IsInertial() ? "sec-imu-" : "sec-camera-") + s.name);
    ASSERT_FALSE(sec.empty()) << s.name;
    EXPECT_EQ(sec.find("class=\"omitted\""), std::string::npos) << s.name;
    for (const char* f : s.IsInertial() ? std::vector<const char*>{"-gyro-error", "-bias"}
                                        : std::vector<const char*>{"-residuals", "-image"})
      EXPECT_NE(std::find(drawn.begin(), drawn.end(), "fig-" + s.name + f), drawn.end())
          << s.name << f;
    const SensorResiduals& stats = result.residuals.at(s.name);
    if (!s.IsInertial()) {
      double sum = 0.0;
      int n = 0;
      for (const auto& r : report::ReadCornerResiduals(report::CornersPath(out, s.name))) {
        if (!r.outlier) {
          sum += r.whitened * r.whitened;
          n += 2;
        }
      }
      EXPECT_EQ(n, stats.count) << s.name;
      EXPECT_NEAR(std::sqrt(sum / n), *stats.rms_whitened, 1e-6 * *stats.rms_whitened) << s.name;
      continue;
    }
    const auto gyro = report::ReadInertialSamples(report::GyroPath(out, s.name));
    ASSERT_GT(gyro.size(), 500u) << s.name;  // 5 s at 200 Hz
    double sum = 0.0;
    for (const auto& r : gyro)
      sum += ((r.meas - r.pred) / s.noise.GyroSampleSigma()).squaredNorm();
    const double rms = std::sqrt(sum / (3.0 * gyro.size()));
    std::printf("discrete report: %s gyro whitened RMS per sample %.3f (preintegrated %.3f)\n",
                s.name.c_str(), rms, *stats.rms_whitened_gyro);
    // Measured 3.8 - 4.3 on the 8 s recording (3.2 - 3.6 on the 5 s one): the cubic rotation
    // between 0.05 s keyframes is the larger part; a wrong frame or clock gives hundreds.
    EXPECT_GT(rms, 0.5) << s.name;
    EXPECT_LT(rms, 10.0) << s.name;
  }
  fs::remove_all(root);
}

// A camera-only rig (SPEC section 7) gets the same report from its own model: camera sections with
// every corner, the correlation, and no trajectory (omitted, saying why).
TEST(CalibrateReportCameraOnly, EurocStereo) {
  const fs::path data = fs::path(CTCAL_SHARED_DATA_DIR) / "euroc_cam_april";
  if (!fs::exists(data / "reference.yaml"))
    GTEST_SKIP() << "the shared EuRoC data is absent (" << data << ")";
  const std::string root = report::test::MakeTempDir("ctcal_camonly_report");
  const std::string out = root + "/out";
  const std::string cmd = std::string(CTCAL_BINARY) + " calibrate --rig " +
                          (data / "reference.yaml").string() + " --data " + data.string() +
                          " --out " + out + " > " + root + "/log.txt 2>&1";
  // EuRoC's published rig states 1 px for corners that fit to ~0.2 px (issue 19): the report's
  // whitened RMS checks fail, so `calibrate` exits 3 (SPEC section 8) until the noise is estimated
  // from the data; no other check may fail.
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  ASSERT_TRUE(WEXITSTATUS(status) == 0 || WEXITSTATUS(status) == 3) << Slurp(root + "/log.txt");
  {
    std::istringstream lines(Slurp(root + "/log.txt"));
    for (std::string line; std::getline(lines, line);)
      if (line.rfind("check failed:", 0) == 0) {
        EXPECT_NE(line.find("whitened RMS"), std::string::npos) << line;
      }
  }
  const RigConfig result = LoadRig(out + "/result.yaml");
  const std::string html = Slurp(out + "/report.html");
  for (const std::string cam : {"cam0", "cam1"}) {
    const std::string sec = SectionOf(html, "sec-camera-" + cam);
    ASSERT_FALSE(sec.empty()) << cam;
    EXPECT_EQ(sec.find("class=\"omitted\""), std::string::npos) << cam;
    const auto rows = report::ReadCornerResiduals(report::CornersPath(out, cam));
    double sum = 0.0;
    int n = 0;
    for (const auto& r : rows) {
      if (!r.outlier) {
        sum += r.whitened * r.whitened;
        n += 2;
      }
    }
    const SensorResiduals& stats = result.residuals.at(cam);
    EXPECT_EQ(n, stats.count) << cam;
    EXPECT_NEAR(std::sqrt(sum / n), *stats.rms_whitened, 1e-6 * *stats.rms_whitened) << cam;
  }
  EXPECT_EQ(SectionOf(html, "sec-correlation").find("class=\"omitted\""), std::string::npos);
  EXPECT_NE(SectionOf(html, "sec-trajectory").find("camera-only"), std::string::npos);
  fs::remove_all(root);
}

}  // namespace
}  // namespace ctcal
