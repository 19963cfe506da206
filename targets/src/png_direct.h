// The common PNGs decoded in one piece with libdeflate (image_file.cpp's fast path): 8- or 16-bit
// grey or RGB without transparency, not interlaced -- what cameras and the calibration recordings
// store. libpng inflates row by row through zlib, whose inflate is ~1.8x slower than libdeflate's
// whole-buffer one (a rendered 752x480 frame: 1.47 against 0.83 ms), and that was a fifth of the
// detection's CPU time.
//
// The decoder never fails on its own: on anything it does not take (another colour type, depth or
// interlacing; transparency; a palette; an unknown critical chunk) and on anything wrong (a CRC of
// a critical chunk, a chunk past the end, a zlib stream that is corrupt, too short, too long or
// not alone in the IDAT chunks, an unknown row filter, no IEND) it returns false, and libpng
// decodes the same bytes and decides: its image, or its error message. What it returns is what
// libpng with image_file.cpp's conversions gives (BGR order, 16-bit samples in the host's order).
#pragma once

#include <opencv2/core.hpp>

#include <cstddef>
#include <cstdint>

namespace ctcal::internal {

// A whole PNG file in `data`: true with `*image` set, or false (libpng's to decode). Images beyond
// `max_side` a side or `max_bytes` decoded are left to libpng too (it refuses them by name).
bool DecodePngDirect(const std::uint8_t* data, std::size_t size, std::uint64_t max_side,
                     std::uint64_t max_bytes, cv::Mat* image);

}  // namespace ctcal::internal
