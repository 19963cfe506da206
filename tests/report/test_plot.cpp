// The plotting library: a plot with data draws something, a plot without finite data says so on
// the page instead of crashing or drawing empty axes, and the three outputs are well formed.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "ctcal/report/plot.h"
#include "report_test_util.h"

namespace ctcal::report {
namespace {

cv::Mat Decode(const std::string& png) {
  const std::vector<uchar> bytes(png.begin(), png.end());
  return cv::imdecode(bytes, cv::IMREAD_GRAYSCALE);
}

// The plotted area only (no title, no tick labels): x 70..(w-20), y 30..(h-45) of a 1x1 figure.
double PlotAreaStdDev(const Figure& f) {
  const cv::Mat img = Decode(RenderPng(f));
  return test::PixelStdDev(img(cv::Rect(80, 40, img.cols - 110, img.rows - 90)));
}

Figure LineFigure(const std::vector<double>& y) {
  Figure f(1, 1, 400, 300);
  auto& p = f.Add<XYPlot>();
  std::vector<double> x;
  for (size_t i = 0; i < y.size(); ++i)
    x.push_back(static_cast<double>(i));
  p.Line(x, y, "data", PaletteColor(0), 2.0);
  return f;
}

// `f` as the one page of DIR/f.pdf in a new temporary DIR, which it returns.
std::string WritePdf(const Figure& f) {
  const std::string dir = test::MakeTempDir("ctcal_plot");
  PdfDocument pdf(dir + "/f.pdf");
  pdf.AddPage(f);
  pdf.Close();
  return dir;
}

std::string PdfText(const Figure& f) {
  const std::string dir = WritePdf(f);
  const std::string cmd = "pdftotext " + dir + "/f.pdf " + dir + "/f.txt";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream t(dir + "/f.txt");
  std::stringstream ss;
  ss << t.rdbuf();
  std::filesystem::remove_all(dir);
  return ss.str();
}

TEST(Plot, LinePlotWithDataIsNotBlank) {
  std::vector<double> y;
  for (int i = 0; i < 100; ++i)
    y.push_back(std::sin(0.1 * i));
  const Figure f = LineFigure(y);
  EXPECT_TRUE(f.HasData());
  EXPECT_GT(PlotAreaStdDev(f), 10.0);
}

TEST(Plot, NanDataSaysSoInsteadOfPlotting) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Figure f = LineFigure({nan, nan, INFINITY, nan});
  EXPECT_FALSE(f.HasData());
  EXPECT_NE(PdfText(f).find("no finite data to plot"), std::string::npos);
  // Also an empty heat map, trajectory and correlation matrix: drawn with a note, no crash.
  Figure g(1, 3, 900, 300);
  g.Add<HeatMap>().values = Eigen::MatrixXd::Constant(3, 3, nan);
  g.Add<Trajectory3D>().p_W = {Eigen::Vector3d::Constant(nan)};
  g.Add<MatrixPlot>();
  EXPECT_FALSE(g.HasData());
  const std::string text = PdfText(g);
  EXPECT_NE(text.find("no finite data to plot"), std::string::npos);
  EXPECT_NE(text.find("no finite poses to plot"), std::string::npos);
  EXPECT_NE(text.find("no correlation data"), std::string::npos);
}

TEST(Plot, PartlyNanDataIsPlotted) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> y;
  for (int i = 0; i < 100; ++i)
    y.push_back(i % 10 == 0 ? nan : std::sin(0.1 * i));
  const Figure f = LineFigure(y);
  EXPECT_TRUE(f.HasData());
  EXPECT_GT(PlotAreaStdDev(f), 10.0);
  EXPECT_EQ(PdfText(f).find("no finite data"), std::string::npos);
}

TEST(Plot, HistogramIsADensity) {
  XYPlot p;
  std::vector<double> v;
  for (int i = 0; i < 1200; ++i)
    v.push_back(-3.0 + 6.0 * (i + 0.5) / 1200.0);  // uniform on [-3, 3], 100 per bin
  const Series& s = p.Histogram(v, 12, -3, 3, "", PaletteColor(0));
  double area = 0;
  for (size_t i = 0; i < s.y.size(); ++i) {
    area += s.y[i] * (s.x0[i] - s.x[i]);
    EXPECT_NEAR(s.y[i], 1.0 / 6.0, 1e-12);
  }
  EXPECT_NEAR(area, 1.0, 1e-12);
  // Values outside the range keep the total honest: the density no longer integrates to 1.
  v.push_back(100.0);
  const Series& t = p.Histogram(v, 12, -3, 3, "", PaletteColor(0));
  EXPECT_NEAR(t.y[0], 1.0 / 6.0 * 1200.0 / 1201.0, 1e-12);
}

TEST(Plot, EveryPanelKindDrawsToPngSvgAndPdf) {
  Figure f(2, 3, 900, 600);
  f.title = "all panels";
  auto& sc = f.Add<XYPlot>();
  sc.ScatterByValue({1, 2, 3}, {3, 1, 2}, {0, 1, 2});
  sc.Band({0, 4}, {-1, -1}, {1, 1}, "band", PaletteColor(2));
  auto& hm = f.Add<HeatMap>();
  hm.values = Eigen::MatrixXd::Random(4, 6);
  auto& tb = f.Add<Table>();
  tb.AddRow({"a", "b"});
  tb.AddRow({"1", "2"});
  auto& tr = f.Add<Trajectory3D>();
  for (int i = 0; i < 50; ++i) {
    tr.p_W.emplace_back(std::cos(0.1 * i), std::sin(0.1 * i), 0.01 * i);
    tr.R_W.push_back(Eigen::Matrix3d::Identity());
  }
  auto& mp = f.Add<MatrixPlot>();
  mp.values = Eigen::MatrixXd::Identity(3, 3);
  mp.names = {"a", "b", "c"};
  f.Add<TextPanel>().lines = std::vector<std::string>(12, "a line of text in the panel");
  for (const auto& p : f.panels())
    EXPECT_TRUE(p->HasData());
  const cv::Mat img = Decode(RenderPng(f));
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 900);
  EXPECT_EQ(img.rows, 600);
  // Every grid cell holds a drawing.
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 3; ++c)
      EXPECT_GT(test::PixelStdDev(img(cv::Rect(c * 300 + 20, r * 285 + 40, 260, 230))), 5.0)
          << "cell " << r << "," << c;
  const std::string svg = RenderSvg(f);
  EXPECT_NE(svg.find("<svg"), std::string::npos);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
}

// Vector dots (a scatter of up to a few thousand points) are discs of the series' radius in the
// PNG and on the PDF page alike: the page draws each as a zero-length round-capped stroke, which
// both cairo and a PDF renderer (poppler's pdftoppm here) must paint as a filled circle.
TEST(Plot, ScatterDotsAreDiscsOfTheirRadiusInPngAndPdf) {
  Figure f(1, 1, 400, 300);
  auto& p = f.Add<XYPlot>();
  p.x_min = 0.0;
  p.x_max = 10.0;
  p.y_min = 0.0;
  p.y_max = 10.0;
  p.legend = false;
  constexpr double kRadius = 5.0;  // pt
  p.Scatter({2.5, 5.0, 7.5}, {2.5, 7.5, 5.0}, "", Color{0, 0, 0, 1}, kRadius);
  const auto dark_area = [](const cv::Mat& gray) {
    // The dots only: the plot area inside the frame (no ticks or labels), pixels below mid-grey.
    const cv::Mat inner = gray(cv::Rect(90, 50, gray.cols - 130, gray.rows - 110));
    return static_cast<double>(cv::countNonZero(inner < 128));
  };
  const double disc = M_PI * kRadius * kRadius;  // px at 1 px per pt
  const double png = dark_area(Decode(RenderPng(f, 1.0)));
  EXPECT_NEAR(png, 3.0 * disc, 0.25 * 3.0 * disc);
  const std::string dir = WritePdf(f);
  const std::string cmd = "pdftoppm -r 72 -gray -png " + dir + "/f.pdf " + dir + "/page";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const cv::Mat page = cv::imread(dir + "/page-1.png", cv::IMREAD_GRAYSCALE);
  std::filesystem::remove_all(dir);
  ASSERT_FALSE(page.empty());
  ASSERT_EQ(page.cols, 400);
  EXPECT_NEAR(dark_area(page), png, 0.25 * png);
}

TEST(Plot, UnwritablePdfThrowsNamingThePath) {
  try {
    PdfDocument pdf("/nonexistent_dir_ctcal/x.pdf");
    pdf.Close();
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent_dir_ctcal/x.pdf"), std::string::npos);
  }
}

TEST(Plot, FormatNumber) {
  EXPECT_EQ(FormatNumber(0.0), "0");
  EXPECT_EQ(FormatNumber(1.5), "1.5");
  EXPECT_EQ(FormatNumber(2e-5, 3), "2.0e-05");
  EXPECT_EQ(FormatNumber(std::numeric_limits<double>::infinity()), "inf");
  EXPECT_EQ(FormatNumber(std::nan("")), "nan");
}

}  // namespace
}  // namespace ctcal::report
