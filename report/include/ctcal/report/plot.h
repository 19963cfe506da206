// A small plotting library on cairo for the calibration report: figures made of panels (x-y
// plots, heat maps, tables, a 3-D trajectory view, a correlation matrix, text), drawn with one
// consistent style to PNG files, SVG strings (inline HTML) and PDF pages.
//
// A figure is a grid of panels; a panel is plain data until it is drawn, so building a figure
// cannot fail. A panel with no finite data draws a visible "no data" note instead of empty axes
// (a report must never show an empty plot as if it were a result); HasData() lets callers leave
// such a figure out.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace ctcal::report {

struct Color {
  double r = 0.0, g = 0.0, b = 0.0, a = 1.0;
};

// Categorical colours (tab10-like), cycling.
Color PaletteColor(int i);
// Sequential colour map (viridis), t clamped to [0, 1].
Color Viridis(double t);
// Diverging colour map (blue - white - red), t clamped to [-1, 1].
Color Diverging(double t);
inline const Color kPass{0.18, 0.62, 0.27};
inline const Color kWarn{0.93, 0.62, 0.10};
inline const Color kFail{0.84, 0.19, 0.15};

// Where the plotted area of a panel lies, in device units.
struct Rect {
  double x = 0.0, y = 0.0, w = 0.0, h = 0.0;
};

class Panel {
 public:
  virtual ~Panel() = default;
  // Draws into `area` of a cairo context (passed as void* so that cairo stays out of this header).
  virtual void Draw(void* cairo, const Rect& area) const = 0;
  // Whether the panel has anything finite to show.
  virtual bool HasData() const = 0;

  std::string title;
};

// ---------------------------------------------------------------------------------------------
// x-y plot: lines, scatter (optionally coloured by a value, with a colour bar), bands (fill
// between two curves, e.g. +-3 sigma), histogram bars, arrows (vector fields), horizontal lines.
struct Series {
  enum class Kind { kLine, kScatter, kBand, kBars, kArrows, kHLine, kStep };
  Kind kind = Kind::kLine;
  std::vector<double> x, y;
  std::vector<double> y2;     // band: upper curve (y is the lower one); arrows: dy (x: dx)
  std::vector<double> x0;     // arrows: start x (y0 in y2 is unused); bars: right bin edges
  std::vector<double> y0;     // arrows: start y
  std::vector<double> value;  // scatter: colour by value (viridis), empty: `color`
  std::string label;          // empty: not in the legend
  Color color = PaletteColor(0);
  double width = 1.5;  // line width, marker radius, arrow width
  bool dashed = false;
};

class XYPlot : public Panel {
 public:
  std::string x_label, y_label;
  std::string value_label;  // colour-bar label for scatter-by-value
  std::vector<Series> series;
  bool legend = true;
  bool equal_aspect = false;  // same scale on x and y (image-plane plots)
  bool y_down = false;        // y grows downwards (image coordinates)
  // Fixed axis ranges; NaN: from the data.
  double x_min = std::numeric_limits<double>::quiet_NaN(), x_max = x_min, y_min = x_min,
         y_max = x_min;

  Series& Line(const std::vector<double>& x, const std::vector<double>& y, const std::string& label,
               Color c, double width = 1.5);
  Series& Scatter(const std::vector<double>& x, const std::vector<double>& y,
                  const std::string& label, Color c, double radius = 2.0);
  Series& ScatterByValue(const std::vector<double>& x, const std::vector<double>& y,
                         const std::vector<double>& value, double radius = 2.0);
  Series& Band(const std::vector<double>& x, const std::vector<double>& lower,
               const std::vector<double>& upper, const std::string& label, Color c);
  Series& HLine(double y, const std::string& label, Color c, bool dashed = true);
  Series& Arrows(const std::vector<double>& x0, const std::vector<double>& y0,
                 const std::vector<double>& dx, const std::vector<double>& dy, Color c);
  // Histogram of the finite values over `bins` equal bins on [lo, hi], normalised to a density
  // (area 1) so that a density curve can be overlaid. Returns the bars.
  Series& Histogram(const std::vector<double>& values, int bins, double lo, double hi,
                    const std::string& label, Color c);
  // The standard normal density on [lo, hi], the reference of whitened residuals.
  Series& NormalDensity(double lo, double hi, Color c);

  void Draw(void* cairo, const Rect& area) const override;
  bool HasData() const override;
};

// ---------------------------------------------------------------------------------------------
// A grid of values over a rectangle (e.g. mean reprojection error per image cell), with a colour
// bar. values(r, c): row r from y_lo (top when y_down), column c from x_lo. NaN cells are grey.
class HeatMap : public Panel {
 public:
  Eigen::MatrixXd values;
  double x_lo = 0.0, x_hi = 1.0, y_lo = 0.0, y_hi = 1.0;
  bool y_down = true;
  std::string x_label, y_label, value_label;
  // Colour range; NaN: from the data (min..max of finite values).
  double v_min = std::numeric_limits<double>::quiet_NaN(), v_max = v_min;

  void Draw(void* cairo, const Rect& area) const override;
  bool HasData() const override;
};

// ---------------------------------------------------------------------------------------------
// A table; a cell may carry a background (status) colour. The first row is the header.
class Table : public Panel {
 public:
  struct Cell {
    std::string text;
    bool has_fill = false;
    Color fill;
    bool monospace = false;
  };
  std::vector<std::vector<Cell>> rows;
  double font_size = 10.0;
  // > 0: a table too wide or too long for its panel is drawn with a smaller font, down to this
  // size, before cells are cut and the rows beyond the panel are left out.
  double min_font_size = 0.0;

  void AddRow(const std::vector<std::string>& texts);
  void Draw(void* cairo, const Rect& area) const override;
  bool HasData() const override { return rows.size() > 1; }
};

// ---------------------------------------------------------------------------------------------
// Orthographic view of a trajectory: the path, and an axes triad (x red, y green, z blue) at
// every `triad_every`-th pose. Viewed from azimuth / elevation (degrees) about the world z axis.
class Trajectory3D : public Panel {
 public:
  std::vector<Eigen::Vector3d> p_W;  // positions
  std::vector<Eigen::Matrix3d> R_W;  // orientations (same length, or empty: no triads)
  std::vector<double> t;             // colours the path by time when given
  int triad_every = 20;
  double azimuth_deg = -60.0, elevation_deg = 25.0;

  void Draw(void* cairo, const Rect& area) const override;
  bool HasData() const override;
};

// ---------------------------------------------------------------------------------------------
// A symmetric matrix in [-1, 1] with named rows (correlations), diverging colours.
class MatrixPlot : public Panel {
 public:
  Eigen::MatrixXd values;
  std::vector<std::string> names;

  void Draw(void* cairo, const Rect& area) const override;
  bool HasData() const override;
};

// ---------------------------------------------------------------------------------------------
// Free text (one paragraph per element), for notes and PDF text pages.
class TextPanel : public Panel {
 public:
  std::vector<std::string> lines;
  double font_size = 11.0;
  double min_font_size = 0.0;  // > 0: shrink (down to it) until the lines fit the panel
  bool monospace = false;

  void Draw(void* cairo, const Rect& area) const override;
  bool HasData() const override { return !lines.empty(); }
};

// ---------------------------------------------------------------------------------------------
// A figure: a title and panels on a rows x cols grid (row-major). Sizes in device units (px for
// PNG, pt for PDF and SVG).
class Figure {
 public:
  Figure(int rows, int cols, double width, double height);

  template <typename P>
  P& Add() {
    auto p = std::make_unique<P>();
    P& ref = *p;
    panels_.push_back(std::move(p));
    return ref;
  }
  // A panel spanning several grid cells, starting at the next free cell.
  void SetSpan(int panel_index, int row_span, int col_span);

  std::string title;
  std::string id;  // HTML element id and PNG file stem

  double width() const { return width_; }
  double height() const { return height_; }
  bool HasData() const;
  const std::vector<std::unique_ptr<Panel>>& panels() const { return panels_; }

  // Draws into a cairo context (void* = cairo_t*) scaled to the figure's size.
  void Draw(void* cairo) const;

 private:
  int rows_, cols_;
  double width_, height_;
  std::vector<std::unique_ptr<Panel>> panels_;
  std::vector<std::pair<int, int>> spans_;  // (row_span, col_span) per panel
};

// PNG at `scale` device pixels per figure unit. Throws std::runtime_error when it cannot write.
void SavePng(const Figure& figure, const std::string& path, double scale = 1.0);
// The PNG bytes, for base64 inlining.
std::string RenderPng(const Figure& figure, double scale = 1.0);
// A standalone <svg> document.
std::string RenderSvg(const Figure& figure);

// A multi-page PDF; each page takes the size of the figure drawn on it.
class PdfDocument {
 public:
  explicit PdfDocument(const std::string& path);  // throws std::runtime_error
  ~PdfDocument();
  PdfDocument(const PdfDocument&) = delete;
  PdfDocument& operator=(const PdfDocument&) = delete;

  void AddPage(const Figure& figure);
  int pages() const { return pages_; }
  // Finishes the file; throws std::runtime_error on a write error. Called by the destructor.
  void Close();

 private:
  std::string path_;
  void* surface_ = nullptr;  // cairo_surface_t*
  int pages_ = 0;
};

// "1.23e-05"-style short numbers for ticks and tables (up to `digits` significant digits).
std::string FormatNumber(double v, int digits = 4);

}  // namespace ctcal::report
