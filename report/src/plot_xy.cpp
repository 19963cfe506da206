// XYPlot (plot.h): lines, scatters, bands, arrows and histograms on one pair of axes.
#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "plot_draw.h"

namespace ctcal::report {
using namespace detail;  // NOLINT(build/namespaces): plot_draw.h is this file's toolbox
namespace {

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
    if (alpha != coverage_alpha_) {
      // The dot's opacity per mask pixel, (alpha m + 127) / 255: a series' dots share their alpha.
      coverage_alpha_ = alpha;
      coverage_.resize(mask_.size());
      for (size_t k = 0; k < mask_.size(); ++k)
        coverage_[k] = static_cast<std::uint8_t>((alpha * mask_[k] + 127u) / 255u);
    }
    const std::uint32_t opaque = 0xff000000u | (r << 16) | (g << 8) | b;
    // The source's channels two to a word, each in 16 bits: red and blue, alpha (255) and green.
    const std::uint32_t src_rb = (r << 16) | b, src_ag = (255u << 16) | g;
    for (int dy = -reach_; dy <= reach_; ++dy) {
      const int py = cy + dy;
      if (py < 0 || py >= h_)
        continue;
      auto* row = reinterpret_cast<std::uint32_t*>(data_ + static_cast<size_t>(py) * stride_);
      const std::uint8_t* m = &coverage_[static_cast<size_t>(dy + reach_) * side];
      // Only the disc's own pixels of this row (the mask is 0 outside [first, last]).
      const auto [first, last] = span_[static_cast<size_t>(dy + reach_)];
      for (int dx = std::max(first, -cx); dx <= std::min(last, w_ - 1 - cx); ++dx) {
        const int px = cx + dx;
        const std::uint32_t a = m[dx + reach_];
        if (a == 255) {  // "over" with full coverage is the source itself
          row[px] = opaque;
          continue;
        }
        if (a == 0)
          continue;
        // Premultiplied ARGB32 "over", out = (src a + dst (255 - a) + 127) / 255 per 8-bit
        // channel, two channels at a time: each sum is below 2^16, and (t + (t >> 8)) >> 8 of
        // t = sum + 128 is that quotient exactly for sums up to 255^2.
        const std::uint32_t d = row[px];
        const std::uint32_t ia = 255u - a;
        std::uint32_t rb = src_rb * a + (d & 0x00ff00ffu) * ia + 0x00800080u;
        std::uint32_t ag = src_ag * a + ((d >> 8) & 0x00ff00ffu) * ia + 0x00800080u;
        rb = ((rb + ((rb >> 8) & 0x00ff00ffu)) >> 8) & 0x00ff00ffu;
        ag = (ag + ((ag >> 8) & 0x00ff00ffu)) & 0xff00ff00u;
        row[px] = rb | ag;
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
  std::vector<std::uint8_t> coverage_;     // mask_ times the dots' alpha (Stamp)
  std::uint32_t coverage_alpha_ = 256;     // the alpha coverage_ holds (256: none yet)
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
        // Each dot a zero-length subpath stroked with round caps at twice its radius: the disc
        // cairo_arc's fill would give (cairo and the PDF format both paint such a subpath as a
        // filled circle), written on a PDF page as "x y m x y l S" instead of two Bezier arcs.
        // The demo report's page text, which cairo formats and deflates on the report's longest
        // thread, 4.2 -> 3.6 MB.
        cairo_save(cr);
        cairo_set_dash(cr, nullptr, 0, 0.0);
        cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
        cairo_set_line_width(cr, 2.0 * s.width);
        for (size_t i = 0; i < n; ++i) {
          if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i]))
            continue;
          SetColor(cr, color_of(i));
          const double x = ax.X(s.x[i]), y = ax.Y(s.y[i]);
          cairo_move_to(cr, x, y);
          cairo_line_to(cr, x, y);
          cairo_stroke(cr);
        }
        cairo_restore(cr);
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

}  // namespace ctcal::report
