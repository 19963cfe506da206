#include "ctcal/targets/image_file.h"

// jpeglib.h needs FILE and size_t declared before it.
#include <csetjmp>
#include <cstdio>

#include <jerror.h>
#include <jpeglib.h>
#include <png.h>
#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <system_error>
#include <vector>

#include <sys/stat.h>

#include "png_direct.h"

// libpng and libjpeg report errors by longjmp. A longjmp skips the destructors of everything it
// unwinds, so the rule throughout: a function that calls setjmp holds no object with a destructor
// (everything C++ -- the cv::Mat, the libraries' structs' owners -- lives in its caller, which a
// longjmp never leaves), and the callbacks that longjmp (errors, reads) hold none either. No C++
// exception is thrown through the libraries' C frames.

namespace ctcal {
namespace {

constexpr const char* kFormats = "ctcal reads PNG and JPEG images";
// A guard against a corrupt or hostile header (a few bytes claiming a gigapixel image): larger
// than any camera's image, small enough to allocate.
constexpr std::uint64_t kMaxSide = 65536;
constexpr std::uint64_t kMaxBytes = std::uint64_t(1) << 30;
// Each scan of a progressive JPEG is a pass over all of the image's coefficients, and a scan can
// cost a few bytes: a crafted file makes thousands of passes. Real ones have ~10 scans.
constexpr int kMaxJpegScans = 500;
// The largest PNG file read whole for the direct decoder (png_direct.h): far above any camera's
// frame (a 4K 16-bit RGB image is 50 MB decoded); a larger file streams through libpng, which
// refuses a bad header after its first bytes instead of after reading the whole file.
constexpr std::uint64_t kMaxWholeFile = std::uint64_t(64) << 20;
// Enough bytes of a file's start to tell its format.
constexpr std::size_t kHeadSize = 12;
constexpr bool kLittleEndian = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__;

// Fixed-size text, which the callbacks that longjmp can fill without owning anything.
constexpr std::size_t kMessageSize = 256;
static_assert(kMessageSize >= JMSG_LENGTH_MAX, "libjpeg's messages must fit");

// Where the encoded bytes come from: memory, or a file read as decoding goes. A PNG file is read
// whole into its thread's buffer for the direct decoder (png_direct.h); a fresh buffer of a
// file's size per image cost ~150 page faults per 752x480 image, 2-3 ms on the development
// machine, as much as the decoding itself, so the buffer is kept between images.
struct Source {
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;
  std::size_t offset = 0;
  std::FILE* file = nullptr;
};

// Why decoding stopped: a library's message (corrupt data), or ctcal's own (`unsupported`: a valid
// file ctcal does not read, the message says why).
struct Failure {
  char message[kMessageSize] = {};
  bool unsupported = false;
};

struct Layout {
  int rows = 0;
  int cols = 0;
  int type = 0;
  int passes = 1;  // PNG: interlacing passes
};

struct FileCloser {
  void operator()(std::FILE* file) const { std::fclose(file); }
};

std::string ErrnoText(int error) {
  return std::generic_category().message(error);
}

// False (the reason in `failure`) when the image is beyond the limits above.
bool WithinLimits(std::uint64_t cols, std::uint64_t rows, int type, const char* format,
                  Failure* failure) {
  if (cols > 0 && rows > 0 && cols <= kMaxSide && rows <= kMaxSide &&
      cols * rows * CV_ELEM_SIZE(type) <= kMaxBytes)
    return true;
  std::snprintf(failure->message, sizeof(failure->message),
                "a %s of %llu x %llu pixels (ctcal reads at most %llu a side and 1 GiB decoded)",
                format, static_cast<unsigned long long>(cols),
                static_cast<unsigned long long>(rows), static_cast<unsigned long long>(kMaxSide));
  failure->unsupported = true;
  return false;
}

// ---------------------------------------------------------------------------------------------
// PNG (libpng)

void PngError(png_structp png, png_const_charp message) {
  auto* failure = static_cast<Failure*>(png_get_error_ptr(png));
  std::snprintf(failure->message, sizeof(failure->message), "%s", message);
  png_longjmp(png, 1);
}

// Warnings are about ancillary chunks (a bad colour profile, a text chunk's CRC), which libpng
// drops; the pixels are intact. Not printed.
void PngWarning(png_structp, png_const_charp) {}

void PngRead(png_structp png, png_bytep out, std::size_t length) {
  auto* source = static_cast<Source*>(png_get_io_ptr(png));
  if (source->file != nullptr) {
    if (std::fread(out, 1, length, source->file) != length) {
      png_error(png, std::ferror(source->file) ? std::strerror(errno)
                                               : "the file ends early (truncated)");
    }
    return;
  }
  if (source->size - source->offset < length)
    png_error(png, "the data ends early (truncated)");
  std::memcpy(out, source->data + source->offset, length);
  source->offset += length;
}

// libpng's structs for reading or writing, freed however the work ends.
struct PngStructs {
  png_structp png = nullptr;
  png_infop info = nullptr;
  bool writing;
  PngStructs(bool write, Failure* failure) : writing(write) {
    png = (writing ? png_create_write_struct : png_create_read_struct)(
        PNG_LIBPNG_VER_STRING, failure, PngError, PngWarning);
    if (png != nullptr)
      info = png_create_info_struct(png);
  }
  ~PngStructs() {
    if (writing)
      png_destroy_write_struct(&png, &info);
    else
      png_destroy_read_struct(&png, &info, nullptr);
  }
  PngStructs(const PngStructs&) = delete;
  PngStructs& operator=(const PngStructs&) = delete;
};

// Reads the header and asks for the conversions cv::imread(IMREAD_UNCHANGED) asks for (OpenCV's
// grfmt_png.cpp, in its order), so that the pixels are the same. False on an error.
bool PngReadHeader(png_structp png, png_infop info, Failure* failure, Layout* layout) {
  if (setjmp(png_jmpbuf(png)))
    return false;
  png_read_info(png, info);
  const int color = png_get_color_type(png, info);
  const int depth = png_get_bit_depth(png, info);
  int channels = 1;  // grey, its tRNS (one transparent grey level) ignored as OpenCV does
  if (color == PNG_COLOR_TYPE_RGB || color == PNG_COLOR_TYPE_PALETTE) {
    png_bytep trans = nullptr;
    int num_trans = 0;
    png_color_16p trans_values = nullptr;
    png_get_tRNS(png, info, &trans, &num_trans, &trans_values);
    channels = num_trans > 0 ? 4 : 3;
  } else if (color == PNG_COLOR_TYPE_GRAY_ALPHA || color == PNG_COLOR_TYPE_RGB_ALPHA) {
    channels = 4;
  }
  const int type = CV_MAKETYPE(depth == 16 ? CV_16U : CV_8U, channels);
  if (!WithinLimits(png_get_image_width(png, info), png_get_image_height(png, info), type, "PNG",
                    failure))
    return false;

  if (depth == 16 && kLittleEndian)
    png_set_swap(png);
  if (channels < 4)
    png_set_strip_alpha(png);
  else
    png_set_tRNS_to_alpha(png);
  if (color == PNG_COLOR_TYPE_PALETTE)
    png_set_palette_to_rgb(png);
  if ((color & PNG_COLOR_MASK_COLOR) == 0 && depth < 8)
    png_set_expand_gray_1_2_4_to_8(png);
  if (channels > 1) {
    if (color & PNG_COLOR_MASK_COLOR)
      png_set_bgr(png);
    else
      png_set_gray_to_rgb(png);
  }
  layout->passes = png_set_interlace_handling(png);
  png_read_update_info(png, info);

  layout->rows = static_cast<int>(png_get_image_height(png, info));
  layout->cols = static_cast<int>(png_get_image_width(png, info));
  layout->type = type;
  // What the conversions give must be what the cv::Mat holds (a guard: they always agree).
  if (png_get_channels(png, info) != channels ||
      png_get_rowbytes(png, info) != std::size_t(layout->cols) * CV_ELEM_SIZE(type))
    png_error(png, "unexpected row layout after conversion");
  return true;
}

bool PngReadRows(png_structp png, int passes, cv::Mat* image) {
  if (setjmp(png_jmpbuf(png)))
    return false;
  // What png_read_image does, without its array of row pointers.
  for (int pass = 0; pass < passes; ++pass) {
    for (int y = 0; y < image->rows; ++y)
      png_read_row(png, image->ptr(y), nullptr);
  }
  // The chunks after the image data, to the end: a file cut after its pixels is still truncated
  // (as for cv::imread).
  png_read_end(png, nullptr);
  return true;
}

cv::Mat DecodePng(Source* source, Failure* failure) {
  PngStructs structs(false, failure);
  if (structs.png == nullptr || structs.info == nullptr) {
    std::snprintf(failure->message, sizeof(failure->message), "out of memory");
    return {};
  }
  png_set_read_fn(structs.png, source, PngRead);
  Layout layout;
  if (!PngReadHeader(structs.png, structs.info, failure, &layout))
    return {};
  cv::Mat image(layout.rows, layout.cols, layout.type);
  if (!PngReadRows(structs.png, layout.passes, &image))
    return {};
  return image;
}

// ---------------------------------------------------------------------------------------------
// JPEG (libjpeg-turbo)

struct JpegFailure {
  jpeg_error_mgr manager;  // first: libjpeg hands &manager back as cinfo->err
  std::jmp_buf jump;
  Failure* failure;
};

[[noreturn]] void JpegFail(j_common_ptr cinfo) {
  auto* jpeg_failure = reinterpret_cast<JpegFailure*>(cinfo->err);
  (*cinfo->err->format_message)(cinfo, jpeg_failure->failure->message);
  std::longjmp(jpeg_failure->jump, 1);
}

void JpegErrorExit(j_common_ptr cinfo) {
  JpegFail(cinfo);
}

// libjpeg's warnings. After those of lost image data it would go on and fill the rest of the
// image with grey (cv::imread returns that image): here they fail. The others are harmless and,
// unlike libjpeg's default, not printed.
void JpegEmitMessage(j_common_ptr cinfo, int level) {
  if (level >= 0)
    return;  // trace messages (none at the default trace level)
  switch (cinfo->err->msg_code) {
    case JWRN_EXTRANEOUS_DATA:  // stray bytes before a marker, e.g. in some cameras' frames
    case JWRN_ADOBE_XFORM:
    case JWRN_JFIF_MAJOR:
    case JWRN_BOGUS_ICC:  // a bad colour profile, which ctcal does not use
      return;
    default:
      JpegFail(cinfo);
  }
}

void JpegProgress(j_common_ptr cinfo) {
  const auto* decompress = reinterpret_cast<j_decompress_ptr>(cinfo);
  if (decompress->input_scan_number <= kMaxJpegScans)
    return;
  auto* jpeg_failure = reinterpret_cast<JpegFailure*>(cinfo->err);
  std::snprintf(jpeg_failure->failure->message, sizeof(jpeg_failure->failure->message),
                "more than %d progressive scans", kMaxJpegScans);
  std::longjmp(jpeg_failure->jump, 1);
}

// libjpeg's decompressor and its error and progress hooks, destroyed however decoding ends
// (jpeg_destroy_decompress is safe on a struct that jpeg_create_decompress never finished).
struct JpegDecompressor {
  jpeg_decompress_struct cinfo{};
  JpegFailure failure{};
  jpeg_progress_mgr progress{};
  explicit JpegDecompressor(Failure* why) {
    cinfo.err = jpeg_std_error(&failure.manager);
    failure.manager.error_exit = JpegErrorExit;
    failure.manager.emit_message = JpegEmitMessage;
    failure.failure = why;
    progress.progress_monitor = JpegProgress;
  }
  ~JpegDecompressor() { jpeg_destroy_decompress(&cinfo); }
  JpegDecompressor(const JpegDecompressor&) = delete;
  JpegDecompressor& operator=(const JpegDecompressor&) = delete;
};

// Reads the header and starts decompressing to what cv::imread(IMREAD_UNCHANGED) gives: grey for
// one component, BGR for three (libjpeg-turbo converts straight to BGR, as OpenCV asks it to).
bool JpegStart(JpegDecompressor* d, Source* source, Layout* layout) {
  if (setjmp(d->failure.jump))
    return false;
  jpeg_create_decompress(&d->cinfo);
  d->cinfo.progress = &d->progress;
  // A progressive JPEG holds all its coefficients (~2 bytes a sample, zeroed first): bounded as the
  // decoded image is (beyond it libjpeg fails, having no backing store).
  d->cinfo.mem->max_memory_to_use = static_cast<long>(kMaxBytes);
  if (source->file != nullptr)
    jpeg_stdio_src(&d->cinfo, source->file);
  else
    jpeg_mem_src(&d->cinfo, source->data, static_cast<unsigned long>(source->size));
  jpeg_read_header(&d->cinfo, TRUE);
  Failure* failure = d->failure.failure;
  const int components = d->cinfo.num_components;
  if (components == 1) {
    d->cinfo.out_color_space = JCS_GRAYSCALE;
  } else if (components == 3) {
    d->cinfo.out_color_space = JCS_EXT_BGR;
  } else {
    std::snprintf(failure->message, sizeof(failure->message),
                  "a JPEG of %d colour components%s; ctcal reads grey and colour (3-component) "
                  "JPEGs",
                  components, components == 4 ? " (CMYK or YCCK)" : "");
    failure->unsupported = true;
    return false;
  }
  const int type = CV_8UC(components);
  if (!WithinLimits(d->cinfo.image_width, d->cinfo.image_height, type, "JPEG", failure))
    return false;
  jpeg_start_decompress(&d->cinfo);
  if (d->cinfo.output_components != components || d->cinfo.output_width != d->cinfo.image_width ||
      d->cinfo.output_height != d->cinfo.image_height) {
    std::snprintf(failure->message, sizeof(failure->message), "unexpected output layout");
    return false;
  }
  layout->rows = static_cast<int>(d->cinfo.output_height);
  layout->cols = static_cast<int>(d->cinfo.output_width);
  layout->type = type;
  return true;
}

bool JpegReadRows(JpegDecompressor* d, cv::Mat* image) {
  if (setjmp(d->failure.jump))
    return false;
  while (d->cinfo.output_scanline < d->cinfo.output_height) {
    JSAMPROW row = image->ptr(static_cast<int>(d->cinfo.output_scanline));
    // Neither the file nor the memory source suspends: no row means no progress.
    if (jpeg_read_scanlines(&d->cinfo, &row, 1) != 1) {
      std::snprintf(d->failure.failure->message, sizeof(d->failure.failure->message),
                    "no more rows after row %u", d->cinfo.output_scanline);
      return false;
    }
  }
  // To the end marker: a file cut after its last row is still truncated (as a PNG cut after its
  // pixels). What follows the marker is not read.
  jpeg_finish_decompress(&d->cinfo);
  return true;
}

cv::Mat DecodeJpeg(Source* source, Failure* failure) {
  JpegDecompressor decompressor(failure);
  Layout layout;
  if (!JpegStart(&decompressor, source, &layout))
    return {};
  cv::Mat image(layout.rows, layout.cols, layout.type);
  if (!JpegReadRows(&decompressor, &image))
    return {};
  return image;
}

// ---------------------------------------------------------------------------------------------
// Format by content

bool StartsWith(const std::uint8_t* head, std::size_t n, const char* magic, std::size_t length) {
  return n >= length && std::memcmp(head, magic, length) == 0;
}

bool IsPng(const std::uint8_t* head, std::size_t n) {
  return StartsWith(head, n, "\x89PNG\r\n\x1a\n", 8);
}

bool IsJpeg(const std::uint8_t* head, std::size_t n) {
  return StartsWith(head, n, "\xff\xd8\xff", 3);
}

// Why data that is neither PNG nor JPEG is not read: the common image formats by their magic
// bytes, anything else by its first bytes.
std::string OtherFormat(const std::uint8_t* head, std::size_t n) {
  std::string what;
  if (n == 0) {
    what = "no data (0 bytes)";
  } else if (StartsWith(head, n, "BM", 2)) {
    what = "a BMP image";
  } else if (StartsWith(head, n, "II*\0", 4) || StartsWith(head, n, "MM\0*", 4)) {
    what = "a TIFF image";
  } else if (StartsWith(head, n, "GIF8", 4)) {
    what = "a GIF image";
  } else if (StartsWith(head, n, "RIFF", 4) && n >= 12 && std::memcmp(head + 8, "WEBP", 4) == 0) {
    what = "a WebP image";
  } else if (n >= 2 && head[0] == 'P' && head[1] >= '1' && head[1] <= '7') {
    what = "a PNM (PGM/PPM) image";
  } else if (StartsWith(head, n, "\0\0\0\x0cjP  ", 8) ||
             StartsWith(head, n, "\xff\x4f\xff\x51", 4)) {
    what = "a JPEG 2000 image";
  } else {
    what = "neither PNG nor JPEG (it starts with";
    for (std::size_t i = 0; i < std::min<std::size_t>(n, 8); ++i) {
      char hex[4];
      std::snprintf(hex, sizeof(hex), " %02x", head[i]);
      what += hex;
    }
    what += ")";
  }
  return what + "; " + kFormats;
}

// The image, or an empty one with *why set. `head` holds the first `n` bytes of `source`, which
// still starts at its beginning.
cv::Mat Decode(Source* source, const std::uint8_t* head, std::size_t n, std::string* why) {
  const bool png = IsPng(head, n);
  if (!png && !IsJpeg(head, n)) {
    *why = OtherFormat(head, n);
    return {};
  }
  cv::Mat image;
  if (png && source->file == nullptr &&
      internal::DecodePngDirect(source->data, source->size, kMaxSide, kMaxBytes, &image))
    return image;
  Failure failure;
  image = png ? DecodePng(source, &failure) : DecodeJpeg(source, &failure);
  if (image.empty()) {
    if (failure.unsupported)
      *why = failure.message;
    else
      *why = std::string("corrupt or truncated ") + (png ? "PNG (" : "JPEG (") + failure.message +
             "); " + kFormats;
  }
  return image;
}

// ---------------------------------------------------------------------------------------------
// PNG writing

void PngWrite(png_structp png, png_bytep data, std::size_t length) {
  if (std::fwrite(data, 1, length, static_cast<std::FILE*>(png_get_io_ptr(png))) != length)
    png_error(png, std::strerror(errno));
}

void PngFlush(png_structp) {}  // fclose flushes

// cv::imwrite's defaults and calls (OpenCV's grfmt_png.cpp), so the files stay byte for byte the
// same; level 1 with the "sub" filter is also the fast choice for the simulator's many images.
bool PngWriteImage(png_structp png, png_infop info, const cv::Mat& image) {
  if (setjmp(png_jmpbuf(png)))
    return false;
  const int channels = image.channels();
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
  png_set_compression_level(png, Z_BEST_SPEED);
  png_set_compression_strategy(png, Z_RLE);
  png_set_IHDR(png, info, static_cast<png_uint_32>(image.cols),
               static_cast<png_uint_32>(image.rows), image.depth() == CV_16U ? 16 : 8,
               channels == 1   ? PNG_COLOR_TYPE_GRAY
               : channels == 3 ? PNG_COLOR_TYPE_RGB
                               : PNG_COLOR_TYPE_RGB_ALPHA,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  png_set_bgr(png);
  if (kLittleEndian)
    png_set_swap(png);
  for (int y = 0; y < image.rows; ++y)
    png_write_row(png, image.ptr(y));
  png_write_end(png, info);
  return true;
}

// The whole of a regular file of at most `limit` bytes into `bytes` (its thread's buffer, kept),
// from the file's start; false (the file's position unknown) where it is not one or a read fails.
bool ReadWhole(std::FILE* file, std::size_t limit, std::vector<std::uint8_t>* bytes) {
  struct stat st {};
  if (fstat(fileno(file), &st) != 0 || !S_ISREG(st.st_mode) || st.st_size <= 0 ||
      static_cast<std::uint64_t>(st.st_size) > limit || std::fseek(file, 0, SEEK_SET) != 0)
    return false;
  bytes->resize(static_cast<std::size_t>(st.st_size));
  return std::fread(bytes->data(), 1, bytes->size(), file) == bytes->size();
}

}  // namespace

cv::Mat ReadImageFile(const std::string& path) {
  const auto fail = [&](const std::string& why) {
    return std::runtime_error("cannot read image " + path + ": " + why);
  };
  const std::unique_ptr<std::FILE, FileCloser> file(std::fopen(path.c_str(), "rb"));
  if (!file)
    throw fail(ErrnoText(errno));
  std::uint8_t head[kHeadSize];
  const std::size_t n = std::fread(head, 1, sizeof(head), file.get());
  if (std::ferror(file.get()))
    throw fail(ErrnoText(errno));  // e.g. a folder
  Source source;
  source.file = file.get();
  // A PNG of a regular file from memory (its direct decoder's way); a file that grew or shrank
  // meanwhile, a larger one, or any other, read as decoding goes from its start.
  thread_local std::vector<std::uint8_t> bytes;
  if (IsPng(head, n) && ReadWhole(file.get(), kMaxWholeFile, &bytes)) {
    source.file = nullptr;
    source.data = bytes.data();
    source.size = bytes.size();
  } else if (std::fseek(file.get(), 0, SEEK_SET) != 0) {
    throw fail(ErrnoText(errno));
  }
  std::string why;
  cv::Mat image = Decode(&source, head, n, &why);
  if (bytes.capacity() > (std::size_t(16) << 20))
    std::vector<std::uint8_t>().swap(bytes);
  if (image.empty())
    throw fail(why);
  return image;
}

cv::Mat DecodeImage(const std::uint8_t* data, std::size_t size, const std::string& what) {
  Source source;
  source.data = data;
  source.size = data != nullptr ? size : 0;
  std::string why;
  cv::Mat image = Decode(&source, data, std::min(source.size, kHeadSize), &why);
  if (image.empty())
    throw std::runtime_error(what + " cannot be decoded: " + why);
  return image;
}

void WritePngFile(const std::string& path, const cv::Mat& image) {
  const auto fail = [&](const std::string& why) {
    return std::runtime_error("cannot write " + path + ": " + why);
  };
  const int channels = image.channels();
  if (image.empty() || (image.depth() != CV_8U && image.depth() != CV_16U) ||
      (channels != 1 && channels != 3 && channels != 4)) {
    throw fail("a PNG holds a non-empty 8- or 16-bit image of 1, 3 or 4 channels, not " +
               cv::typeToString(image.type()) + " of " + std::to_string(image.cols) + " x " +
               std::to_string(image.rows));
  }
  if (static_cast<std::uint64_t>(image.cols) > kMaxSide ||
      static_cast<std::uint64_t>(image.rows) > kMaxSide)
    throw fail("larger than 65536 pixels a side");
  std::unique_ptr<std::FILE, FileCloser> file(std::fopen(path.c_str(), "wb"));
  if (!file)
    throw fail(ErrnoText(errno));
  std::string why;
  {
    Failure failure;
    PngStructs structs(true, &failure);
    if (structs.png == nullptr || structs.info == nullptr) {
      why = "out of memory";
    } else {
      png_set_write_fn(structs.png, file.get(), PngWrite, PngFlush);
      if (!PngWriteImage(structs.png, structs.info, image))
        why = failure.message;
    }
  }
  // fclose writes what stdio still buffers: its failure (a full disk) is the write's.
  if (std::fclose(file.release()) != 0 && why.empty())
    why = ErrnoText(errno);
  if (!why.empty()) {
    std::error_code ec;
    if (std::filesystem::is_regular_file(path, ec))  // never a device given as the path
      std::filesystem::remove(path, ec);
    throw fail(why);
  }
}

}  // namespace ctcal
