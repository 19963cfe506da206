#include "ctcal/targets/board_pdf.h"

#include <cairo-pdf.h>
#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

namespace ctcal {
namespace {

constexpr double kPointsPerMetre = 72.0 / 0.0254;
constexpr double kCaptionBand = 0.022;  // m below the pattern: scale bar and text

std::string Format(const char* format, double a, double b = 0.0, double c = 0.0) {
  char buffer[256];
  std::snprintf(buffer, sizeof(buffer), format, a, b, c);
  return buffer;
}

}  // namespace

Eigen::Vector2d BoardPdfPageSize(const Board& board, const BoardPdfOptions& options) {
  const Eigen::AlignedBox2d box = board.PatternBox();
  return Eigen::Vector2d(box.sizes().x() + 2.0 * options.margin_m,
                         box.sizes().y() + 2.0 * options.margin_m + kCaptionBand);
}

void WriteBoardPdf(const Board& board, const std::string& path, const BoardPdfOptions& options) {
  const Eigen::AlignedBox2d box = board.PatternBox();
  const Eigen::Vector2d page = BoardPdfPageSize(board, options);
  cairo_surface_t* surface = cairo_pdf_surface_create(path.c_str(), page.x() * kPointsPerMetre,
                                                      page.y() * kPointsPerMetre);
  if (cairo_surface_status(surface) != CAIRO_STATUS_SUCCESS) {
    const std::string what = cairo_status_to_string(cairo_surface_status(surface));
    cairo_surface_destroy(surface);
    throw std::runtime_error(path + ": cannot write the PDF (" + what + ")");
  }
  cairo_t* cr = cairo_create(surface);
  // Work in metres on the board plane: x right, y up, the caption band under the pattern.
  cairo_scale(cr, kPointsPerMetre, kPointsPerMetre);
  cairo_translate(cr, options.margin_m - box.min().x(), options.margin_m + box.max().y());
  cairo_scale(cr, 1.0, -1.0);

  // One path for all black cells, filled once: abutting cells merge without hairline seams.
  cairo_set_source_rgb(cr, 0.0, 0.0, 0.0);
  cairo_set_fill_rule(cr, CAIRO_FILL_RULE_WINDING);
  if (board.type() == TargetType::kAprilGrid) {
    const double size = board.config().tag_size;
    const double gap = board.config().tag_spacing * size;
    const double period = size + gap;
    const double bit = board.TagBitSize();
    const int cells = Board::kTagDataBits + 2 * board.config().black_tag_border;
    for (int j = 0; j < board.tag_rows(); ++j) {
      for (int i = 0; i < board.tag_cols(); ++i) {
        const double x0 = i * period;
        const double y0 = j * period;
        for (int cy = 0; cy < cells; ++cy) {
          for (int cx = 0; cx < cells; ++cx) {
            if (board.IsBlack(x0 + (cx + 0.5) * bit, y0 + (cy + 0.5) * bit))
              cairo_rectangle(cr, x0 + cx * bit, y0 + cy * bit, bit, bit);
          }
        }
      }
    }
    for (int j = 0; j <= board.tag_rows(); ++j) {
      for (int i = 0; i <= board.tag_cols(); ++i)
        cairo_rectangle(cr, i * period - gap, j * period - gap, gap, gap);
    }
  } else if (board.type() == TargetType::kCharuco) {
    const TargetConfig& t = board.config();
    for (int j = 0; j < t.squares_y; ++j) {
      for (int i = 0; i < t.squares_x; ++i) {
        // A black square, or a white one around a marker (drawn below): its margin tells.
        const double margin = 0.25 * (t.square_length_m - t.marker_length_m);
        if (board.IsBlack(i * t.square_length_m + margin, j * t.square_length_m + margin))
          cairo_rectangle(cr, i * t.square_length_m, j * t.square_length_m, t.square_length_m,
                          t.square_length_m);
      }
    }
    const int cells = board.MarkerCells();
    const double cell = t.marker_length_m / cells;
    for (const Board::Marker& marker : board.Markers()) {
      for (int cy = 0; cy < cells; ++cy) {
        for (int cx = 0; cx < cells; ++cx) {
          const double x0 = marker.top_left.x() + cx * cell;
          const double y0 = marker.top_left.y() - (cy + 1) * cell;
          if (board.IsBlack(x0 + 0.5 * cell, y0 + 0.5 * cell))
            cairo_rectangle(cr, x0, y0, cell, cell);
        }
      }
    }
  } else {
    const double rs = board.config().row_spacing_m;
    const double cs = board.config().col_spacing_m;
    for (int i = 0; i <= board.config().target_rows; ++i) {
      for (int j = 0; j <= board.config().target_cols; ++j) {
        const double x0 = (i - 1) * rs;
        const double y0 = (j - 1) * cs;
        if (board.IsBlack(x0 + 0.5 * rs, y0 + 0.5 * cs))
          cairo_rectangle(cr, x0, y0, rs, cs);
      }
    }
  }
  cairo_fill(cr);

  // Back to page coordinates (metres, y down) for the caption band.
  cairo_identity_matrix(cr);
  cairo_scale(cr, kPointsPerMetre, kPointsPerMetre);
  const double band_top = options.margin_m + box.sizes().y() + 0.004;
  const double left = options.margin_m;
  // The board's axes, as Kalibr draws them: x right (red), y up (green); at the band's right end.
  const double axis = 0.008;
  const double ox = std::max(left, options.margin_m + box.sizes().x() - axis - 0.002);
  const double oy = band_top + 0.015;
  cairo_set_line_width(cr, 0.0004);
  cairo_set_source_rgb(cr, 0.8, 0.0, 0.0);
  cairo_move_to(cr, ox, oy);
  cairo_line_to(cr, ox + axis, oy);
  cairo_stroke(cr);
  cairo_set_source_rgb(cr, 0.0, 0.6, 0.0);
  cairo_move_to(cr, ox, oy);
  cairo_line_to(cr, ox, oy - axis);
  cairo_stroke(cr);

  // Scale bar: 100 mm (50 mm on narrow boards) with centimetre ticks.
  const double bar = box.sizes().x() >= 0.11 ? 0.1 : 0.05;
  cairo_set_source_rgb(cr, 0.0, 0.0, 0.0);
  cairo_set_line_width(cr, 0.0003);
  cairo_move_to(cr, left, band_top + 0.003);
  cairo_line_to(cr, left + bar, band_top + 0.003);
  for (int k = 0; k <= static_cast<int>(std::lround(bar * 100)); ++k) {
    const double tick = (k % 5 == 0) ? 0.003 : 0.0015;
    cairo_move_to(cr, left + 0.01 * k, band_top + 0.003);
    cairo_line_to(cr, left + 0.01 * k, band_top + 0.003 - tick);
  }
  cairo_stroke(cr);

  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, 0.0028);
  cairo_move_to(cr, left + bar + 0.003, band_top + 0.003);
  cairo_show_text(cr,
                  Format("%.0f mm: print at 100 %%, then measure this bar", bar * 1000).c_str());
  std::string line;
  if (board.type() == TargetType::kAprilGrid) {
    const TargetConfig& t = board.config();
    line = "target_type: aprilgrid, tagCols: " + std::to_string(t.tag_cols) +
           ", tagRows: " + std::to_string(t.tag_rows) +
           Format(", tagSize: %.4g m, tagSpacing: %.4g (gap %.1f mm)", t.tag_size, t.tag_spacing,
                  t.tag_spacing * t.tag_size * 1000) +
           ", blackTagBorder: " + std::to_string(t.black_tag_border) + ", tag36h11";
  } else if (board.type() == TargetType::kCharuco) {
    const TargetConfig& t = board.config();
    line = "target_type: charuco, squaresX: " + std::to_string(t.squares_x) +
           ", squaresY: " + std::to_string(t.squares_y) +
           Format(", squareLength: %.4g m, markerLength: %.4g m, dictionary: ", t.square_length_m,
                  t.marker_length_m) +
           t.dictionary;
  } else {
    const TargetConfig& t = board.config();
    line = "target_type: checkerboard, targetCols: " + std::to_string(t.target_cols) +
           ", targetRows: " + std::to_string(t.target_rows) +
           Format(", rowSpacingMeters: %.4g, colSpacingMeters: %.4g", t.row_spacing_m,
                  t.col_spacing_m);
  }
  cairo_move_to(cr, left, band_top + 0.009);
  cairo_show_text(cr, line.c_str());
  cairo_move_to(cr, left, band_top + 0.0135);
  cairo_show_text(cr, "ctcal target: corner 0 at the bottom-left, x right (red), y up (green)");

  cairo_destroy(cr);
  cairo_surface_finish(surface);
  const cairo_status_t status = cairo_surface_status(surface);
  cairo_surface_destroy(surface);
  if (status != CAIRO_STATUS_SUCCESS) {
    throw std::runtime_error(path + ": cannot write the PDF (" +
                             std::string(cairo_status_to_string(status)) + ")");
  }
}

}  // namespace ctcal
