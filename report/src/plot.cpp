// Drawing of plot.h's panels with cairo. One style for everything: DejaVu Sans, light grid,
// thin dark axes, tab10 colours, titles bold at the top left of their panel.
#include "ctcal/report/plot.h"

#include <cairo-pdf.h>
#include <cairo-svg.h>
#include <cairo.h>
#include <libdeflate.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

namespace ctcal::report {
namespace {

constexpr const char* kFont = "DejaVu Sans";
constexpr const char* kMono = "DejaVu Sans Mono";
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

cairo_t* Cr(void* p) {
  return static_cast<cairo_t*>(p);
}

void SetColor(cairo_t* cr, const Color& c) {
  cairo_set_source_rgba(cr, c.r, c.g, c.b, c.a);
}

void SetFont(cairo_t* cr, double size, bool bold = false, bool mono = false) {
  cairo_select_font_face(cr, mono ? kMono : kFont, CAIRO_FONT_SLANT_NORMAL,
                         bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, size);
}

double TextWidth(cairo_t* cr, const std::string& s) {
  cairo_text_extents_t e;
  cairo_text_extents(cr, s.c_str(), &e);
  return e.x_advance;
}

// Text anchored at (x, y): ax, ay in {0, 0.5, 1} = left/centre/right, top/middle/baseline-ish.
void Text(cairo_t* cr, const std::string& s, double x, double y, double ax, double ay,
          double angle = 0.0) {
  cairo_font_extents_t fe;
  cairo_font_extents(cr, &fe);
  const double w = TextWidth(cr, s);
  const double h = fe.ascent;
  cairo_save(cr);
  cairo_translate(cr, x, y);
  cairo_rotate(cr, angle);
  cairo_move_to(cr, -ax * w, -ay * h + h);
  cairo_show_text(cr, s.c_str());
  cairo_restore(cr);
}

// Shortens `s` with an ellipsis to fit `max_w`.
std::string Fit(cairo_t* cr, std::string s, double max_w) {
  if (TextWidth(cr, s) <= max_w)
    return s;
  while (s.size() > 1 && TextWidth(cr, s + "...") > max_w)
    s.pop_back();
  return s + "...";
}

// "Nice" tick positions covering [lo, hi] (Heckbert's loose labelling, about n ticks).
std::vector<double> Ticks(double lo, double hi, int n) {
  std::vector<double> t;
  if (!(hi > lo) || !std::isfinite(lo) || !std::isfinite(hi))
    return t;
  const double raw = (hi - lo) / std::max(n, 1);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / mag;
  const double step = mag * (f < 1.5 ? 1.0 : f < 3.0 ? 2.0 : f < 7.0 ? 5.0 : 10.0);
  // Counted, not accumulated: a range far narrower than its magnitude (a constant sample
  // interval with 1e-12 jitter) would make `v += step` a no-op and the loop endless.
  const double first = std::ceil(lo / step - 1e-9);
  const double count = std::floor(hi / step + 1e-9) - first;
  if (!(count >= 0.0 && count <= 100.0))
    return t;
  for (int i = 0; i <= static_cast<int>(count); ++i) {
    const double v = (first + i) * step;
    t.push_back(std::abs(v) < step * 1e-9 ? 0.0 : v);
  }
  return t;
}

void Range(const std::vector<double>& v, double* lo, double* hi) {
  for (const double x : v) {
    if (std::isfinite(x)) {
      *lo = std::min(*lo, x);
      *hi = std::max(*hi, x);
    }
  }
}

// Pads a degenerate or tight range so that data do not sit on the frame.
void Pad(double* lo, double* hi, double frac) {
  // A range below 1e-9 of its magnitude is rounding noise on one value: treat it as one value.
  if (!(*hi - *lo > 1e-9 * std::max(std::abs(*lo), std::abs(*hi)))) {
    const double c = std::isfinite(*lo) ? *lo : 0.0;
    const double d = std::max(std::abs(c) * 0.1, 1e-9);
    *lo = c - d;
    *hi = c + d;
    return;
  }
  const double d = (*hi - *lo) * frac;
  *lo -= d;
  *hi += d;
}

void PanelTitle(cairo_t* cr, const std::string& title, const Rect& a) {
  if (title.empty())
    return;
  SetFont(cr, 11.0, true);
  cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
  Text(cr, Fit(cr, title, a.w - 4), a.x + 2, a.y + 2, 0.0, 0.0);
}

void NoData(cairo_t* cr, const Rect& a, const std::string& why) {
  cairo_set_source_rgb(cr, 0.96, 0.96, 0.96);
  cairo_rectangle(cr, a.x, a.y, a.w, a.h);
  cairo_fill(cr);
  SetFont(cr, 12.0, false);
  cairo_set_source_rgb(cr, 0.45, 0.45, 0.45);
  Text(cr, why, a.x + a.w / 2, a.y + a.h / 2, 0.5, 0.5);
}

// A vertical colour bar with ticks, `cmap` maps [0, 1] to a colour.
template <typename Map>
void ColorBar(cairo_t* cr, const Rect& bar, double lo, double hi, const std::string& label,
              Map cmap) {
  const int steps = 64;
  for (int i = 0; i < steps; ++i) {
    SetColor(cr, cmap((i + 0.5) / steps));
    const double y = bar.y + bar.h * (1.0 - (i + 1.0) / steps);
    cairo_rectangle(cr, bar.x, y, bar.w, bar.h / steps + 0.5);
    cairo_fill(cr);
  }
  cairo_set_source_rgb(cr, 0.2, 0.2, 0.2);
  cairo_set_line_width(cr, 0.6);
  cairo_rectangle(cr, bar.x, bar.y, bar.w, bar.h);
  cairo_stroke(cr);
  SetFont(cr, 8.5);
  for (const double t : Ticks(lo, hi, 5)) {
    const double y = bar.y + bar.h * (1.0 - (t - lo) / (hi - lo));
    cairo_move_to(cr, bar.x + bar.w, y);
    cairo_line_to(cr, bar.x + bar.w + 3, y);
    cairo_stroke(cr);
    Text(cr, FormatNumber(t, 3), bar.x + bar.w + 5, y, 0.0, 0.5);
  }
  if (!label.empty())
    Text(cr, label, bar.x + bar.w + 42, bar.y + bar.h / 2, 0.5, 0.5, -M_PI / 2);
}

// Axes frame with ticks, grid and labels; returns the data->device transform.
struct Axes {
  Rect plot;
  double x_lo, x_hi, y_lo, y_hi;
  bool y_down = false;
  double X(double x) const { return plot.x + (x - x_lo) / (x_hi - x_lo) * plot.w; }
  double Y(double y) const {
    const double f = (y - y_lo) / (y_hi - y_lo);
    return y_down ? plot.y + f * plot.h : plot.y + (1.0 - f) * plot.h;
  }
};

void DrawAxes(cairo_t* cr, const Axes& ax, const std::string& x_label, const std::string& y_label,
              bool grid) {
  const Rect& p = ax.plot;
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_rectangle(cr, p.x, p.y, p.w, p.h);
  cairo_fill(cr);
  const auto xt = Ticks(ax.x_lo, ax.x_hi, std::max(2, static_cast<int>(p.w / 70)));
  const auto yt = Ticks(ax.y_lo, ax.y_hi, std::max(2, static_cast<int>(p.h / 40)));
  cairo_set_line_width(cr, 0.5);
  if (grid) {
    cairo_set_source_rgb(cr, 0.88, 0.88, 0.88);
    for (const double t : xt) {
      cairo_move_to(cr, ax.X(t), p.y);
      cairo_line_to(cr, ax.X(t), p.y + p.h);
    }
    for (const double t : yt) {
      cairo_move_to(cr, p.x, ax.Y(t));
      cairo_line_to(cr, p.x + p.w, ax.Y(t));
    }
    cairo_stroke(cr);
  }
  cairo_set_source_rgb(cr, 0.25, 0.25, 0.25);
  cairo_set_line_width(cr, 0.8);
  cairo_rectangle(cr, p.x, p.y, p.w, p.h);
  cairo_stroke(cr);
  SetFont(cr, 8.5);
  for (const double t : xt) {
    cairo_move_to(cr, ax.X(t), p.y + p.h);
    cairo_line_to(cr, ax.X(t), p.y + p.h + 3);
    cairo_stroke(cr);
    Text(cr, FormatNumber(t, 4), ax.X(t), p.y + p.h + 5, 0.5, 0.0);
  }
  for (const double t : yt) {
    cairo_move_to(cr, p.x - 3, ax.Y(t));
    cairo_line_to(cr, p.x, ax.Y(t));
    cairo_stroke(cr);
    Text(cr, FormatNumber(t, 4), p.x - 5, ax.Y(t), 1.0, 0.5);
  }
  SetFont(cr, 9.5);
  if (!x_label.empty())
    Text(cr, x_label, p.x + p.w / 2, p.y + p.h + 18, 0.5, 0.0);
  if (!y_label.empty())
    Text(cr, y_label, p.x - 50, p.y + p.h / 2, 0.5, 0.5, -M_PI / 2);
}

void Arrow(cairo_t* cr, double x0, double y0, double x1, double y1, double head) {
  cairo_move_to(cr, x0, y0);
  cairo_line_to(cr, x1, y1);
  cairo_stroke(cr);
  const double a = std::atan2(y1 - y0, x1 - x0);
  const double len = std::hypot(x1 - x0, y1 - y0);
  const double h = std::min(head, 0.5 * len);
  cairo_move_to(cr, x1, y1);
  cairo_line_to(cr, x1 - h * std::cos(a - 0.45), y1 - h * std::sin(a - 0.45));
  cairo_line_to(cr, x1 - h * std::cos(a + 0.45), y1 - h * std::sin(a + 0.45));
  cairo_close_path(cr);
  cairo_fill(cr);
}

// Dots stamped into an ARGB image over the plotted area `area` (device units), `scale` image
// pixels per unit: an anti-aliased disc per dot, blended "over" in call order.
class DotRaster {
 public:
  DotRaster(const Rect& area, double scale, double radius)
      : area_(area),
        scale_(scale),
        w_(std::max(1, static_cast<int>(std::ceil(area.w * scale)))),
        h_(std::max(1, static_cast<int>(std::ceil(area.h * scale)))) {
    surface_ = cairo_image_surface_create(CAIRO_FORMAT_ARGB32, w_, h_);
    cairo_surface_flush(surface_);
    data_ = cairo_image_surface_get_data(surface_);
    stride_ = cairo_image_surface_get_stride(surface_);
    const double r = std::max(radius * scale, 0.5);
    reach_ = static_cast<int>(std::ceil(r + 0.5));
    const int side = 2 * reach_ + 1;
    mask_.resize(static_cast<size_t>(side) * side);
    span_.assign(static_cast<size_t>(side), {0, -1});
    for (int dy = -reach_; dy <= reach_; ++dy) {
      auto& [first, last] = span_[static_cast<size_t>(dy + reach_)];
      for (int dx = -reach_; dx <= reach_; ++dx) {
        const auto m = static_cast<std::uint8_t>(
            255.0 * std::clamp(r + 0.5 - std::hypot(dx, dy), 0.0, 1.0) + 0.5);
        mask_[static_cast<size_t>(dy + reach_) * side + (dx + reach_)] = m;
        if (m != 0) {
          first = std::min(first, dx);
          last = dx;
        }
      }
    }
  }
  ~DotRaster() { cairo_surface_destroy(surface_); }
  DotRaster(const DotRaster&) = delete;
  DotRaster& operator=(const DotRaster&) = delete;

  void Stamp(double x, double y, const Color& c) {
    if (data_ == nullptr)
      return;
    const int cx = static_cast<int>((x - area_.x) * scale_ + 0.5);
    const int cy = static_cast<int>((y - area_.y) * scale_ + 0.5);
    const int side = 2 * reach_ + 1;
    const auto channel = [](double v) {
      return static_cast<std::uint32_t>(std::clamp(v, 0.0, 1.0) * 255.0 + 0.5);
    };
    const std::uint32_t alpha = channel(c.a), r = channel(c.r), g = channel(c.g), b = channel(c.b);
    const std::uint32_t opaque = 0xff000000u | (r << 16) | (g << 8) | b;
    for (int dy = -reach_; dy <= reach_; ++dy) {
      const int py = cy + dy;
      if (py < 0 || py >= h_)
        continue;
      auto* row = reinterpret_cast<std::uint32_t*>(data_ + static_cast<size_t>(py) * stride_);
      const std::uint8_t* m = &mask_[static_cast<size_t>(dy + reach_) * side];
      // Only the disc's own pixels of this row (the mask is 0 outside [first, last]).
      const auto [first, last] = span_[static_cast<size_t>(dy + reach_)];
      for (int dx = std::max(first, -cx); dx <= std::min(last, w_ - 1 - cx); ++dx) {
        const int px = cx + dx;
        const std::uint32_t a = (alpha * m[dx + reach_] + 127) / 255;
        if (a == 255) {  // "over" with full coverage is the source itself
          row[px] = opaque;
          continue;
        }
        if (a == 0)
          continue;
        // Premultiplied ARGB32 "over": out = src a + (1 - a) dst, per 8-bit channel.
        const std::uint32_t d = row[px];
        const auto over = [&](int shift, std::uint32_t src) {
          return ((src * a + ((d >> shift) & 0xffu) * (255u - a) + 127u) / 255u) << shift;
        };
        row[px] = over(24, 255u) | over(16, r) | over(8, g) | over(0, b);
      }
    }
  }

  void PaintOnto(cairo_t* cr) {
    cairo_surface_mark_dirty(surface_);
    cairo_save(cr);
    cairo_translate(cr, area_.x, area_.y);
    cairo_scale(cr, 1.0 / scale_, 1.0 / scale_);
    cairo_set_source_surface(cr, surface_, 0.0, 0.0);
    cairo_paint(cr);
    cairo_restore(cr);
  }

 private:
  Rect area_;
  double scale_;
  int w_, h_;
  cairo_surface_t* surface_ = nullptr;
  unsigned char* data_ = nullptr;
  int stride_ = 0;
  int reach_ = 0;
  std::vector<std::uint8_t> mask_;         // disc coverage, 0..255
  std::vector<std::pair<int, int>> span_;  // per mask row, the dx range of non-zero coverage
};

// A line of many more points than half-points across (XYPlot::Draw), drawn as the band it
// covers: per half-point column the lowest and the highest point, reaching back to the previous
// column's last point so that the line stays connected, `width` thick like the stroke. The band's
// upper edge runs through the columns' centres at the highest point of the column and its two
// neighbours (a one-column spike keeps a flat top as wide as a stroke's cap instead of thinning to
// a needle), its lower edge back likewise: one polygon per run, two points per column on a PDF
// page instead of a rectangle. NaN breaks the line.
template <typename AxesT>
void DrawDenseLine(cairo_t* cr, const AxesT& ax, const std::vector<double>& x,
                   const std::vector<double>& y, double width) {
  const size_t n = std::min(x.size(), y.size());
  const double half = 0.5 * width;
  struct Column {
    double index, top, bottom;
  };
  std::vector<Column> run;
  std::vector<double> upper, lower;  // the band's edges per column
  const auto fill_run = [&]() {
    if (run.empty())
      return;
    const size_t m = run.size();
    upper.resize(m);
    lower.resize(m);
    for (size_t i = 0; i < m; ++i) {
      upper[i] = run[i].top;
      lower[i] = run[i].bottom;
      for (const size_t j : {i - 1, i + 1}) {  // i - 1 wraps to a huge index at i = 0
        if (j < m && std::abs(run[j].index - run[i].index) == 1.0) {
          upper[i] = std::min(upper[i], run[j].top);
          lower[i] = std::max(lower[i], run[j].bottom);
        }
      }
    }
    const auto centre = [&](size_t i) { return 0.5 * run[i].index + 0.25; };
    // The ends reach out like the stroke's (to the outer columns' bars' edges).
    const double x0 = centre(0) - 0.25 - 0.5 * half, x1 = centre(m - 1) + 0.25 + 0.5 * half;
    cairo_move_to(cr, x0, upper[0]);
    for (size_t i = 0; i < m; ++i)
      cairo_line_to(cr, centre(i), upper[i]);
    cairo_line_to(cr, x1, upper[m - 1]);
    cairo_line_to(cr, x1, lower[m - 1]);
    for (size_t i = m; i-- > 0;)
      cairo_line_to(cr, centre(i), lower[i]);
    cairo_line_to(cr, x0, lower[0]);
    cairo_close_path(cr);
    run.clear();
  };
  bool open = false, have_prev = false;
  double column = 0.0, lo = 0.0, hi = 0.0, last = 0.0, prev_last = 0.0;
  const auto flush = [&]() {
    if (!open)
      return;
    double top = lo, bottom = hi;
    if (have_prev) {
      top = std::min(top, prev_last);
      bottom = std::max(bottom, prev_last);
    }
    run.push_back({column, top - half, bottom + half});
    prev_last = last;
    have_prev = true;
    open = false;
  };
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(x[i]) || !std::isfinite(y[i])) {
      flush();
      fill_run();
      have_prev = false;
      continue;
    }
    const double dx = ax.X(x[i]), dy = ax.Y(y[i]);
    const double c = std::floor(2.0 * dx);
    if (open && c != column)
      flush();
    if (!open) {
      open = true;
      column = c;
      lo = hi = last = dy;
      continue;
    }
    lo = std::min(lo, dy);
    hi = std::max(hi, dy);
    last = dy;
  }
  flush();
  fill_run();
  cairo_fill(cr);
}

}  // namespace

Color PaletteColor(int i) {
  static const Color kTab10[] = {{0.12, 0.47, 0.71}, {1.00, 0.50, 0.05}, {0.17, 0.63, 0.17},
                                 {0.84, 0.15, 0.16}, {0.58, 0.40, 0.74}, {0.55, 0.34, 0.29},
                                 {0.89, 0.47, 0.76}, {0.50, 0.50, 0.50}, {0.74, 0.74, 0.13},
                                 {0.09, 0.75, 0.81}};
  return kTab10[((i % 10) + 10) % 10];
}

Color Viridis(double t) {
  // Five control points of matplotlib's viridis, interpolated linearly.
  static const double k[5][3] = {{0.267, 0.005, 0.329},
                                 {0.229, 0.322, 0.546},
                                 {0.128, 0.567, 0.551},
                                 {0.369, 0.789, 0.383},
                                 {0.993, 0.906, 0.144}};
  if (!std::isfinite(t))
    return {0.7, 0.7, 0.7};
  t = std::clamp(t, 0.0, 1.0) * 4.0;
  const int i = std::min(static_cast<int>(t), 3);
  const double f = t - i;
  return {k[i][0] + f * (k[i + 1][0] - k[i][0]), k[i][1] + f * (k[i + 1][1] - k[i][1]),
          k[i][2] + f * (k[i + 1][2] - k[i][2])};
}

Color Diverging(double t) {
  if (!std::isfinite(t))
    return {0.7, 0.7, 0.7};
  t = std::clamp(t, -1.0, 1.0);
  const Color blue{0.13, 0.40, 0.67}, red{0.70, 0.09, 0.17}, white{0.97, 0.97, 0.97};
  const Color& e = t < 0 ? blue : red;
  const double f = std::abs(t);
  return {white.r + f * (e.r - white.r), white.g + f * (e.g - white.g),
          white.b + f * (e.b - white.b)};
}

std::string FormatNumber(double v, int digits) {
  if (std::isnan(v))
    return "nan";
  if (std::isinf(v))
    return v > 0 ? "inf" : "-inf";
  char buf[64];
  const double a = std::abs(v);
  if (a != 0.0 && (a < 1e-3 || a >= 1e5))
    std::snprintf(buf, sizeof(buf), "%.*e", std::max(digits - 2, 1), v);
  else
    std::snprintf(buf, sizeof(buf), "%.*g", digits, v);
  return buf;
}

// ------------------------------------------------------------------------------------- XYPlot

Series& XYPlot::Line(const std::vector<double>& x, const std::vector<double>& y,
                     const std::string& label, Color c, double width) {
  Series s;
  s.kind = Series::Kind::kLine;
  s.x = x;
  s.y = y;
  s.label = label;
  s.color = c;
  s.width = width;
  series.push_back(std::move(s));
  return series.back();
}

Series& XYPlot::Scatter(const std::vector<double>& x, const std::vector<double>& y,
                        const std::string& label, Color c, double radius) {
  Series& s = Line(x, y, label, c, radius);
  s.kind = Series::Kind::kScatter;
  return s;
}

Series& XYPlot::ScatterByValue(const std::vector<double>& x, const std::vector<double>& y,
                               const std::vector<double>& value, double radius) {
  Series& s = Scatter(x, y, "", PaletteColor(0), radius);
  s.value = value;
  return s;
}

Series& XYPlot::Band(const std::vector<double>& x, const std::vector<double>& lower,
                     const std::vector<double>& upper, const std::string& label, Color c) {
  Series& s = Line(x, lower, label, c);
  s.kind = Series::Kind::kBand;
  s.y2 = upper;
  return s;
}

Series& XYPlot::HLine(double y, const std::string& label, Color c, bool dashed) {
  Series& s = Line({}, {y}, label, c, 1.0);
  s.kind = Series::Kind::kHLine;
  s.dashed = dashed;
  return s;
}

Series& XYPlot::Arrows(const std::vector<double>& x0, const std::vector<double>& y0,
                       const std::vector<double>& dx, const std::vector<double>& dy, Color c) {
  Series& s = Line(dx, dy, "", c, 1.0);
  s.kind = Series::Kind::kArrows;
  s.x0 = x0;
  s.y0 = y0;
  return s;
}

Series& XYPlot::Histogram(const std::vector<double>& values, int bins, double lo, double hi,
                          const std::string& label, Color c) {
  bins = std::max(bins, 1);
  std::vector<double> counts(bins, 0.0);
  double n = 0;
  for (const double v : values) {
    if (!std::isfinite(v))
      continue;
    n += 1;  // values outside [lo, hi] count in the total so that the density stays honest
    if (v < lo || v > hi)
      continue;
    const int b = std::min(static_cast<int>((v - lo) / (hi - lo) * bins), bins - 1);
    counts[b] += 1;
  }
  const double w = (hi - lo) / bins;
  Series s;
  s.kind = Series::Kind::kBars;
  for (int b = 0; b < bins; ++b) {
    s.x.push_back(lo + b * w);
    s.x0.push_back(lo + (b + 1) * w);
    s.y.push_back(n > 0 ? counts[b] / (n * w) : kNaN);
  }
  s.label = label;
  s.color = c;
  series.push_back(std::move(s));
  return series.back();
}

Series& XYPlot::NormalDensity(double lo, double hi, Color c) {
  std::vector<double> x, y;
  for (int i = 0; i <= 200; ++i) {
    const double v = lo + (hi - lo) * i / 200.0;
    x.push_back(v);
    y.push_back(std::exp(-0.5 * v * v) / std::sqrt(2.0 * M_PI));
  }
  return Line(x, y, "N(0,1)", c, 1.8);
}

bool XYPlot::HasData() const {
  for (const Series& s : series) {
    if (s.kind == Series::Kind::kHLine)
      continue;
    for (size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i) {
      if (std::isfinite(s.x[i]) && std::isfinite(s.y[i]))
        return true;
    }
  }
  return false;
}

void XYPlot::Draw(void* cairo, const Rect& area) const {
  cairo_t* cr = Cr(cairo);
  PanelTitle(cr, title, area);
  const bool has_bar =
      std::any_of(series.begin(), series.end(), [](const Series& s) { return !s.value.empty(); });
  Rect p{area.x + 62, area.y + 20, area.w - 62 - (has_bar ? 78 : 12), area.h - 20 - 36};
  if (!HasData() || p.w < 20 || p.h < 20) {
    NoData(cr, p, "no finite data to plot");
    return;
  }
  double xl = INFINITY, xh = -INFINITY, yl = INFINITY, yh = -INFINITY;
  double vl = INFINITY, vh = -INFINITY;
  for (const Series& s : series) {
    if (s.kind == Series::Kind::kHLine) {
      Range(s.y, &yl, &yh);
      continue;
    }
    if (s.kind == Series::Kind::kArrows) {
      Range(s.x0, &xl, &xh);
      Range(s.y0, &yl, &yh);
      continue;
    }
    Range(s.x, &xl, &xh);
    Range(s.y, &yl, &yh);
    if (s.kind == Series::Kind::kBand)
      Range(s.y2, &yl, &yh);
    if (s.kind == Series::Kind::kBars) {
      Range(s.x0, &xl, &xh);
      yl = std::min(yl, 0.0);
    }
    Range(s.value, &vl, &vh);
  }
  if (xl > xh) {  // only horizontal lines
    xl = 0;
    xh = 1;
  }
  Pad(&xl, &xh, 0.0);
  Pad(&yl, &yh, 0.05);
  if (std::isfinite(x_min))
    xl = x_min;
  if (std::isfinite(x_max))
    xh = x_max;
  if (std::isfinite(y_min))
    yl = y_min;
  if (std::isfinite(y_max))
    yh = y_max;
  if (equal_aspect) {
    // Same units per device unit on both axes: widen the range that is relatively shorter.
    const double sx = (xh - xl) / p.w, sy = (yh - yl) / p.h;
    const bool fixed = std::isfinite(x_min) && std::isfinite(x_max) && std::isfinite(y_min) &&
                       std::isfinite(y_max);
    if (fixed) {  // an image: shrink the plotted area to the image's aspect, never past its edges
      if (sx > sy)
        p.h = (yh - yl) / sx;
      else
        p.w = (xh - xl) / sy;
    } else if (sx > sy) {
      const double c = 0.5 * (yl + yh), h = 0.5 * sx * p.h;
      yl = c - h;
      yh = c + h;
    } else {
      const double c = 0.5 * (xl + xh), h = 0.5 * sy * p.w;
      xl = c - h;
      xh = c + h;
    }
  }
  Axes ax{p, xl, xh, yl, yh, y_down};
  DrawAxes(cr, ax, x_label, y_label, true);

  cairo_save(cr);
  cairo_rectangle(cr, p.x, p.y, p.w, p.h);
  cairo_clip(cr);
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
  for (const Series& s : series) {
    const size_t n = std::min(s.x.size(), s.y.size());
    const double dash[] = {5.0, 3.0};
    cairo_set_dash(cr, dash, s.dashed ? 2 : 0, 0);
    switch (s.kind) {
      case Series::Kind::kLine:
      case Series::Kind::kStep: {
        SetColor(cr, s.color);
        cairo_set_line_width(cr, s.width);
        bool pen = false;  // NaN breaks the line
        const auto point = [&](size_t i) {
          if (pen)
            cairo_line_to(cr, ax.X(s.x[i]), ax.Y(s.y[i]));
          else
            cairo_move_to(cr, ax.X(s.x[i]), ax.Y(s.y[i]));
          pen = true;
        };
        // A dense line (a 60 s IMU stream: 12000 points on ~700 pt) is drawn as the filled band
        // of its half-point columns' lowest and highest points, joined to the previous column's
        // last point: the picture of the stroke (spikes kept) without stroking thousands of
        // overlapping zigzag segments, which cost cairo ~1 s per PNG.
        const bool thin = s.kind == Series::Kind::kLine && static_cast<double>(n) > 4 * p.w;
        if (thin) {
          DrawDenseLine(cr, ax, s.x, s.y, s.width);
          break;
        }
        for (size_t i = 0; i < n; ++i) {
          if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) {
            pen = false;
            continue;
          }
          point(i);
        }
        cairo_stroke(cr);
        break;
      }
      case Series::Kind::kScatter: {
        // Up to kVectorDots dots are vector circles. Beyond, cairo's per-dot fill (a minute's
        // recording has 170k corners per camera: 3.5 s per drawing) is replaced by stamping an
        // anti-aliased disc into an image (the PNG's pixels, 2 px per pt on a PDF page), later
        // dots over earlier ones as the vector path would draw them (same look, ~50 ms, a fixed
        // size in the PDF).
        constexpr size_t kVectorDots = 3000;
        const auto color_of = [&](size_t i) {
          Color c = s.color;
          if (i < s.value.size())
            c = Viridis(vh > vl ? (s.value[i] - vl) / (vh - vl) : 0.5);
          c.a = s.color.a;
          return c;
        };
        if (n > kVectorDots) {
          // Image targets: their own resolution; vector pages: 2 px per pt (144 dpi: dots of
          // radius >= 1.2 pt stay round; 64 % of the pixels of 2.5 px per pt, which cairo
          // deflates at zlib's level 6 and the stamping fills).
          double scale = 2.0;
          if (cairo_surface_get_type(cairo_get_target(cr)) == CAIRO_SURFACE_TYPE_IMAGE) {
            double ux = 1.0, uy = 0.0;
            cairo_user_to_device_distance(cr, &ux, &uy);
            scale = std::max(std::hypot(ux, uy), 0.5);
          }
          DotRaster raster(p, scale, s.width);
          for (size_t i = 0; i < n; ++i) {
            if (std::isfinite(s.x[i]) && std::isfinite(s.y[i]))
              raster.Stamp(ax.X(s.x[i]), ax.Y(s.y[i]), color_of(i));
          }
          raster.PaintOnto(cr);
          break;
        }
        for (size_t i = 0; i < n; ++i) {
          if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i]))
            continue;
          SetColor(cr, color_of(i));
          cairo_arc(cr, ax.X(s.x[i]), ax.Y(s.y[i]), s.width, 0, 2 * M_PI);
          cairo_fill(cr);
        }
        break;
      }
      case Series::Kind::kBand: {
        Color c = s.color;
        c.a = 0.18;
        SetColor(cr, c);
        const size_t m = std::min(n, s.y2.size());
        // A band of many more points than half-points across (a 60 s envelope: 18000) keeps one
        // point per half-point column and each edge's last: its edges are smooth curves or
        // constants, and the PDF page would otherwise hold every sample twice.
        const bool dense = static_cast<double>(m) > 4 * p.w;
        double column = kNaN;
        const auto skip = [&](size_t i, bool last) {
          if (!dense || last)
            return false;
          const double here = std::floor(2.0 * ax.X(s.x[i]));
          if (here == column)
            return true;
          column = here;
          return false;
        };
        bool any = false;
        for (size_t i = 0; i < m; ++i) {
          if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i]) || skip(i, i + 1 == m))
            continue;
          any ? cairo_line_to(cr, ax.X(s.x[i]), ax.Y(s.y[i]))
              : cairo_move_to(cr, ax.X(s.x[i]), ax.Y(s.y[i]));
          any = true;
        }
        column = kNaN;
        for (size_t i = m; i-- > 0;) {
          if (std::isfinite(s.x[i]) && std::isfinite(s.y2[i]) && !skip(i, i == 0))
            cairo_line_to(cr, ax.X(s.x[i]), ax.Y(s.y2[i]));
        }
        if (any)
          cairo_fill(cr);
        else
          cairo_new_path(cr);
        break;
      }
      case Series::Kind::kBars: {
        for (size_t i = 0; i < n && i < s.x0.size(); ++i) {
          if (!std::isfinite(s.y[i]))
            continue;
          const double x0 = ax.X(s.x[i]), x1 = ax.X(s.x0[i]);
          const double y0 = ax.Y(0.0), y1 = ax.Y(s.y[i]);
          Color c = s.color;
          c.a = 0.55;
          SetColor(cr, c);
          cairo_rectangle(cr, x0, std::min(y0, y1), x1 - x0, std::abs(y1 - y0));
          cairo_fill_preserve(cr);
          SetColor(cr, s.color);
          cairo_set_line_width(cr, 0.5);
          cairo_stroke(cr);
        }
        break;
      }
      case Series::Kind::kArrows: {
        SetColor(cr, s.color);
        cairo_set_line_width(cr, s.width);
        for (size_t i = 0; i < n && i < s.x0.size() && i < s.y0.size(); ++i) {
          if (!std::isfinite(s.x0[i]) || !std::isfinite(s.y0[i]) || !std::isfinite(s.x[i]) ||
              !std::isfinite(s.y[i]))
            continue;
          Arrow(cr, ax.X(s.x0[i]), ax.Y(s.y0[i]), ax.X(s.x0[i] + s.x[i]), ax.Y(s.y0[i] + s.y[i]),
                4.0);
        }
        break;
      }
      case Series::Kind::kHLine: {
        if (s.y.empty() || !std::isfinite(s.y[0]))
          break;
        SetColor(cr, s.color);
        cairo_set_line_width(cr, s.width);
        cairo_move_to(cr, p.x, ax.Y(s.y[0]));
        cairo_line_to(cr, p.x + p.w, ax.Y(s.y[0]));
        cairo_stroke(cr);
        break;
      }
    }
  }
  cairo_set_dash(cr, nullptr, 0, 0);
  cairo_restore(cr);

  if (has_bar && vh >= vl) {
    if (!(vh > vl))
      vh = vl + 1.0;
    ColorBar(cr, Rect{p.x + p.w + 10, p.y, 12, p.h}, vl, vh, value_label,
             [](double t) { return Viridis(t); });
  }

  // Legend: top right inside the plot, on a translucent white box.
  std::vector<const Series*> items;
  for (const Series& s : series) {
    if (!s.label.empty())
      items.push_back(&s);
  }
  if (legend && !items.empty()) {
    SetFont(cr, 8.5);
    double w = 0;
    for (const Series* s : items)
      w = std::max(w, TextWidth(cr, s->label));
    const double lh = 12, bw = w + 30, bh = lh * items.size() + 6;
    const double bx = p.x + p.w - bw - 6, by = p.y + 6;
    cairo_set_source_rgba(cr, 1, 1, 1, 0.85);
    cairo_rectangle(cr, bx, by, bw, bh);
    cairo_fill_preserve(cr);
    cairo_set_source_rgb(cr, 0.75, 0.75, 0.75);
    cairo_set_line_width(cr, 0.5);
    cairo_stroke(cr);
    for (size_t i = 0; i < items.size(); ++i) {
      const Series& s = *items[i];
      const double yy = by + 3 + lh * (i + 0.5);
      Color c = s.color;
      if (s.kind == Series::Kind::kBand || s.kind == Series::Kind::kBars) {
        c.a = 0.4;
        SetColor(cr, c);
        cairo_rectangle(cr, bx + 5, yy - 4, 16, 8);
        cairo_fill(cr);
      } else if (s.kind == Series::Kind::kScatter) {
        SetColor(cr, c);
        cairo_arc(cr, bx + 13, yy, 3, 0, 2 * M_PI);
        cairo_fill(cr);
      } else {
        SetColor(cr, c);
        cairo_set_line_width(cr, std::min(s.width, 2.5));
        const double dash[] = {4.0, 2.0};
        cairo_set_dash(cr, dash, s.dashed ? 2 : 0, 0);
        cairo_move_to(cr, bx + 5, yy);
        cairo_line_to(cr, bx + 21, yy);
        cairo_stroke(cr);
        cairo_set_dash(cr, nullptr, 0, 0);
      }
      cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
      Text(cr, s.label, bx + 25, yy, 0.0, 0.5);
    }
  }
}

// ------------------------------------------------------------------------------------ HeatMap

bool HeatMap::HasData() const {
  return values.size() > 0 && values.array().isFinite().any();
}

void HeatMap::Draw(void* cairo, const Rect& area) const {
  cairo_t* cr = Cr(cairo);
  PanelTitle(cr, title, area);
  Rect p{area.x + 62, area.y + 20, area.w - 62 - 78, area.h - 20 - 36};
  if (!HasData() || p.w < 20 || p.h < 20) {
    NoData(cr, p, "no finite data to plot");
    return;
  }
  // Keep the grid's aspect (image pixels are square).
  const double sx = (x_hi - x_lo) / p.w, sy = (y_hi - y_lo) / p.h;
  if (sx > sy)
    p.h = (y_hi - y_lo) / sx;
  else
    p.w = (x_hi - x_lo) / sy;
  double lo = v_min, hi = v_max;
  if (!std::isfinite(lo) || !std::isfinite(hi)) {
    lo = INFINITY;
    hi = -INFINITY;
    for (int i = 0; i < values.size(); ++i) {
      const double v = values.data()[i];
      if (std::isfinite(v)) {
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
    }
    if (std::isfinite(v_min))
      lo = v_min;
    if (std::isfinite(v_max))
      hi = v_max;
  }
  if (!(hi > lo))
    hi = lo + 1.0;
  Axes ax{p, x_lo, x_hi, y_lo, y_hi, y_down};
  DrawAxes(cr, ax, x_label, y_label, false);
  const double cw = (x_hi - x_lo) / values.cols(), ch = (y_hi - y_lo) / values.rows();
  for (int r = 0; r < values.rows(); ++r) {
    for (int c = 0; c < values.cols(); ++c) {
      const double v = values(r, c);
      SetColor(cr, std::isfinite(v) ? Viridis((v - lo) / (hi - lo)) : Color{0.85, 0.85, 0.85});
      const double x0 = ax.X(x_lo + c * cw), x1 = ax.X(x_lo + (c + 1) * cw);
      const double y0 = ax.Y(y_lo + r * ch), y1 = ax.Y(y_lo + (r + 1) * ch);
      cairo_rectangle(cr, x0, std::min(y0, y1), x1 - x0 + 0.3, std::abs(y1 - y0) + 0.3);
      cairo_fill(cr);
    }
  }
  cairo_set_source_rgb(cr, 0.25, 0.25, 0.25);
  cairo_set_line_width(cr, 0.8);
  cairo_rectangle(cr, p.x, p.y, p.w, p.h);
  cairo_stroke(cr);
  ColorBar(cr, Rect{p.x + p.w + 10, p.y, 12, p.h}, lo, hi, value_label,
           [](double t) { return Viridis(t); });
}

// -------------------------------------------------------------------------------------- Table

void Table::AddRow(const std::vector<std::string>& texts) {
  std::vector<Cell> row;
  for (const std::string& t : texts) {
    Cell cell;
    cell.text = t;
    row.push_back(cell);
  }
  rows.push_back(std::move(row));
}

void Table::Draw(void* cairo, const Rect& area) const {
  cairo_t* cr = Cr(cairo);
  PanelTitle(cr, title, area);
  const Rect p{area.x + 4, area.y + (title.empty() ? 2 : 20), area.w - 8,
               area.h - (title.empty() ? 4 : 22)};
  if (rows.empty()) {
    NoData(cr, p, "empty table");
    return;
  }
  size_t cols = 0;
  for (const auto& r : rows)
    cols = std::max(cols, r.size());
  // Column widths from the content, scaled down to fit.
  std::vector<double> w(cols, 0.0);
  double total = 0;
  const auto measure = [&](double size) {
    std::fill(w.begin(), w.end(), 0.0);
    for (size_t r = 0; r < rows.size(); ++r) {
      for (size_t c = 0; c < rows[r].size(); ++c) {
        SetFont(cr, size, r == 0, rows[r][c].monospace);
        w[c] = std::max(w[c], TextWidth(cr, rows[r][c].text) + 12);
      }
    }
    total = 0;
    for (const double x : w)
      total += x;
  };
  double fs = font_size;
  measure(fs);
  if (min_font_size > 0.0) {
    // Text width scales with the font size, the 12 pt of padding per column does not.
    const double pad = 12.0 * static_cast<double>(cols);
    const double by_width =
        total > p.w ? 0.97 * fs * (p.w - pad) / std::max(total - pad, 1e-9) : fs;
    const double by_height = p.h / (1.65 * static_cast<double>(rows.size()));
    const double fitted = std::max(min_font_size, std::min({fs, by_width, by_height}));
    if (fitted < fs) {
      fs = fitted;
      measure(fs);
    }
  }
  if (total > p.w) {
    // Too wide: cap the widest columns at one common width, so that narrow ones (status,
    // sensor) stay whole and only long text is cut.
    std::vector<double> sorted(w);
    std::sort(sorted.begin(), sorted.end());
    double below = 0.0, cap = p.w / static_cast<double>(cols);
    for (size_t i = 0; i < sorted.size(); ++i) {
      const double c = (p.w - below) / static_cast<double>(sorted.size() - i);
      if (c <= sorted[i]) {
        cap = c;
        break;
      }
      below += sorted[i];
    }
    for (double& x : w)
      x = std::min(x, cap);
    total = p.w;
  }
  const double scale = 1.0;
  const double rh = fs * 1.65;
  double y = p.y;
  for (size_t r = 0; r < rows.size() && y + rh <= p.y + p.h + 0.5; ++r) {
    double x = p.x;
    if (r == 0) {
      cairo_set_source_rgb(cr, 0.90, 0.92, 0.95);
      cairo_rectangle(cr, p.x, y, std::min(total, p.w), rh);
      cairo_fill(cr);
    } else if (r % 2 == 0) {
      cairo_set_source_rgb(cr, 0.975, 0.975, 0.975);
      cairo_rectangle(cr, p.x, y, std::min(total, p.w), rh);
      cairo_fill(cr);
    }
    for (size_t c = 0; c < rows[r].size(); ++c) {
      const Cell& cell = rows[r][c];
      const double cw = w[c] * scale;
      if (cell.has_fill) {
        SetColor(cr, cell.fill);
        cairo_rectangle(cr, x + 1, y + 1, cw - 2, rh - 2);
        cairo_fill(cr);
        cairo_set_source_rgb(cr, 1, 1, 1);
      } else {
        cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
      }
      SetFont(cr, fs, r == 0 || cell.has_fill, cell.monospace);
      Text(cr, Fit(cr, cell.text, cw - 8), x + 5, y + rh / 2, 0.0, 0.5);
      x += cw;
    }
    y += rh;
  }
  cairo_set_source_rgb(cr, 0.6, 0.6, 0.6);
  cairo_set_line_width(cr, 0.6);
  cairo_move_to(cr, p.x, p.y + rh);
  cairo_line_to(cr, p.x + std::min(total, p.w), p.y + rh);
  cairo_stroke(cr);
}

// ------------------------------------------------------------------------------- Trajectory3D

bool Trajectory3D::HasData() const {
  return std::any_of(p_W.begin(), p_W.end(),
                     [](const Eigen::Vector3d& p) { return p.allFinite(); });
}

void Trajectory3D::Draw(void* cairo, const Rect& area) const {
  cairo_t* cr = Cr(cairo);
  PanelTitle(cr, title, area);
  const Rect p{area.x + 8, area.y + 22, area.w - 16, area.h - 30};
  if (!HasData()) {
    NoData(cr, p, "no finite poses to plot");
    return;
  }
  // View rotation: azimuth about world z, then elevation; screen x right, screen y up = view z.
  const double az = azimuth_deg * M_PI / 180.0, el = elevation_deg * M_PI / 180.0;
  const Eigen::Vector3d right(-std::sin(az), std::cos(az), 0.0);
  const Eigen::Vector3d toward(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                               std::sin(el));
  const Eigen::Vector3d up = toward.cross(right);
  auto proj = [&](const Eigen::Vector3d& x) { return Eigen::Vector2d(right.dot(x), up.dot(x)); };
  Eigen::Vector2d lo(INFINITY, INFINITY), hi(-INFINITY, -INFINITY);
  Eigen::Vector3d lo3 = Eigen::Vector3d::Constant(INFINITY), hi3 = -lo3;
  for (const auto& x : p_W) {
    if (!x.allFinite())
      continue;
    lo = lo.cwiseMin(proj(x));
    hi = hi.cwiseMax(proj(x));
    lo3 = lo3.cwiseMin(x);
    hi3 = hi3.cwiseMax(x);
  }
  const double extent = std::max((hi3 - lo3).maxCoeff(), 1e-3);
  const double triad = 0.08 * extent;
  // The bounding box is drawn too: its corners stick out of the path's outline in most views.
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d corner((k & 1) ? hi3.x() : lo3.x(), (k & 2) ? hi3.y() : lo3.y(),
                                 (k & 4) ? hi3.z() : lo3.z());
    lo = lo.cwiseMin(proj(corner));
    hi = hi.cwiseMax(proj(corner));
  }
  lo -= Eigen::Vector2d::Constant(triad * 1.5);
  hi += Eigen::Vector2d::Constant(triad * 1.5);
  const double s = std::min(p.w / (hi.x() - lo.x()), p.h / (hi.y() - lo.y()));
  const Eigen::Vector2d c = 0.5 * (lo + hi);
  auto dev = [&](const Eigen::Vector3d& x) {
    const Eigen::Vector2d q = proj(x);
    return Eigen::Vector2d(p.x + p.w / 2 + s * (q.x() - c.x()),
                           p.y + p.h / 2 - s * (q.y() - c.y()));
  };
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_rectangle(cr, p.x, p.y, p.w, p.h);
  cairo_fill(cr);
  // Bounding box of the trajectory, for depth cues.
  cairo_set_source_rgb(cr, 0.8, 0.8, 0.8);
  cairo_set_line_width(cr, 0.5);
  for (int e = 0; e < 12; ++e) {
    const int axis = e / 4, k = e % 4;
    Eigen::Vector3d a, b;
    for (int d = 0, bit = 0; d < 3; ++d) {
      if (d == axis) {
        a[d] = lo3[d];
        b[d] = hi3[d];
      } else {
        a[d] = b[d] = ((k >> bit) & 1) ? hi3[d] : lo3[d];
        ++bit;
      }
    }
    const auto pa = dev(a), pb = dev(b);
    cairo_move_to(cr, pa.x(), pa.y());
    cairo_line_to(cr, pb.x(), pb.y());
  }
  cairo_stroke(cr);
  // Path coloured by time.
  cairo_set_line_width(cr, 1.2);
  double t0 = t.empty() ? 0.0 : t.front(), t1 = t.empty() ? 1.0 : t.back();
  if (!(t1 > t0))
    t1 = t0 + 1.0;
  for (size_t i = 1; i < p_W.size(); ++i) {
    if (!p_W[i - 1].allFinite() || !p_W[i].allFinite())
      continue;
    SetColor(cr, t.size() == p_W.size() ? Viridis((t[i] - t0) / (t1 - t0)) : Color{0.3, 0.3, 0.3});
    const auto a = dev(p_W[i - 1]), b = dev(p_W[i]);
    cairo_move_to(cr, a.x(), a.y());
    cairo_line_to(cr, b.x(), b.y());
    cairo_stroke(cr);
  }
  if (R_W.size() == p_W.size()) {
    const int every = std::max(triad_every, 1);
    cairo_set_line_width(cr, 1.0);
    for (size_t i = 0; i < p_W.size(); i += every) {
      if (!p_W[i].allFinite() || !R_W[i].allFinite())
        continue;
      const auto o = dev(p_W[i]);
      for (int a = 0; a < 3; ++a) {
        SetColor(cr, a == 0   ? Color{0.85, 0.1, 0.1}
                     : a == 1 ? Color{0.1, 0.65, 0.1}
                              : Color{0.1, 0.2, 0.9});
        const auto e = dev(p_W[i] + triad * R_W[i].col(a));
        cairo_move_to(cr, o.x(), o.y());
        cairo_line_to(cr, e.x(), e.y());
        cairo_stroke(cr);
      }
    }
  }
  // World axes legend at the bottom left.
  const Eigen::Vector2d o(p.x + 28, p.y + p.h - 28);
  SetFont(cr, 9, true);
  const char* names[] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    const Eigen::Vector3d e = Eigen::Vector3d::Unit(a);
    const Eigen::Vector2d d(right.dot(e), -up.dot(e));
    SetColor(cr, a == 0   ? Color{0.85, 0.1, 0.1}
                 : a == 1 ? Color{0.1, 0.65, 0.1}
                          : Color{0.1, 0.2, 0.9});
    cairo_set_line_width(cr, 1.5);
    Arrow(cr, o.x(), o.y(), o.x() + 20 * d.x(), o.y() + 20 * d.y(), 4);
    Text(cr, names[a], o.x() + 26 * d.x(), o.y() + 26 * d.y(), 0.5, 0.5);
  }
  SetFont(cr, 8.5);
  cairo_set_source_rgb(cr, 0.3, 0.3, 0.3);
  Text(cr,
       "world frame, orthographic; box " + FormatNumber(hi3.x() - lo3.x(), 3) + " x " +
           FormatNumber(hi3.y() - lo3.y(), 3) + " x " + FormatNumber(hi3.z() - lo3.z(), 3) +
           " m; path coloured by time",
       p.x + p.w - 4, p.y + p.h - 4, 1.0, 1.0);
}

// --------------------------------------------------------------------------------- MatrixPlot

bool MatrixPlot::HasData() const {
  return values.size() > 0 && values.array().isFinite().any();
}

void MatrixPlot::Draw(void* cairo, const Rect& area) const {
  cairo_t* cr = Cr(cairo);
  PanelTitle(cr, title, area);
  const int n = static_cast<int>(values.rows());
  SetFont(cr, n > 40 ? 5.5 : n > 20 ? 7.0 : 8.5);
  double label_w = 0;
  for (const auto& s : names)
    label_w = std::max(label_w, TextWidth(cr, s));
  label_w = std::min(label_w + 6, area.w * 0.3);
  const double side = std::min(area.w - label_w - 90, area.h - 26 - label_w);
  const Rect p{area.x + label_w, area.y + 22, side, side};
  if (!HasData() || side < 20 || values.cols() != n) {
    NoData(cr, Rect{area.x + 8, area.y + 22, area.w - 16, area.h - 30}, "no correlation data");
    return;
  }
  const double cell = side / n;
  // One image pixel per cell, scaled up without smoothing: the ~100 parameters of a rig are
  // 10 000 cells, which as filled rectangles were 0.6 MB of a PDF page.
  cairo_surface_t* cells = cairo_image_surface_create(CAIRO_FORMAT_RGB24, n, n);
  cairo_surface_flush(cells);
  unsigned char* pixels = cairo_image_surface_get_data(cells);
  const int stride = cairo_image_surface_get_stride(cells);
  if (pixels != nullptr) {
    const auto channel = [](double v) {
      return static_cast<std::uint32_t>(std::clamp(v, 0.0, 1.0) * 255.0 + 0.5);
    };
    for (int r = 0; r < n; ++r) {
      auto* row = reinterpret_cast<std::uint32_t*>(pixels + static_cast<size_t>(r) * stride);
      for (int c = 0; c < n; ++c) {
        const Color k = Diverging(values(r, c));
        row[c] = (channel(k.r) << 16) | (channel(k.g) << 8) | channel(k.b);
      }
    }
  }
  cairo_surface_mark_dirty(cells);
  cairo_save(cr);
  cairo_translate(cr, p.x, p.y);
  cairo_scale(cr, cell, cell);
  cairo_set_source_surface(cr, cells, 0.0, 0.0);
  cairo_pattern_set_filter(cairo_get_source(cr), CAIRO_FILTER_NEAREST);
  cairo_rectangle(cr, 0.0, 0.0, n, n);
  cairo_fill(cr);
  cairo_restore(cr);
  cairo_surface_destroy(cells);
  cairo_set_source_rgb(cr, 0.25, 0.25, 0.25);
  cairo_set_line_width(cr, 0.8);
  cairo_rectangle(cr, p.x, p.y, p.w, p.h);
  cairo_stroke(cr);
  // Labels only when they are legible.
  if (cell >= 5.0) {
    cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
    for (int i = 0; i < n && i < static_cast<int>(names.size()); ++i) {
      const std::string s = Fit(cr, names[i], label_w - 4);
      Text(cr, s, p.x - 3, p.y + (i + 0.5) * cell, 1.0, 0.5);
      Text(cr, s, p.x + (i + 0.5) * cell, p.y + p.h + 3, 1.0, 0.5, -M_PI / 2);
    }
  } else if (!names.empty()) {
    // Too many for a label each: one per quantity (`cam0.intrinsics`, the name up to its
    // index), with thin lines between the quantities so that blocks can be told apart.
    std::vector<std::pair<int, int>> groups;
    std::vector<std::string> keys;
    for (int i = 0; i < n && i < static_cast<int>(names.size()); ++i) {
      const std::string key = names[i].substr(0, names[i].find('['));
      if (keys.empty() || keys.back() != key) {
        groups.emplace_back(i, i + 1);
        keys.push_back(key);
      } else {
        groups.back().second = i + 1;
      }
    }
    cairo_set_source_rgba(cr, 0.2, 0.2, 0.2, 0.35);
    cairo_set_line_width(cr, 0.4);
    for (const auto& [begin, end] : groups) {
      if (begin == 0)
        continue;
      cairo_move_to(cr, p.x + begin * cell, p.y);
      cairo_line_to(cr, p.x + begin * cell, p.y + p.h);
      cairo_move_to(cr, p.x, p.y + begin * cell);
      cairo_line_to(cr, p.x + p.w, p.y + begin * cell);
    }
    cairo_stroke(cr);
    cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
    for (std::size_t g = 0; g < groups.size(); ++g) {
      const double span = (groups[g].second - groups[g].first) * cell;
      if (span < 5.0)
        continue;
      const double mid = (groups[g].first + groups[g].second) * 0.5 * cell;
      const std::string s = Fit(cr, keys[g], label_w - 4);
      Text(cr, s, p.x - 3, p.y + mid, 1.0, 0.5);
      Text(cr, s, p.x + mid, p.y + p.h + 3, 1.0, 0.5, -M_PI / 2);
    }
  }
  ColorBar(cr, Rect{p.x + p.w + 10, p.y, 12, p.h}, -1.0, 1.0, "correlation",
           [](double t) { return Diverging(2.0 * t - 1.0); });
}

// ---------------------------------------------------------------------------------- TextPanel

void TextPanel::Draw(void* cairo, const Rect& area) const {
  cairo_t* cr = Cr(cairo);
  PanelTitle(cr, title, area);
  double fs = font_size;
  double y = area.y + (title.empty() ? 4 : 24);
  if (min_font_size > 0.0 && !lines.empty()) {
    // Monospace blocks (code to paste) must not wrap or be cut: shrink to the widest line and
    // to the height.
    SetFont(cr, fs, false, monospace);
    double widest = 0.0;
    for (const std::string& line : lines)
      widest = std::max(widest, TextWidth(cr, line));
    // 3 % margin: hinted glyph advances do not scale exactly with the size.
    const double by_width =
        monospace && widest > area.w - 8 ? 0.97 * fs * (area.w - 8) / widest : fs;
    const double by_height = (area.y + area.h - y) / (1.45 * static_cast<double>(lines.size()));
    fs = std::max(min_font_size, std::min({fs, by_width, by_height}));
  }
  SetFont(cr, fs, false, monospace);
  cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
  const double lh = fs * 1.45;
  for (const std::string& line : lines) {
    // Greedy word wrap (monospace blocks are not wrapped, only cut).
    std::istringstream words(line);
    std::string word, current;
    auto flush = [&](const std::string& s) {
      if (y + lh <= area.y + area.h)
        Text(cr, Fit(cr, s, area.w - 8), area.x + 4, y, 0.0, 0.0);
      y += lh;
    };
    if (monospace) {
      flush(line);
      continue;
    }
    while (words >> word) {
      const std::string trial = current.empty() ? word : current + " " + word;
      if (TextWidth(cr, trial) > area.w - 8 && !current.empty()) {
        flush(current);
        current = word;
      } else {
        current = trial;
      }
    }
    flush(current);
  }
}

// ------------------------------------------------------------------------------------- Figure

Figure::Figure(int rows, int cols, double width, double height)
    : rows_(std::max(rows, 1)), cols_(std::max(cols, 1)), width_(width), height_(height) {}

void Figure::SetSpan(int panel_index, int row_span, int col_span) {
  if (spans_.size() < panels_.size())
    spans_.resize(panels_.size(), {1, 1});
  if (panel_index >= 0 && panel_index < static_cast<int>(spans_.size()))
    spans_[panel_index] = {std::max(row_span, 1), std::max(col_span, 1)};
}

bool Figure::HasData() const {
  return std::any_of(panels_.begin(), panels_.end(),
                     [](const std::unique_ptr<Panel>& p) { return p->HasData(); });
}

void Figure::Draw(void* cairo) const {
  cairo_t* cr = Cr(cairo);
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_paint(cr);
  double top = 8;
  if (!title.empty()) {
    SetFont(cr, 14, true);
    cairo_set_source_rgb(cr, 0.05, 0.05, 0.05);
    Text(cr, title, 12, 8, 0.0, 0.0);
    top = 30;
  }
  const double cw = (width_ - 16) / cols_, ch = (height_ - top - 6) / rows_;
  std::vector<std::vector<bool>> used(rows_, std::vector<bool>(cols_, false));
  for (size_t i = 0; i < panels_.size(); ++i) {
    const auto span = i < spans_.size() ? spans_[i] : std::pair<int, int>{1, 1};
    // Next free cell, row-major.
    int r = -1, c = -1;
    for (int rr = 0; rr < rows_ && r < 0; ++rr) {
      for (int cc = 0; cc < cols_; ++cc) {
        if (!used[rr][cc]) {
          r = rr;
          c = cc;
          break;
        }
      }
    }
    if (r < 0)
      break;  // more panels than cells: the rest is not drawn
    const int rs = std::min(span.first, rows_ - r), cs = std::min(span.second, cols_ - c);
    for (int rr = r; rr < r + rs; ++rr) {
      for (int cc = c; cc < c + cs; ++cc)
        used[rr][cc] = true;
    }
    const Rect area{8 + c * cw + 4, top + r * ch + 2, cs * cw - 8, rs * ch - 6};
    cairo_save(cr);
    panels_[i]->Draw(cr, area);
    cairo_restore(cr);
  }
}

// ------------------------------------------------------------------------------------ outputs

namespace {

cairo_status_t AppendToString(void* closure, const unsigned char* data, unsigned int length) {
  static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
  return CAIRO_STATUS_SUCCESS;
}

cairo_surface_t* DrawImage(const Figure& figure, double scale) {
  const int w = static_cast<int>(std::ceil(figure.width() * scale));
  const int h = static_cast<int>(std::ceil(figure.height() * scale));
  cairo_surface_t* surface = cairo_image_surface_create(CAIRO_FORMAT_RGB24, w, h);
  cairo_t* cr = cairo_create(surface);
  cairo_scale(cr, scale, scale);
  figure.Draw(cr);
  cairo_destroy(cr);
  cairo_surface_flush(surface);
  return surface;
}

}  // namespace

namespace {

void AppendBigEndian(std::string* out, std::uint32_t v) {
  for (const int shift : {24, 16, 8, 0})
    out->push_back(static_cast<char>((v >> shift) & 0xffu));
}

// One PNG chunk: length, type, data, CRC-32 of type and data.
void AppendChunk(std::string* out, const char* type, const char* data, std::size_t size) {
  AppendBigEndian(out, static_cast<std::uint32_t>(size));
  const std::size_t at = out->size();
  out->append(type, 4);
  out->append(data, size);
  AppendBigEndian(out, libdeflate_crc32(0, out->data() + at, size + 4));
}

// 8-bit RGB PNG of an RGB24 surface, every row "up"-filtered (plots are mostly flat colour), the
// image data one zlib stream by libdeflate at level 2: the size of zlib's level 2 (cairo's own
// writer uses level 6, ~40 % of the report's rendering time) at a third of its time.
std::string EncodePng(cairo_surface_t* surface) {
  const int w = cairo_image_surface_get_width(surface);
  const int h = cairo_image_surface_get_height(surface);
  const int stride = cairo_image_surface_get_stride(surface);
  const unsigned char* data = cairo_image_surface_get_data(surface);
  const std::size_t row_bytes = 1 + 3 * static_cast<std::size_t>(w);
  std::vector<unsigned char> filtered(row_bytes * static_cast<std::size_t>(h));
  std::vector<unsigned char> rgb(3 * static_cast<std::size_t>(w)), above(rgb.size(), 0);
  for (int y = 0; y < h; ++y) {
    const auto* px = reinterpret_cast<const std::uint32_t*>(data + static_cast<size_t>(y) * stride);
    for (int x = 0; x < w; ++x) {
      rgb[3 * x] = static_cast<unsigned char>((px[x] >> 16) & 0xffu);
      rgb[3 * x + 1] = static_cast<unsigned char>((px[x] >> 8) & 0xffu);
      rgb[3 * x + 2] = static_cast<unsigned char>(px[x] & 0xffu);
    }
    unsigned char* row = &filtered[static_cast<std::size_t>(y) * row_bytes];
    row[0] = 2;  // "up": each byte minus the byte above it
    for (std::size_t i = 0; i < rgb.size(); ++i)
      row[1 + i] = static_cast<unsigned char>(rgb[i] - above[i]);
    std::swap(rgb, above);
  }
  libdeflate_compressor* compressor = libdeflate_alloc_compressor(2);
  if (compressor == nullptr)
    throw std::runtime_error("PNG encoding failed: out of memory");
  std::string idat(libdeflate_zlib_compress_bound(compressor, filtered.size()), '\0');
  const std::size_t packed = libdeflate_zlib_compress(compressor, filtered.data(), filtered.size(),
                                                      idat.data(), idat.size());
  libdeflate_free_compressor(compressor);
  if (packed == 0)
    throw std::runtime_error("PNG encoding failed: compression");
  std::string bytes("\x89PNG\r\n\x1a\n", 8);
  std::string header;
  AppendBigEndian(&header, static_cast<std::uint32_t>(w));
  AppendBigEndian(&header, static_cast<std::uint32_t>(h));
  header += std::string("\x08\x02\x00\x00\x00", 5);  // 8 bits, RGB, deflate, filters, no interlace
  AppendChunk(&bytes, "IHDR", header.data(), header.size());
  AppendChunk(&bytes, "IDAT", idat.data(), packed);
  AppendChunk(&bytes, "IEND", nullptr, 0);
  return bytes;
}

}  // namespace

std::string RenderPng(const Figure& figure, double scale) {
  cairo_surface_t* surface = DrawImage(figure, scale);
  try {
    std::string bytes = EncodePng(surface);
    cairo_surface_destroy(surface);
    return bytes;
  } catch (...) {
    cairo_surface_destroy(surface);
    throw;
  }
}

void SavePng(const Figure& figure, const std::string& path, double scale) {
  const std::string bytes = RenderPng(figure, scale);
  std::ofstream f(path, std::ios::binary);
  f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!f)
    throw std::runtime_error(path + ": cannot write PNG");
}

std::string RenderSvg(const Figure& figure) {
  std::string svg;
  cairo_surface_t* surface =
      cairo_svg_surface_create_for_stream(AppendToString, &svg, figure.width(), figure.height());
  cairo_t* cr = cairo_create(surface);
  figure.Draw(cr);
  cairo_destroy(cr);
  cairo_surface_finish(surface);
  const cairo_status_t st = cairo_surface_status(surface);
  cairo_surface_destroy(surface);
  if (st != CAIRO_STATUS_SUCCESS)
    throw std::runtime_error(std::string("SVG rendering failed: ") + cairo_status_to_string(st));
  return svg;
}

PdfDocument::PdfDocument(const std::string& path) : path_(path) {
  cairo_surface_t* s = cairo_pdf_surface_create(path.c_str(), 842, 595);
  if (cairo_surface_status(s) != CAIRO_STATUS_SUCCESS) {
    const std::string why = cairo_status_to_string(cairo_surface_status(s));
    cairo_surface_destroy(s);
    throw std::runtime_error(path + ": cannot create PDF: " + why);
  }
  surface_ = s;
}

PdfDocument::~PdfDocument() {
  try {
    Close();
  } catch (...) {  // a destructor must not throw; Close() reports errors to explicit callers
  }
}

void PdfDocument::AddPage(const Figure& figure) {
  auto* s = static_cast<cairo_surface_t*>(surface_);
  if (!s)
    throw std::logic_error(path_ + ": PDF already closed");
  cairo_pdf_surface_set_size(s, figure.width(), figure.height());
  cairo_t* cr = cairo_create(s);
  figure.Draw(cr);
  cairo_show_page(cr);
  cairo_destroy(cr);
  ++pages_;
}

void PdfDocument::Close() {
  auto* s = static_cast<cairo_surface_t*>(surface_);
  if (!s)
    return;
  surface_ = nullptr;
  cairo_surface_finish(s);
  const cairo_status_t st = cairo_surface_status(s);
  cairo_surface_destroy(s);
  if (st != CAIRO_STATUS_SUCCESS)
    throw std::runtime_error(path_ + ": writing the PDF failed: " + cairo_status_to_string(st));
}

}  // namespace ctcal::report
