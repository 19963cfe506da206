// The drawing helpers of plot_draw.h and plot.h's colour maps and number format.
#include "plot_draw.h"

#include <algorithm>
#include <cstdio>

namespace ctcal::report {
namespace detail {

cairo_t* Cr(void* p) {
  return static_cast<cairo_t*>(p);
}

void SetColor(cairo_t* cr, const Color& c) {
  cairo_set_source_rgba(cr, c.r, c.g, c.b, c.a);
}

void SetFont(cairo_t* cr, double size, bool bold, bool mono) {
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
          double angle) {
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

}  // namespace detail

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

}  // namespace ctcal::report
