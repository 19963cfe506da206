// Figure (plot.h): the panels' grid on a page, and its outputs: PNG (encoded with libdeflate),
// SVG, PDF pages.
#include <cairo-pdf.h>
#include <cairo-svg.h>
#include <cairo.h>
#include <libdeflate.h>

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <string>
#include <utility>

#include "plot_draw.h"

namespace ctcal::report {
using namespace detail;  // NOLINT(build/namespaces): plot_draw.h is this file's toolbox

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
