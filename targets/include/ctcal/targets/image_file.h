// Image files: PNG and JPEG read (from a file or from memory, e.g. a ROS CompressedImage) and PNG
// written, by libpng and libjpeg-turbo directly. OpenCV's imgcodecs module is not linked: it pulls
// GDAL, gdcm, poppler and ~90 more shared libraries whose loading was most of every start of the
// ctcal program, for formats a calibration dataset never holds (SPEC section 6: PNG; ROS
// CompressedImage: JPEG or PNG).
//
// The images are what cv::imread(path, cv::IMREAD_UNCHANGED) gives (same libraries, same
// conversions; bit-exact, tested in targets_image_file):
// - depth: CV_8U, or CV_16U for 16-bit PNGs (TUM-VI's images stay 16-bit);
// - channels: grey PNG/JPEG -> 1 (a grey PNG's tRNS transparency is dropped), colour -> 3 (BGR),
//   PNG with alpha -> 4 (BGRA); grey + alpha -> 4 (the grey copied to B, G and R); palette -> 3
//   (BGR), or 4 (BGRA) when the palette has transparency; 1/2/4-bit grey -> 8-bit scaled to
//   0..255 (1-bit 1 -> 255); no gamma or sBIT correction; interlaced PNGs are de-interlaced;
// - JPEG EXIF orientation is not applied (nor is it by IMREAD_UNCHANGED).
// Not read: CMYK/YCCK JPEGs (4 components, never a camera's), 12-bit JPEGs, any other format.
// The format is told by the file's first bytes, never by its name.
//
// Failures throw std::runtime_error naming the file (or what the caller names a buffer) and why;
// corrupt or truncated data is such a failure, never a crash nor a partly grey image (libjpeg's
// warnings of lost data, e.g. "Premature end of JPEG file", are failures here; its harmless ones,
// e.g. extraneous bytes before a marker, are not). Limits: at most 65536 pixels a side and 1 GiB
// decoded. Thread-safe: calls share no state.
#pragma once

#include <opencv2/core.hpp>

#include <cstddef>
#include <cstdint>
#include <string>

namespace ctcal {

// Throws "cannot read image <path>: <why>" (a missing file, another format, corrupt data, ...).
cv::Mat ReadImageFile(const std::string& path);

// The same from memory. `what` names the buffer in the error: "<what> cannot be decoded: <why>".
cv::Mat DecodeImage(const std::uint8_t* data, std::size_t size, const std::string& what);

// Writes a CV_8U or CV_16U image of 1 (grey), 3 (BGR) or 4 (BGRA) channels as PNG, with the
// settings cv::imwrite uses by default (zlib level 1, the "sub" filter, run-length strategy), so
// the files are byte for byte what it wrote. On failure nothing is left at `path` and it throws
// "cannot write <path>: <why>".
void WritePngFile(const std::string& path, const cv::Mat& image);

}  // namespace ctcal
