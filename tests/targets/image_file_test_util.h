// Image files written without OpenCV for the image file tests: PNGs by libpng (palettes, grey with
// alpha, 1/2/4-bit grey, tRNS, interlacing, hand-made chunks) and JPEGs by libjpeg (CMYK, any scan
// script), which cv::imwrite / cv::imencode cannot write. The libraries abort (libpng) or exit
// (libjpeg) on an error here: only valid data is written.
#pragma once

// jpeglib.h needs FILE and size_t declared before it.
#include <cstdio>

#include <jpeglib.h>
#include <png.h>
#include <zlib.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace ctcal::image_test {

// A PNG written by libpng itself (what cv::imwrite cannot write: palettes, grey + alpha, 1/2/4-bit
// grey, tRNS, interlacing). `rows` holds the packed rows as PNG stores them (16-bit big-endian).
struct PngSpec {
  int width = 0, height = 0, bit_depth = 8, color_type = PNG_COLOR_TYPE_GRAY;
  bool interlaced = false;
  std::vector<png_color> palette;
  std::vector<png_byte> trans;  // palette alpha
  bool trans_color = false;     // grey / RGB tRNS: the colour of the first pixel
  int filters = 0;              // png_set_filter's mask (0: libpng's default)
  std::size_t idat_bytes = 0;   // the largest IDAT chunk (0: libpng's default, 8 KiB)
  std::vector<std::vector<std::uint8_t>> rows;
};

inline void AppendBytes(png_structp png, png_bytep data, std::size_t length) {
  auto* out = static_cast<std::vector<std::uint8_t>*>(png_get_io_ptr(png));
  out->insert(out->end(), data, data + length);
}

// libpng aborts on an error here (no setjmp): only valid specs are written.
inline std::vector<std::uint8_t> EncodePng(const PngSpec& s) {
  std::vector<std::uint8_t> out;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  png_set_write_fn(png, &out, AppendBytes, nullptr);
  if (s.filters != 0)
    png_set_filter(png, PNG_FILTER_TYPE_BASE, s.filters);
  if (s.idat_bytes != 0)
    png_set_compression_buffer_size(png, s.idat_bytes);
  png_set_IHDR(png, info, s.width, s.height, s.bit_depth, s.color_type,
               s.interlaced ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  if (!s.palette.empty())
    png_set_PLTE(png, info, s.palette.data(), static_cast<int>(s.palette.size()));
  if (!s.trans.empty())
    png_set_tRNS(png, info, s.trans.data(), static_cast<int>(s.trans.size()), nullptr);
  if (s.trans_color) {
    // The first sample(s) of the first row, as a 16-bit value per channel.
    png_color_16 colour{};
    const std::vector<std::uint8_t>& r = s.rows[0];
    const auto sample = [&](int i) -> png_uint_16 {
      if (s.bit_depth == 16)
        return static_cast<png_uint_16>(r[2 * i] << 8 | r[2 * i + 1]);
      if (s.bit_depth == 8)
        return r[i];
      return static_cast<png_uint_16>(r[0] >> (8 - s.bit_depth));
    };
    if (s.color_type == PNG_COLOR_TYPE_GRAY) {
      colour.gray = sample(0);
    } else {
      colour.red = sample(0);
      colour.green = sample(1);
      colour.blue = sample(2);
    }
    png_set_tRNS(png, info, nullptr, 0, &colour);
  }
  png_write_info(png, info);
  const int passes = png_set_interlace_handling(png);
  for (int pass = 0; pass < passes; ++pass) {
    for (const std::vector<std::uint8_t>& row : s.rows)
      png_write_row(png, row.data());
  }
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return out;
}

// Random packed rows of `bytes_per_row`.
inline std::vector<std::vector<std::uint8_t>> RandomRows(int height, int bytes_per_row,
                                                         std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<std::vector<std::uint8_t>> rows(height, std::vector<std::uint8_t>(bytes_per_row));
  for (auto& row : rows) {
    for (auto& b : row)
      b = static_cast<std::uint8_t>(rng());
  }
  return rows;
}

inline PngSpec Spec(int color_type, int bit_depth, int samples_per_pixel, std::uint32_t seed) {
  PngSpec s;
  s.width = 37;  // odd sizes: partial bytes at the end of packed rows, every Adam7 pass partial
  s.height = 23;
  s.bit_depth = bit_depth;
  s.color_type = color_type;
  s.rows = RandomRows(s.height, (s.width * samples_per_pixel * bit_depth + 7) / 8, seed);
  return s;
}

// Every colour type, depth and option a PNG has, read as cv::imdecode(IMREAD_UNCHANGED) reads it.
inline std::vector<std::pair<std::string, PngSpec>> PngCases() {
  std::vector<std::pair<std::string, PngSpec>> cases;
  for (int depth : {1, 2, 4, 8, 16})
    cases.emplace_back("grey " + std::to_string(depth) + "-bit",
                       Spec(PNG_COLOR_TYPE_GRAY, depth, 1, depth));
  for (int depth : {8, 16}) {
    const std::string d = " " + std::to_string(depth) + "-bit";
    cases.emplace_back("grey+alpha" + d, Spec(PNG_COLOR_TYPE_GRAY_ALPHA, depth, 2, 20 + depth));
    cases.emplace_back("rgb" + d, Spec(PNG_COLOR_TYPE_RGB, depth, 3, 30 + depth));
    cases.emplace_back("rgba" + d, Spec(PNG_COLOR_TYPE_RGB_ALPHA, depth, 4, 40 + depth));
    PngSpec grey_trns = Spec(PNG_COLOR_TYPE_GRAY, depth, 1, 50 + depth);
    grey_trns.trans_color = true;
    cases.emplace_back("grey tRNS" + d, grey_trns);
    PngSpec rgb_trns = Spec(PNG_COLOR_TYPE_RGB, depth, 3, 60 + depth);
    rgb_trns.trans_color = true;
    cases.emplace_back("rgb tRNS" + d, rgb_trns);
  }
  for (int depth : {1, 2, 4, 8}) {
    for (bool alpha : {false, true}) {
      PngSpec s = Spec(PNG_COLOR_TYPE_PALETTE, depth, 1, 70 + depth);
      const int entries = 1 << depth;
      for (int i = 0; i < entries; ++i) {
        s.palette.push_back({static_cast<png_byte>(i * 37), static_cast<png_byte>(255 - i),
                             static_cast<png_byte>(i * 11 + 3)});
        if (alpha)
          s.trans.push_back(static_cast<png_byte>(255 - 2 * i));
      }
      cases.emplace_back("palette " + std::to_string(depth) + "-bit" + (alpha ? " tRNS" : ""), s);
    }
  }
  PngSpec interlaced_rgb = Spec(PNG_COLOR_TYPE_RGB, 8, 3, 90);
  interlaced_rgb.interlaced = true;
  cases.emplace_back("interlaced rgb 8-bit", interlaced_rgb);
  PngSpec interlaced_grey = Spec(PNG_COLOR_TYPE_GRAY, 16, 1, 91);
  interlaced_grey.interlaced = true;
  cases.emplace_back("interlaced grey 16-bit", interlaced_grey);
  PngSpec interlaced_palette = Spec(PNG_COLOR_TYPE_PALETTE, 2, 1, 92);
  interlaced_palette.palette = {{0, 0, 0}, {255, 0, 0}, {0, 255, 0}, {0, 0, 255}};
  interlaced_palette.interlaced = true;
  cases.emplace_back("interlaced palette 2-bit", interlaced_palette);
  return cases;
}

// The row filter types of a non-interlaced PNG (its IDAT chunks inflated) and how many IDATs
// it has.
inline std::pair<std::set<int>, int> FiltersAndIdats(const std::vector<std::uint8_t>& png,
                                                     std::size_t row_bytes, int height) {
  std::vector<std::uint8_t> stream;
  int idats = 0;
  for (std::size_t at = 8; at + 12 <= png.size();) {
    const std::size_t length = std::size_t(png[at]) << 24 | std::size_t(png[at + 1]) << 16 |
                               std::size_t(png[at + 2]) << 8 | png[at + 3];
    if (std::memcmp(png.data() + at + 4, "IDAT", 4) == 0) {
      stream.insert(stream.end(), png.begin() + at + 8, png.begin() + at + 8 + length);
      ++idats;
    }
    at += length + 12;
  }
  std::vector<std::uint8_t> rows((row_bytes + 1) * height);
  uLongf size = rows.size();
  std::set<int> types;
  if (uncompress(rows.data(), &size, stream.data(), stream.size()) == Z_OK) {
    for (int y = 0; y < height; ++y)
      types.insert(rows[y * (row_bytes + 1)]);
  }
  return {types, idats};
}

// The PNG chunk `type` + `data` with its length and CRC.
inline void AppendChunk(std::vector<std::uint8_t>* png, const char* type,
                        const std::vector<std::uint8_t>& data) {
  const auto put32 = [&](std::uint32_t v) {
    for (int shift = 24; shift >= 0; shift -= 8)
      png->push_back(static_cast<std::uint8_t>(v >> shift));
  };
  put32(static_cast<std::uint32_t>(data.size()));
  std::vector<std::uint8_t> typed(type, type + 4);
  typed.insert(typed.end(), data.begin(), data.end());
  png->insert(png->end(), typed.begin(), typed.end());
  put32(static_cast<std::uint32_t>(crc32(0, typed.data(), static_cast<uInt>(typed.size()))));
}

// A 16 x 8 JPEG written by libjpeg itself (what cv::imencode cannot write): `components` samples
// per pixel in `colour_space`, `scans` its scan script when not empty. libjpeg exits on an error
// here: only valid data is written.
inline std::vector<std::uint8_t> EncodeJpeg(int components, J_COLOR_SPACE colour_space,
                                            const std::vector<jpeg_scan_info>& scans = {}) {
  jpeg_compress_struct cinfo;
  jpeg_error_mgr err;
  cinfo.err = jpeg_std_error(&err);
  jpeg_create_compress(&cinfo);
  unsigned char* out = nullptr;
  unsigned long size = 0;
  jpeg_mem_dest(&cinfo, &out, &size);
  cinfo.image_width = 16;
  cinfo.image_height = 8;
  cinfo.input_components = components;
  cinfo.in_color_space = colour_space;
  jpeg_set_defaults(&cinfo);
  if (!scans.empty()) {
    cinfo.scan_info = scans.data();
    cinfo.num_scans = static_cast<int>(scans.size());
  }
  jpeg_start_compress(&cinfo, TRUE);
  std::vector<JSAMPLE> row(16 * components);
  while (cinfo.next_scanline < cinfo.image_height) {
    for (std::size_t i = 0; i < row.size(); ++i)
      row[i] = static_cast<JSAMPLE>(i * 37 + cinfo.next_scanline * 11);
    JSAMPROW p = row.data();
    jpeg_write_scanlines(&cinfo, &p, 1);
  }
  jpeg_finish_compress(&cinfo);
  const std::vector<std::uint8_t> bytes(out, out + size);
  jpeg_destroy_compress(&cinfo);
  std::free(out);
  return bytes;
}

// Where a JPEG's frame header (SOF0 or SOF2) holds height and width; past the end for a PNG.
inline std::size_t SofSizeOffset(const std::vector<std::uint8_t>& bytes) {
  for (std::size_t i = 2; i + 9 < bytes.size(); ++i) {
    if (bytes[i] == 0xFF && (bytes[i + 1] == 0xC0 || bytes[i + 1] == 0xC2))
      return i + 5;  // marker, length (2), precision (1)
  }
  return bytes.size();
}

}  // namespace ctcal::image_test
