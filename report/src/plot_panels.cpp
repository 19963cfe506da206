// The other panels of plot.h: HeatMap, Table, Trajectory3D, MatrixPlot, TextPanel.
#include <cairo.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <vector>

#include "plot_draw.h"

namespace ctcal::report {
using namespace detail;  // NOLINT(build/namespaces): plot_draw.h is this file's toolbox

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

}  // namespace ctcal::report
