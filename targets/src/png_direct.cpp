#include "png_direct.h"

#include <libdeflate.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <utility>
#include <vector>

// The PNG specification (ISO/IEC 15948, W3C "Portable Network Graphics (PNG) Specification"):
// chunks of a 4-byte big-endian length, a 4-byte type, the data and a CRC-32 of type and data;
// IHDR first, the image data as one zlib stream split over consecutive IDAT chunks, IEND last.
// The stream inflates to the rows, each a filter-type byte and the filtered row.

namespace ctcal::internal {
namespace {

constexpr std::uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
constexpr std::uint32_t kMaxChunk = 0x7fffffffu;  // the specification's largest length
// A decoder's buffers stay with its thread between images (a detection reads thousands of the
// same size: fresh pages cost as much as the decoding); beyond this they are freed after use.
constexpr std::size_t kKeptBytes = std::size_t(16) << 20;

std::uint32_t Be32(const std::uint8_t* p) {
  return std::uint32_t(p[0]) << 24 | std::uint32_t(p[1]) << 16 | std::uint32_t(p[2]) << 8 | p[3];
}

bool IsType(const std::uint8_t* type, const char* name) {
  return std::memcmp(type, name, 4) == 0;
}

struct DecompressorFree {
  void operator()(libdeflate_decompressor* d) const { libdeflate_free_decompressor(d); }
};

struct Buffers {
  std::unique_ptr<libdeflate_decompressor, DecompressorFree> decompressor{
      libdeflate_alloc_decompressor()};
  std::vector<std::pair<const std::uint8_t*, std::size_t>> idat;  // the IDAT chunks' data
  std::vector<std::uint8_t> stream;  // the IDAT chunks' data gathered, where there are several
  std::vector<std::uint8_t> rows;    // the inflated rows, each after its filter byte
  std::vector<std::uint8_t> zero;    // the row above the first

  void Trim() {
    for (std::vector<std::uint8_t>* v : {&stream, &rows, &zero}) {
      if (v->capacity() > kKeptBytes)
        std::vector<std::uint8_t>().swap(*v);
    }
  }
};

// a + b - c's nearest of a, b, c, ties in that order (the specification's PaethPredictor), written
// for conditional moves: a row's bytes are a chain, each predicted from the one before.
inline int Paeth(int a, int b, int c) {
  const int pa = std::abs(b - c);  // |p - a|
  const int pb = std::abs(a - c);  // |p - b|
  const int pc = std::abs(a + b - 2 * c);
  const int bc = pb <= pc ? b : c;
  return pa <= std::min(pb, pc) ? a : bc;
}

// Undoes the filters in place: row y is rows[y (stride + 1) + 1 ..], B bytes per pixel (the
// filters' "a" is the byte B back, "b" the byte above, "c" the byte above "a"). The bytes to the
// left are carried in registers, not read back from the row just written (a store-to-load chain
// per byte; 2.5x slower on EuRoC's Paeth-filtered frames). False on an unknown filter type.
template <int B>
bool Unfilter(std::uint8_t* rows, int height, std::size_t stride, const std::uint8_t* zero) {
  for (int y = 0; y < height; ++y) {
    std::uint8_t* const row = rows + static_cast<std::size_t>(y) * (stride + 1);
    std::uint8_t* const x = row + 1;
    const std::uint8_t* const up = y > 0 ? x - (stride + 1) : zero;
    const int type = row[0];
    if (type == 0)  // None
      continue;
    if (type == 2) {  // Up
      for (std::size_t i = 0; i < stride; ++i)
        x[i] = static_cast<std::uint8_t>(x[i] + up[i]);
      continue;
    }
    if (type > 4)
      return false;
    int a[B] = {}, c[B] = {};  // left of the pixel, and above that (0 before the first)
    for (std::size_t i = 0; i + B <= stride; i += B) {
      for (int k = 0; k < B; ++k) {
        const int b = up[i + k];
        const int predicted = type == 1 ? a[k] : type == 3 ? (a[k] + b) >> 1 : Paeth(a[k], b, c[k]);
        a[k] = (x[i + k] + predicted) & 0xff;
        x[i + k] = static_cast<std::uint8_t>(a[k]);
        c[k] = b;
      }
    }
  }
  return true;
}

// The unfiltered rows into the image: RGB to OpenCV's BGR, 16-bit big-endian to the host's order.
void CopyOut(const std::uint8_t* rows, std::size_t stride, int channels, int depth,
             cv::Mat* image) {
  const bool swap = depth == 16 && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__;
  for (int y = 0; y < image->rows; ++y) {
    const std::uint8_t* in = rows + static_cast<std::size_t>(y) * (stride + 1) + 1;
    std::uint8_t* out = image->ptr<std::uint8_t>(y);
    if (channels == 1 && !swap) {
      std::memcpy(out, in, stride);
      continue;
    }
    const int bytes = depth / 8;
    const int pixel = channels * bytes;
    for (int x = 0; x < image->cols; ++x) {
      const std::uint8_t* p = in + static_cast<std::size_t>(x) * pixel;
      std::uint8_t* q = out + static_cast<std::size_t>(x) * pixel;
      for (int c = 0; c < channels; ++c) {
        const int from = (channels == 3 ? 2 - c : c) * bytes;  // B, G, R from R, G, B
        if (bytes == 1) {
          q[c] = p[from];
        } else {
          q[2 * c] = swap ? p[from + 1] : p[from];
          q[2 * c + 1] = swap ? p[from] : p[from + 1];
        }
      }
    }
  }
}

}  // namespace

bool DecodePngDirect(const std::uint8_t* data, std::size_t size, std::uint64_t max_side,
                     std::uint64_t max_bytes, cv::Mat* image) {
  if (data == nullptr || size < sizeof(kSignature) ||
      std::memcmp(data, kSignature, sizeof(kSignature)) != 0)
    return false;
  thread_local Buffers buffers;
  if (buffers.decompressor == nullptr)
    return false;
  // The chunks: IHDR first, consecutive IDATs, IEND; every critical chunk's CRC checked.
  std::uint32_t width = 0, height = 0;
  int depth = 0, channels = 0;
  std::vector<std::pair<const std::uint8_t*, std::size_t>>& idat = buffers.idat;
  idat.clear();
  bool idat_done = false, ended = false;
  std::size_t at = sizeof(kSignature);
  while (!ended) {
    if (size - at < 12)
      return false;
    const std::uint32_t length = Be32(data + at);
    const std::uint8_t* type = data + at + 4;
    if (length > kMaxChunk || size - at - 12 < length)
      return false;
    const std::uint8_t* body = type + 4;
    const bool critical = (type[0] & 0x20) == 0;
    if (critical && libdeflate_crc32(0, type, std::size_t(length) + 4) != Be32(body + length))
      return false;
    const bool first = at == sizeof(kSignature);
    if (first != IsType(type, "IHDR"))
      return false;
    if (IsType(type, "IHDR")) {
      if (length != 13 || body[10] != 0 || body[11] != 0 || body[12] != 0)
        return false;  // compression, filter method 0; interlaced: libpng's
      width = Be32(body);
      height = Be32(body + 4);
      depth = body[8];
      channels = body[9] == 0 ? 1 : body[9] == 2 ? 3 : 0;
      if ((depth != 8 && depth != 16) || channels == 0)
        return false;
    } else if (IsType(type, "IDAT")) {
      if (idat_done)
        return false;  // not consecutive
      idat.emplace_back(body, length);
    } else if (IsType(type, "IEND")) {
      ended = true;
    } else if (critical || IsType(type, "tRNS")) {
      return false;  // PLTE, an unknown critical chunk; transparency adds an alpha channel
    }
    if (!idat.empty() && !IsType(type, "IDAT"))
      idat_done = true;
    at += std::size_t(length) + 12;
  }
  if (idat.empty() || width == 0 || height == 0 || width > max_side || height > max_side)
    return false;
  const std::size_t stride = std::size_t(width) * std::size_t(channels) * std::size_t(depth / 8);
  if (std::uint64_t(stride) * height > max_bytes)
    return false;

  // One zlib stream: where it is split over several IDATs, gathered.
  const std::uint8_t* stream = idat.front().first;
  std::size_t stream_size = idat.front().second;
  if (idat.size() > 1) {
    stream_size = 0;
    for (const auto& chunk : idat)
      stream_size += chunk.second;
    buffers.stream.resize(stream_size);
    std::size_t offset = 0;
    for (const auto& chunk : idat) {
      std::memcpy(buffers.stream.data() + offset, chunk.first, chunk.second);
      offset += chunk.second;
    }
    stream = buffers.stream.data();
  }
  const std::size_t inflated = (stride + 1) * height;
  buffers.rows.resize(inflated);
  std::size_t in_used = 0, out_used = 0;
  const libdeflate_result result =
      libdeflate_zlib_decompress_ex(buffers.decompressor.get(), stream, stream_size,
                                    buffers.rows.data(), inflated, &in_used, &out_used);
  bool ok = result == LIBDEFLATE_SUCCESS && in_used == stream_size && out_used == inflated;
  if (ok) {
    buffers.zero.assign(stride, 0);
    const int bpp = channels * depth / 8;
    std::uint8_t* rows = buffers.rows.data();
    const int h = static_cast<int>(height);
    const std::uint8_t* zero = buffers.zero.data();
    ok = bpp == 1   ? Unfilter<1>(rows, h, stride, zero)
         : bpp == 2 ? Unfilter<2>(rows, h, stride, zero)
         : bpp == 3 ? Unfilter<3>(rows, h, stride, zero)
                    : Unfilter<6>(rows, h, stride, zero);
  }
  if (ok) {
    image->create(static_cast<int>(height), static_cast<int>(width),
                  CV_MAKETYPE(depth == 16 ? CV_16U : CV_8U, channels));
    CopyOut(buffers.rows.data(), stride, channels, depth, image);
  }
  buffers.Trim();
  return ok;
}

}  // namespace ctcal::internal
