// The drawing helpers shared by plot.h's panels (plot_*.cpp): fonts, text, ticks, axes, colour
// bars, arrows. One style for everything: DejaVu Sans, light grid, thin dark axes, tab10 colours,
// titles bold at the top left of their panel. Private to the report library.
#pragma once

#include <cairo.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "ctcal/report/plot.h"

namespace ctcal::report::detail {

constexpr const char* kFont = "DejaVu Sans";
constexpr const char* kMono = "DejaVu Sans Mono";
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

cairo_t* Cr(void* p);
void SetColor(cairo_t* cr, const Color& c);
void SetFont(cairo_t* cr, double size, bool bold = false, bool mono = false);
double TextWidth(cairo_t* cr, const std::string& s);

// Text anchored at (x, y): ax, ay in {0, 0.5, 1} = left/centre/right, top/middle/baseline-ish.
void Text(cairo_t* cr, const std::string& s, double x, double y, double ax, double ay,
          double angle = 0.0);

// Shortens `s` with an ellipsis to fit `max_w`.
std::string Fit(cairo_t* cr, std::string s, double max_w);

// "Nice" tick positions covering [lo, hi] (Heckbert's loose labelling, about n ticks).
std::vector<double> Ticks(double lo, double hi, int n);

void Range(const std::vector<double>& v, double* lo, double* hi);

// Pads a degenerate or tight range so that data do not sit on the frame.
void Pad(double* lo, double* hi, double frac);

void PanelTitle(cairo_t* cr, const std::string& title, const Rect& a);
void NoData(cairo_t* cr, const Rect& a, const std::string& why);

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
              bool grid);

void Arrow(cairo_t* cr, double x0, double y0, double x1, double y1, double head);

}  // namespace ctcal::report::detail
