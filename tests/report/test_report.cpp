// The report data contract and the report: exact CSV round trips, strict readers, the
// first-page checks, and a full HTML + PDF render of a synthetic calibration folder checked
// page by page (pdftoppm), section by section and figure by figure, plus a headless Chromium
// screenshot of the HTML and the `ctcal report` command.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sstream>
#include <tuple>

#include "ctcal/report/report.h"
#include "ctcal/report/report_data.h"
#include "ctcal/sensors/parameter_names.h"
#include "report_test_util.h"

namespace ctcal::report {
namespace {

namespace fs = std::filesystem;

std::string Slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

class ReportTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::MakeTempDir("ctcal_report"); }
  void TearDown() override { fs::remove_all(dir_); }
  // The synthetic output's report data as read, its cam0 errors unrounded again (the writers
  // round them: a write must not see its own rounding already done).
  ReportData UnroundedSyntheticData() const {
    test::MakeSyntheticOut(dir_);
    std::vector<std::string> ignored;
    std::vector<std::string> names;
    for (const auto& s : LoadRig(dir_ + "/result.yaml", &ignored).sensors)
      names.push_back(s.name);
    ReportData data = LoadReportData(dir_, names);
    for (CornerResidual& c : data.corners.at("cam0"))
      c.du += 1e-9;
    return data;
  }
  std::string dir_;
};

TEST_F(ReportTest, DataFilesRoundTrip) {
  std::vector<CornerResidual> c(2);
  c[0] = {123456789012345, 3, 17, 10.125, 479.5, 0.1, -1.0 / 3.0, 0.7, false};
  c[1] = {
      123456789012346, 4, 0, 1e-300, 2.5, std::numeric_limits<double>::infinity(), 0.0, 5.0, true};
  WriteCornerResiduals(dir_, "cam0", c);
  const auto rc = ReadCornerResiduals(CornersPath(dir_, "cam0"));
  ASSERT_EQ(rc.size(), 2u);
  // Corners keep 1e-3 px and the errors 7 significant digits (report_data.h); the rest exactly.
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(rc[i].t_ns, c[i].t_ns);
    EXPECT_EQ(rc[i].frame, c[i].frame);
    EXPECT_EQ(rc[i].corner_id, c[i].corner_id);
    EXPECT_NEAR(rc[i].u, c[i].u, 5e-4);
    EXPECT_NEAR(rc[i].v, c[i].v, 5e-4);
    if (std::isinf(c[i].du))
      EXPECT_EQ(rc[i].du, c[i].du);
    else
      EXPECT_NEAR(rc[i].du, c[i].du, 5e-7 * std::abs(c[i].du));
    EXPECT_NEAR(rc[i].dv, c[i].dv, 5e-7 * std::abs(c[i].dv));
    EXPECT_NEAR(rc[i].whitened, c[i].whitened, 5e-7 * c[i].whitened);
    EXPECT_EQ(rc[i].outlier, c[i].outlier);
  }
  EXPECT_EQ(rc[0].u, 10.125);  // exactly representable at 1e-3
  // The sample tables are gzip files (magic 1f 8b); a plain `.csv` of an older folder reads too.
  {
    std::ifstream gz(CornersPath(dir_, "cam0"), std::ios::binary);
    unsigned char magic[2] = {0, 0};
    gz.read(reinterpret_cast<char*>(magic), 2);
    EXPECT_EQ(magic[0], 0x1f);
    EXPECT_EQ(magic[1], 0x8b);
    const std::string gz_path = CornersPath(dir_, "cam1");
    const std::string plain = gz_path.substr(0, gz_path.size() - 3);
    ASSERT_EQ(plain.substr(plain.size() - 4), ".csv");
    std::ofstream(plain) << "#t_ns,frame,corner_id,u,v,du,dv,whitened,outlier\n"
                         << "7,0,3,1.5,2.5,0.25,-0.5,0.75,0\n";
    const auto old = ReadCornerResiduals(gz_path);
    ASSERT_EQ(old.size(), 1u);
    EXPECT_EQ(old[0].dv, -0.5);
  }
  const std::vector<InertialSample> g = {{5, {0.1, 0.2, 1.0 / 7.0}, {-3e-9, 4, 5}}};
  WriteGyroSamples(dir_, "imu0", g);
  const auto rg = ReadInertialSamples(GyroPath(dir_, "imu0"));
  ASSERT_EQ(rg.size(), 1u);
  EXPECT_EQ(rg[0].t_ns, 5);
  EXPECT_EQ(rg[0].meas, g[0].meas);
  EXPECT_EQ(rg[0].pred, g[0].pred);
  BiasTrack b;
  b.gyro = {{1, {1, 2, 3}, {0.1, 0.2, 0.3}}};
  b.accel = {{2, {4, 5, 6}, {0.4, 0.5, 1.0 / 3.0}}, {3, {7, 8, 9}, {1, 1, 1}}};
  WriteBiasTrack(dir_, "imu0", b);
  const auto rb = ReadBiasTrack(BiasPath(dir_, "imu0"));
  ASSERT_EQ(rb.gyro.size(), 1u);
  ASSERT_EQ(rb.accel.size(), 2u);
  EXPECT_NEAR((rb.accel[0].sigma - b.accel[0].sigma).norm(), 0.0, 1e-7);  // 7 digits
  EXPECT_EQ(rb.accel[1].t_ns, 3);
  PoseSample p;
  p.t_ns = 9;
  p.p_W_B = {1.0 / 3.0, 2, 3};
  p.q_W_B = Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  WriteTrajectory(dir_, {p});
  const auto rt = ReadTrajectory(TrajectoryPath(dir_));
  ASSERT_EQ(rt.size(), 1u);
  EXPECT_EQ(rt[0].p_W_B, p.p_W_B);
  EXPECT_EQ(rt[0].q_W_B.coeffs(), p.q_W_B.coeffs());
  Correlation corr;
  corr.names = {"cam0.intrinsics[0]", "imu1.t_B_S[2]"};
  corr.values.resize(2, 2);
  corr.values << 1, -0.123456789, -0.123456789, 1;
  WriteCorrelation(dir_, corr);
  const auto rcorr = ReadCorrelation(CorrelationPath(dir_));
  EXPECT_EQ(rcorr.names, corr.names);
  EXPECT_EQ(rcorr.values, corr.values);
  const RunInfo info = {{"command", "ctcal calibrate --rig a,b"}, {"ceres", "2.1"}};
  WriteRunInfo(dir_, info);
  EXPECT_EQ(ReadRunInfo(RunInfoPath(dir_)), info);
  // Missing files read as empty.
  EXPECT_TRUE(ReadCornerResiduals(CornersPath(dir_, "cam9")).empty());
  EXPECT_TRUE(ReadCorrelation(dir_ + "/nope.csv").names.empty());
}

TEST_F(ReportTest, MalformedDataNamesFileAndLine) {
  fs::create_directories(ReportDataDir(dir_));
  const std::string path = CornersPath(dir_, "cam0");
  std::ofstream(path) << "#t_ns,frame,corner_id,u,v,du,dv,whitened,outlier\n"
                      << "1,0,0,1,2,3,4,5,0\n"
                      << "2,0,0,1,2,x3,4,5,0\n";
  try {
    ReadCornerResiduals(path);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path + ":3: 'x3' is not a number"), std::string::npos)
        << e.what();
  }
  std::ofstream(path) << "1,0,0,1,2,3,4,5\n";
  EXPECT_THROW(ReadCornerResiduals(path), std::runtime_error);
  std::ofstream(BiasPath(dir_, "imu0")) << "1,0,0,0,1,1,1,mag\n";
  try {
    ReadBiasTrack(BiasPath(dir_, "imu0"));
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(":1: part must be gyro or accel"), std::string::npos);
  }
  std::ofstream(CorrelationPath(dir_)) << "#name,a,b\na,1,0\nc,0,1\n";
  EXPECT_THROW(ReadCorrelation(CorrelationPath(dir_)), std::runtime_error);
}

// The readers (one pass over the text, cells as views, from_chars) take what they took before
// (CRLF line ends, '+' and blanks before an integer as std::stoll took them, YAML's .nan and .inf)
// and name the file and line of anything else with the same messages.
TEST_F(ReportTest, ReadersKeepTheirInputsAndTheirMessages) {
  fs::create_directories(ReportDataDir(dir_));
  const std::string path = GyroPath(dir_, "imu0");
  std::ofstream(path) << "#t_ns,meas_x,meas_y,meas_z,pred_x,pred_y,pred_z\r\n"
                      << "+5,1,.nan,-.inf,1e-3,-0.0,2\r\n"
                      << " 6,1,2,3,4,5,6\n\n";
  const std::vector<InertialSample> rows = ReadInertialSamples(path);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].t_ns, 5);
  EXPECT_TRUE(std::isnan(rows[0].meas.y()));
  EXPECT_EQ(rows[0].meas.z(), -std::numeric_limits<double>::infinity());
  EXPECT_EQ(rows[0].pred.x(), 1e-3);
  EXPECT_EQ(rows[1].t_ns, 6);
  const auto message = [&](const std::string& text) {
    std::ofstream(path) << "#t_ns,meas_x,meas_y,meas_z,pred_x,pred_y,pred_z\n"
                        << "1,1,2,3,4,5,6\n"
                        << text;
    try {
      ReadInertialSamples(path);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message("1.5,1,2,3,4,5,6\n"), path + ":3: '1.5' is not an integer");
  EXPECT_EQ(message("2,1,2,3,4,5\n"), path + ":3: expected 7 columns, got 6");
  EXPECT_EQ(message("2,1,2,3,4,5,6,\n"), path + ":3: expected 7 columns, got 8");
  EXPECT_EQ(message("2,1,2,3,4,5,1e999x\n"), path + ":3: '1e999x' is not a number");
  EXPECT_EQ(message("2,1,2,3,4,,6\n"), path + ":3: '' is not a number");
  const std::string corners = CornersPath(dir_, "cam0");
  std::ofstream(corners) << "1,0,0,1,2,3,4,5,2\n";
  try {
    ReadCornerResiduals(corners);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), corners + ":1: outlier must be 0 or 1, got 2");
  }
}

TEST(ReportChecks, CoverageCountsInlierCells) {
  std::vector<CornerResidual> c;
  auto at = [&](double u, double v, bool outlier) {
    CornerResidual r;
    r.u = u;
    r.v = v;
    r.outlier = outlier;
    c.push_back(r);
  };
  at(10, 10, false);    // cell (0, 0) of 4x4 over 100x100
  at(99, 99, false);    // cell (3, 3)
  at(50, 10, true);     // outlier: not counted
  at(1000, 10, false);  // off the image
  EXPECT_DOUBLE_EQ(Coverage(c, 100, 100, 4), 2.0 / 16.0);
}

TEST_F(ReportTest, ChecksFollowTheThresholds) {
  const test::SyntheticOut s = test::MakeSyntheticOut(dir_);
  const ReportData data = LoadReportData(dir_, {"cam0", "imu0"});
  const auto checks = EvaluateChecks(s.rig, data);
  auto find = [&](const std::string& name, const std::string& sensor) {
    for (const auto& c : checks)
      if (c.name == name && c.sensor == sensor)
        return c;
    ADD_FAILURE() << "no check " << name << " " << sensor;
    return Check{};
  };
  EXPECT_EQ(find("whitened RMS", "cam0").status, Status::kPass);  // 1.05
  EXPECT_EQ(find("whitened RMS", "imu0").status, Status::kWarn);  // 1.6
  const Check o = find("outlier fraction", "cam0");
  EXPECT_EQ(o.status, Status::kPass);  // 15 of 1400
  EXPECT_NE(o.value.find("of " + std::to_string(s.corners)), std::string::npos);
  EXPECT_EQ(find("observability", "").status, Status::kWarn);  // one weak parameter
  RigConfig bad = s.rig;
  bad.residuals["cam0"].rms_whitened = 0.3;
  bad.observability->unobservable = {"imu0.Tg[0]"};
  const auto bad_checks = EvaluateChecks(bad, data);
  for (const auto& c : bad_checks) {
    if ((c.name == "whitened RMS" && c.sensor == "cam0") || c.name == "observability") {
      EXPECT_EQ(c.status, Status::kFail) << c.name;
    }
  }
}

TEST_F(ReportTest, RendersEverySectionAndEveryPdfPageHasContent) {
  test::MakeSyntheticOut(dir_);
  ReportOptions opt;
  opt.ctcal_version = "test";
  const ReportOutput out = RenderReport(dir_, opt);
  ASSERT_TRUE(fs::exists(out.html_path));
  ASSERT_TRUE(fs::exists(out.pdf_path));
  const std::string html = Slurp(out.html_path);
  // Self-contained: no external resource.
  EXPECT_EQ(html.find("http://"), std::string::npos);
  EXPECT_EQ(html.find("https://"), std::string::npos);
  EXPECT_EQ(html.find("src=\"file"), std::string::npos);
  for (const std::string id :
       {"sec-summary", "sec-parameters", "sec-kalibr", "sec-trajectory", "sec-imu-imu0",
        "sec-imu-imu1", "sec-imu-gyro0", "sec-camera-cam0", "sec-histograms", "sec-correlation",
        "sec-observability", "sec-crosscheck", "sec-config"}) {
    EXPECT_NE(html.find("<section id=\"" + id + "\">"), std::string::npos) << id;
  }
  for (const std::string id :
       {"fig-summary", "fig-parameters", "fig-kalibr-camchain", "fig-kalibr-imu", "fig-trajectory",
        "fig-imu0-intervals", "fig-imu0-gyro", "fig-imu0-gyro-error", "fig-imu0-accel",
        "fig-imu0-accel-error", "fig-imu0-bias", "fig-cam0-residuals", "fig-cam0-image",
        "fig-cam0-distortion", "fig-histograms", "fig-correlation", "fig-observability",
        "fig-excitation", "fig-config"}) {
    EXPECT_NE(html.find("id=\"" + id + "\""), std::string::npos) << id;
    EXPECT_NE(std::find(out.figure_ids.begin(), out.figure_ids.end(), id), out.figure_ids.end())
        << id;
  }
  // Sensors without data and the absent cross-check are omitted with a note, not drawn empty.
  for (const std::string id : {"sec-imu-imu1", "sec-imu-gyro0", "sec-crosscheck"}) {
    const auto at = html.find("<section id=\"" + id + "\">");
    ASSERT_NE(at, std::string::npos);
    const auto end = html.find("</section>", at);
    const std::string sec = html.substr(at, end - at);
    EXPECT_NE(sec.find("class=\"omitted\""), std::string::npos) << id;
    EXPECT_EQ(sec.find("<img"), std::string::npos) << id;
  }
  // Figures are inlined (std::regex would overflow its stack on the base64, so count by hand).
  int images = 0;
  for (auto at = html.find("data:image/png;base64,"); at != std::string::npos;
       at = html.find("data:image/png;base64,", at + 1))
    ++images;
  EXPECT_GE(images, 12);

  // The PDF, rasterised page by page.
  ASSERT_EQ(out.pdf_pages, static_cast<int>(out.figure_ids.size()));
  const std::string prefix = dir_ + "/page";
  const std::string cmd = "pdftoppm -r 40 -gray -png " + out.pdf_path + " " + prefix;
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  int pages = 0;
  for (const auto& e : fs::directory_iterator(dir_)) {
    if (e.path().filename().string().rfind("page", 0) != 0)
      continue;
    ++pages;
    const cv::Mat page = cv::imread(e.path().string(), cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(page.empty()) << e.path();
    // Below the title band, the page holds a drawing.
    const cv::Mat body = page(cv::Rect(0, page.rows / 10, page.cols, page.rows * 8 / 10));
    EXPECT_GT(test::PixelStdDev(body), 8.0) << e.path();
  }
  EXPECT_EQ(pages, out.pdf_pages);
}

// The first page, read back from the PDF's text: the checks, every calibrated quantity with its
// sigma, and Kalibr's transformations to paste; the top of the HTML holds the same.
TEST_F(ReportTest, FirstPageHoldsChecksParametersAndKalibrMatrices) {
  const test::SyntheticOut synth = test::MakeSyntheticOut(dir_);
  const ReportOutput out = RenderReport(dir_);
  const std::string txt = dir_ + "/page1.txt";
  ASSERT_EQ(std::system(("pdftotext -layout -f 1 -l 1 " + out.pdf_path + " " + txt).c_str()), 0);
  const std::string page = Slurp(txt);
  for (const std::string s :
       {"whitened RMS", "outlier fraction", "coverage", "observability", "value +- 1 sigma",
        "intrinsics", "time_offset", "t_B_S", "T_cam_imu:", "timeshift_cam_imu:", "T_i_b:"})
    EXPECT_NE(page.find(s), std::string::npos) << s << "\n" << page;
  // Every calibrated quantity has a row: each sensor's keys freed by `estimate:`.
  std::set<std::string> quantities;
  for (const ScalarParameter& p : ScalarParameters(synth.rig, true))
    quantities.insert(p.key);
  for (const std::string& q : quantities)
    EXPECT_NE(page.find(q), std::string::npos) << q;
  // cam0's fx with its sigma 0.3 px: "<value> +- 0.30".
  EXPECT_NE(page.find("+- 0.30"), std::string::npos) << page;
  const std::string html = Slurp(out.html_path);
  const auto summary = html.find("<section id=\"sec-summary\">");
  const auto next = html.find("</section>", summary);
  const std::string top = html.substr(summary, next - summary);
  EXPECT_NE(top.find("T_cam_imu:"), std::string::npos);
  EXPECT_NE(top.find("class=\"params\""), std::string::npos);
}

TEST_F(ReportTest, CrosscheckTableWhenPresent) {
  test::MakeSyntheticOut(dir_);
  std::ofstream(dir_ + "/crosscheck.yaml")
      << "rows:\n  - {parameter: cam0.time_offset, spline: 0.0101, discrete: 0.0099, "
         "difference_sigma: 0.4}\n";
  ReportOptions opt;
  opt.pdf = false;
  const ReportOutput out = RenderReport(dir_, opt);
  const std::string html = Slurp(out.html_path);
  const auto at = html.find("<section id=\"sec-crosscheck\">");
  ASSERT_NE(at, std::string::npos);
  const std::string sec = html.substr(at, html.find("</section>", at) - at);
  EXPECT_EQ(sec.find("omitted"), std::string::npos);
  EXPECT_NE(sec.find("<th>difference_sigma</th>"), std::string::npos);
  EXPECT_NE(sec.find("<td>0.0099</td>"), std::string::npos);
}

TEST_F(ReportTest, MissingResultIsOneClearError) {
  try {
    RenderReport(dir_);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(dir_ + "/result.yaml: not found"), std::string::npos);
  }
}

TEST_F(ReportTest, HeadlessChromiumScreenshot) {
  const std::string chromium = "/usr/bin/chromium";
  if (!fs::exists(chromium))
    GTEST_SKIP() << "Debian's chromium is not installed (/usr/bin/chromium absent)";
  test::MakeSyntheticOut(dir_);
  ReportOptions opt;
  opt.pdf = false;
  const ReportOutput out = RenderReport(dir_, opt);
  const std::string profile = test::MakeTempDir("ctcal_chromium");
  const std::string shot = dir_ + "/shot.png";
  const std::string cmd = chromium +
                          " --headless --no-sandbox --disable-gpu --disable-quic --no-first-run"
                          " --disable-background-networking --disable-component-update"
                          " --disable-sync --user-data-dir=" +
                          profile + " --window-size=1200,2400 --screenshot=" + shot + " file://" +
                          out.html_path + " >/dev/null 2>&1";
  const int rc = std::system(cmd.c_str());
  fs::remove_all(profile);
  ASSERT_EQ(rc, 0) << cmd;
  const cv::Mat img = cv::imread(shot, cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 1200);
  // The summary table and the first figures are on screen: the page is not blank.
  EXPECT_GT(test::PixelStdDev(img), 20.0);
  EXPECT_GT(test::PixelStdDev(img(cv::Rect(0, 1200, 1200, 1200))), 10.0);
}

TEST_F(ReportTest, CommandLine) {
  const std::string bin = CTCAL_BINARY;
  if (!fs::exists(bin))
    GTEST_SKIP() << "ctcal not built at " << bin;
  test::MakeSyntheticOut(dir_);
  EXPECT_EQ(std::system((bin + " report --out " + dir_ + " >/dev/null").c_str()), 0);
  EXPECT_TRUE(fs::exists(dir_ + "/report.html"));
  EXPECT_TRUE(fs::exists(dir_ + "/report.pdf"));
  const std::string err = dir_ + "/err.txt";
  const int rc = std::system((bin + " report --out " + dir_ + "/nothing 2>" + err).c_str());
  EXPECT_EQ(WEXITSTATUS(rc), 2);
  const std::string text = Slurp(err);
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 1) << text;
  EXPECT_NE(text.find("ctcal report: error: "), std::string::npos) << text;
}

// A `calibrate --method both` folder holds a full result in spline/ and discrete/ and none at the
// top: `ctcal report --out OUT` re-renders both.
TEST_F(ReportTest, CommandLineRendersBothMethodsOfABothFolder) {
  const std::string bin = CTCAL_BINARY;
  if (!fs::exists(bin))
    GTEST_SKIP() << "ctcal not built at " << bin;
  test::MakeSyntheticOut(dir_ + "/spline");
  test::MakeSyntheticOut(dir_ + "/discrete");
  ASSERT_FALSE(fs::exists(dir_ + "/result.yaml"));
  EXPECT_EQ(std::system((bin + " report --out " + dir_ + " >/dev/null").c_str()), 0);
  for (const char* method : {"/spline", "/discrete"}) {
    EXPECT_TRUE(fs::exists(dir_ + method + "/report.html")) << method;
    EXPECT_TRUE(fs::exists(dir_ + method + "/report.pdf")) << method;
  }
  EXPECT_FALSE(fs::exists(dir_ + "/report.html"));
}

// Both methods' figures have the same ids: `--png-dir DIR` of a both folder writes each method's
// below DIR/<method>/ (as the reports are below OUT/<method>/), none over the other's.
TEST_F(ReportTest, PngDirOfABothFolderKeepsEachMethodsFigures) {
  const std::string bin = CTCAL_BINARY;
  if (!fs::exists(bin))
    GTEST_SKIP() << "ctcal not built at " << bin;
  test::MakeSyntheticOut(dir_ + "/spline");
  test::MakeSyntheticOut(dir_ + "/discrete");
  // The discrete trajectory differs, so that its figure must differ from the spline's.
  std::vector<PoseSample> traj = ReadTrajectory(TrajectoryPath(dir_ + "/discrete"));
  for (PoseSample& p : traj)
    p.p_W_B.z() += 0.5 * p.p_W_B.x();
  WriteTrajectory(dir_ + "/discrete", traj);
  const std::string png = dir_ + "/png";
  ASSERT_EQ(
      std::system((bin + " report --out " + dir_ + " --png-dir " + png + " >/dev/null").c_str()),
      0);
  std::set<std::string> spline_ids, discrete_ids;
  for (const auto& [method, ids] :
       {std::pair<std::string, std::set<std::string>*>{"spline", &spline_ids},
        {"discrete", &discrete_ids}}) {
    ASSERT_TRUE(fs::is_directory(png + "/" + method)) << method;
    for (const auto& e : fs::directory_iterator(png + "/" + method))
      ids->insert(e.path().filename().string());
  }
  EXPECT_GT(spline_ids.size(), 10u);
  EXPECT_EQ(spline_ids, discrete_ids);
  EXPECT_TRUE(spline_ids.count("fig-trajectory.png"));
  for (const auto& e : fs::directory_iterator(png))
    EXPECT_TRUE(e.is_directory()) << e.path() << " at the top of --png-dir";
  EXPECT_NE(Slurp(png + "/spline/fig-trajectory.png"), Slurp(png + "/discrete/fig-trajectory.png"));
}

// WriteReportData returns the data as the files hold them: what LoadReportData reads back, to the
// bit; the rounded columns hold printf's digits ("%.3f" for u, v, "%.7g" for the errors and the
// bias rows), the others the exact values; a table longer than one gzip member (4 MiB of text)
// reads back whole.
TEST_F(ReportTest, WrittenDataAreWhatTheFilesHoldToTheBit) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> pixel(-50.0, 800.0), err(-3.0, 3.0);
  const auto printf_value = [](const char* format, double x) {
    char buf[64];
    std::snprintf(buf, sizeof buf, format, x);
    return std::strtod(buf, nullptr);
  };
  ReportData d;
  std::vector<CornerResidual>& corners = d.corners["cam0"];
  for (int i = 0; i < 80000; ++i) {  // ~5.6 MB of text: two gzip members
    CornerResidual c;
    c.t_ns = 1'000'000'000LL + 33'333'333LL * (i / 40);
    c.frame = i / 40;
    c.corner_id = i % 40;
    c.u = pixel(rng);
    c.v = i % 1000 == 0 ? 0.0005 : pixel(rng);  // a tie for "%.3f"
    c.du = err(rng) * std::pow(10.0, -(i % 9));
    c.dv = i == 7 ? std::numeric_limits<double>::quiet_NaN() : -0.0;
    c.whitened = std::hypot(c.du, c.v);
    c.outlier = i % 13 == 0;
    corners.push_back(c);
  }
  BiasSample b{5, Eigen::Vector3d(1.23456789e-3, -2.5e-7, 1.0 / 3.0), Eigen::Vector3d(1, 2, 3)};
  d.bias["imu0"].gyro.push_back(b);
  d.gyro["imu0"].push_back({5, Eigen::Vector3d(0.1, 1.0 / 7.0, -3e-300), Eigen::Vector3d(1, 2, 3)});
  d.trajectory.push_back({5, Eigen::Vector3d(0.1, 0.2, 1.0 / 3.0), Eigen::Quaterniond(1, 0, 0, 0)});
  d.run_info = {{"command", "ctcal calibrate --out a,b"}};

  const ReportData stored = WriteReportData(dir_, d, 2);
  const ReportData read = LoadReportData(dir_, {"cam0", "imu0"}, 2);
  const auto same = [](double x, double y) {
    return std::memcmp(&x, &y, sizeof x) == 0 || (std::isnan(x) && std::isnan(y));
  };
  ASSERT_EQ(read.corners.at("cam0").size(), corners.size());
  for (size_t i = 0; i < corners.size(); ++i) {
    const CornerResidual &s = stored.corners.at("cam0")[i], &r = read.corners.at("cam0")[i],
                         &c = corners[i];
    ASSERT_EQ(r.t_ns, c.t_ns);
    ASSERT_EQ(r.frame, c.frame);
    ASSERT_EQ(r.corner_id, c.corner_id);
    ASSERT_EQ(r.outlier, c.outlier);
    for (const auto& [sv, rv, want] :
         {std::tuple{s.u, r.u, printf_value("%.3f", c.u)},
          std::tuple{s.v, r.v, printf_value("%.3f", c.v)},
          std::tuple{s.du, r.du, printf_value("%.7g", c.du)},
          std::tuple{s.dv, r.dv, std::isnan(c.dv) ? c.dv : printf_value("%.7g", c.dv)},
          std::tuple{s.whitened, r.whitened, printf_value("%.7g", c.whitened)}}) {
      ASSERT_TRUE(same(sv, rv)) << "row " << i << ": " << sv << " written, " << rv << " read";
      ASSERT_TRUE(same(rv, want)) << "row " << i << ": " << rv << " read, printf gives " << want;
    }
  }
  for (int k = 0; k < 3; ++k) {
    EXPECT_TRUE(same(read.bias.at("imu0").gyro[0].b[k], printf_value("%.7g", b.b[k])));
    EXPECT_TRUE(same(stored.bias.at("imu0").gyro[0].b[k], read.bias.at("imu0").gyro[0].b[k]));
    EXPECT_TRUE(same(read.gyro.at("imu0")[0].meas[k], d.gyro.at("imu0")[0].meas[k]));
    EXPECT_TRUE(same(read.trajectory[0].p_W_B[k], d.trajectory[0].p_W_B[k]));
  }
  EXPECT_EQ(read.run_info, d.run_info);
}

// A corner coordinate whose "%.3f" does not fit the writer's buffer (1e60 and beyond: a diverged
// prediction handed to the public writer) is written exactly, as the non-finite values are; the
// writer appended its unwritten buffer before.
TEST_F(ReportTest, CornerCoordinatesTooLongForFixedPointAreWrittenExactly) {
  ReportData d;
  CornerResidual c{7, 0, 1, 1e300, -2.5e61, 1e300, 0.5, 1.0, false};
  d.corners["cam0"] = {c};
  const ReportData stored = WriteReportData(dir_, d, 1);
  const std::vector<CornerResidual> read = ReadCornerResiduals(CornersPath(dir_, "cam0"));
  ASSERT_EQ(read.size(), 1u);
  EXPECT_EQ(read[0].u, c.u);
  EXPECT_EQ(read[0].v, c.v);
  EXPECT_EQ(stored.corners.at("cam0")[0].u, c.u);
  EXPECT_EQ(read[0].du, 1e300);  // "%.7g" fits
  EXPECT_EQ(read[0].dv, 0.5);
}

// `ctcal calibrate` renders the report from the data it has just written, `ctcal report` from the
// folder: the same HTML, byte for byte.
TEST_F(ReportTest, ReportFromMemoryEqualsReportFromTheFolder) {
  const ReportData data = UnroundedSyntheticData();
  const ReportData stored = WriteReportData(dir_, data, 2);
  ReportOptions opt;
  opt.ctcal_version = "test";
  opt.pdf = false;
  RenderReport(dir_, stored, opt);
  const std::string from_memory = Slurp(dir_ + "/report.html");
  RenderReport(dir_, opt);
  EXPECT_EQ(from_memory, Slurp(dir_ + "/report.html"));
}

// `ctcal calibrate` writes the report data in two halves, the exact tables while it draws the
// report: the same files as WriteReportData, byte for byte, and the same data drawn.
TEST_F(ReportTest, WritingInTwoHalvesWritesTheSameFilesAndData) {
  const ReportData data = UnroundedSyntheticData();
  const std::string whole = dir_ + "/whole", halves = dir_ + "/halves";
  const ReportData a = WriteReportData(whole, data, 2);
  const ReportData b = WriteRoundedReportData(halves, data, 2);
  WriteExactReportData(halves, b, 1);
  std::set<std::string> files;
  for (const auto& e : fs::directory_iterator(ReportDataDir(whole)))
    files.insert(e.path().filename().string());
  std::set<std::string> files_b;
  for (const auto& e : fs::directory_iterator(ReportDataDir(halves)))
    files_b.insert(e.path().filename().string());
  EXPECT_EQ(files, files_b);
  // corners, bias, gyro, accel, trajectory, correlation, run info: both halves have files.
  EXPECT_GE(files.size(), 7u);
  for (const std::string& f : files)
    EXPECT_EQ(Slurp(ReportDataDir(whole) + "/" + f), Slurp(ReportDataDir(halves) + "/" + f)) << f;
  ASSERT_EQ(a.corners.at("cam0").size(), b.corners.at("cam0").size());
  for (size_t i = 0; i < a.corners.at("cam0").size(); ++i) {
    const CornerResidual &x = a.corners.at("cam0")[i], &y = b.corners.at("cam0")[i];
    ASSERT_EQ(std::memcmp(&x.du, &y.du, sizeof x.du), 0) << i;
    ASSERT_EQ(std::memcmp(&x.u, &y.u, sizeof x.u), 0) << i;
  }
  ASSERT_EQ(a.bias.size(), b.bias.size());
  for (const auto& [sensor, track] : a.bias)
    for (size_t i = 0; i < track.gyro.size(); ++i)
      ASSERT_EQ(track.gyro[i].b, b.bias.at(sensor).gyro[i].b) << sensor << " " << i;
}

}  // namespace
}  // namespace ctcal::report
