// ctcal's PNG / JPEG reader and PNG writer (image_file.h) against OpenCV's imgcodecs (which the
// tests link, ctcal does not): bit-exact round trips, the same pixels as cv::imread / cv::imdecode
// on real photos (shared/data, opencv-doc) and on PNGs of every colour type, bit depth and
// interlacing (written with libpng: image_file_test_util.h), the same files as cv::imwrite; and bad
// data (empty, other formats, every truncation, random corruption, hostile sizes) as one clear
// error, never a crash.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <sys/resource.h>
#include <unistd.h>

#include <array>
#include <csignal>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "ctcal/targets/image_file.h"
#include "image_file_test_util.h"
#include "png_direct.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;
using image_test::AppendChunk;
using image_test::EncodeJpeg;
using image_test::EncodePng;
using image_test::FiltersAndIdats;
using image_test::PngCases;
using image_test::PngSpec;
using image_test::SofSizeOffset;
using image_test::Spec;
using ::testing::HasSubstr;
using ::testing::StartsWith;

const std::string kAprilDir = std::string(CTCAL_SHARED_DATA_DIR) + "/aprilgrid/";
const std::string kEurocDir = std::string(CTCAL_SHARED_DATA_DIR) + "/euroc_cam_april/";
const std::string kOpencvDir = "/usr/share/doc/opencv-doc/examples/data/";
constexpr const char* kFormats = "ctcal reads PNG and JPEG images";

// A fresh folder per test, removed after it.
class ImageFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("ctcal_image_file_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

// Random pixels, with each depth's extremes in the first row (a byte order or sign slip shows).
cv::Mat RandomImage(int rows, int cols, int type, std::uint32_t seed) {
  cv::Mat image(rows, cols, type);
  cv::RNG rng(seed);
  const bool wide = CV_MAT_DEPTH(type) == CV_16U;
  rng.fill(image, cv::RNG::UNIFORM, 0, wide ? 65536 : 256);
  const double top = wide ? 65535 : 255;
  image.row(0).colRange(0, 2).setTo(cv::Scalar::all(0));
  image.row(0).colRange(2, 4).setTo(cv::Scalar::all(top));
  image.at<std::uint8_t>(0, 4 * static_cast<int>(image.elemSize())) = 1;  // 0x0001 little-endian
  return image;
}

std::vector<std::uint8_t> Bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in), {});
}

void WriteBytes(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
}

// Same type, same pixels (and the message says where they differ).
::testing::AssertionResult Identical(const cv::Mat& a, const cv::Mat& b) {
  if (a.type() != b.type() || a.size() != b.size()) {
    return ::testing::AssertionFailure()
           << cv::typeToString(a.type()) << " " << a.cols << "x" << a.rows << " vs "
           << cv::typeToString(b.type()) << " " << b.cols << "x" << b.rows;
  }
  const double diff = a.empty() ? 0.0 : cv::norm(a, b, cv::NORM_INF);
  if (diff != 0.0)
    return ::testing::AssertionFailure() << "pixels differ by up to " << diff;
  return ::testing::AssertionSuccess();
}

// The message of the std::runtime_error `f` throws ("" and a test failure when it throws none).
template <typename F>
std::string ErrorOf(F f) {
  try {
    f();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  ADD_FAILURE() << "no error";
  return "";
}

cv::Mat Decode(const std::vector<std::uint8_t>& bytes, const std::string& what) {
  return DecodeImage(bytes.data(), bytes.size(), what);
}

std::string DecodeError(const std::vector<std::uint8_t>& bytes) {
  return ErrorOf([&] { DecodeImage(bytes.data(), bytes.size(), "the test's image"); });
}

TEST_F(ImageFile, PngRoundTripsBitExact) {
  for (int type : {CV_8UC1, CV_8UC3, CV_8UC4, CV_16UC1, CV_16UC3, CV_16UC4}) {
    const cv::Mat image = RandomImage(48, 65, type, static_cast<std::uint32_t>(type));
    const std::string path = Path("round_trip.png");
    WritePngFile(path, image);
    EXPECT_TRUE(Identical(ReadImageFile(path), image)) << cv::typeToString(type);
    // The file is standard: OpenCV reads the same pixels back.
    EXPECT_TRUE(Identical(cv::imread(path, cv::IMREAD_UNCHANGED), image)) << cv::typeToString(type);
  }
  // A view into a larger image (rows not contiguous) is written as the view.
  const cv::Mat big = RandomImage(40, 50, CV_8UC1, 7);
  const cv::Mat view = big(cv::Rect(3, 5, 31, 17));
  WritePngFile(Path("view.png"), view);
  EXPECT_TRUE(Identical(ReadImageFile(Path("view.png")), view));
}

// The simulator's files are byte for byte what cv::imwrite wrote before.
TEST_F(ImageFile, WritesTheBytesCvImwriteWrites) {
  for (int type : {CV_8UC1, CV_8UC3, CV_16UC1}) {
    const cv::Mat image = RandomImage(30, 41, type, 11);
    WritePngFile(Path("ours.png"), image);
    std::vector<std::uint8_t> theirs;
    ASSERT_TRUE(cv::imencode(".png", image, theirs));
    EXPECT_EQ(Bytes(Path("ours.png")), theirs) << cv::typeToString(type);
  }
}

TEST_F(ImageFile, RealPngsDecodeAsCvImread) {
  const std::vector<std::string> files = {
      kAprilDir + "EuRoC.png",                            // 752x480 8-bit grey
      kEurocDir + "cam0_1403709395937837056.png",         // the same camera, another frame
      kAprilDir + "TUM_VI.png",                           // 1024x1024 16-bit grey
      kAprilDir + "top.png",                              // 16-bit grey
      kAprilDir + "kalibr_sampledata_img000100_0_0.png",  // 1280x800 8-bit grey
      kAprilDir + "iphone.png"};                          // 1920x1080 RGB
  int read = 0;
  for (const std::string& file : files) {
    if (!fs::exists(file))
      continue;
    const cv::Mat ours = ReadImageFile(file);
    EXPECT_TRUE(Identical(ours, cv::imread(file, cv::IMREAD_UNCHANGED))) << file;
    const std::vector<std::uint8_t> bytes = Bytes(file);
    EXPECT_TRUE(Identical(DecodeImage(bytes.data(), bytes.size(), file), ours)) << file;
    ++read;
  }
  if (read == 0)
    GTEST_SKIP() << CTCAL_SHARED_DATA_DIR << " is absent (the shared data folder)";
  // The types the detector is given: TUM-VI's images stay 16-bit, the phone's photo BGR.
  if (fs::exists(kAprilDir + "TUM_VI.png")) {
    EXPECT_EQ(ReadImageFile(kAprilDir + "TUM_VI.png").type(), CV_16UC1);
  }
  if (fs::exists(kAprilDir + "iphone.png")) {
    EXPECT_EQ(ReadImageFile(kAprilDir + "iphone.png").type(), CV_8UC3);
  }
}

TEST_F(ImageFile, EveryPngKindDecodesAsCvImdecode) {
  for (const auto& [name, spec] : PngCases()) {
    const std::vector<std::uint8_t> bytes = EncodePng(spec);
    const cv::Mat ours = DecodeImage(bytes.data(), bytes.size(), name);
    EXPECT_TRUE(Identical(ours, cv::imdecode(bytes, cv::IMREAD_UNCHANGED))) << name;
    WriteBytes(Path("kind.png"), bytes);
    EXPECT_TRUE(Identical(ReadImageFile(Path("kind.png")), ours)) << name;
  }
}

// The direct decoder (png_direct.h) takes the common kinds -- grey and RGB of 8 and 16 bits, each
// row filter, the data over many IDAT chunks -- and gives cv::imdecode's pixels; every other kind,
// and data it finds wrong, it leaves to libpng.
TEST_F(ImageFile, DirectPngDecoderTakesTheCommonKindsExactly) {
  const auto direct = [](const std::vector<std::uint8_t>& bytes, cv::Mat* image) {
    return internal::DecodePngDirect(bytes.data(), bytes.size(), 65536, std::uint64_t(1) << 30,
                                     image);
  };
  std::uint32_t seed = 100;
  for (const int colour : {PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_RGB}) {
    for (const int depth : {8, 16}) {
      const int samples = colour == PNG_COLOR_TYPE_RGB ? 3 : 1;
      for (const int filter : {PNG_FILTER_NONE, PNG_FILTER_SUB, PNG_FILTER_UP, PNG_FILTER_AVG,
                               PNG_FILTER_PAETH, PNG_ALL_FILTERS}) {
        PngSpec s = image_test::Spec(colour, depth, samples, seed++);
        // A ramp under the noise, so that the predictors' sums wrap around and differ.
        for (std::size_t y = 0; y < s.rows.size(); ++y) {
          for (std::size_t i = 0; i < s.rows[y].size(); ++i)
            s.rows[y][i] = static_cast<std::uint8_t>(7 * i + 13 * y + (s.rows[y][i] & 15));
        }
        s.filters = filter;
        s.idat_bytes = 64;
        const std::vector<std::uint8_t> bytes = EncodePng(s);
        const auto [types, idats] = FiltersAndIdats(bytes, s.rows[0].size(), s.height);
        EXPECT_GT(idats, 3);
        if (filter != PNG_ALL_FILTERS) {  // the first row may be filtered otherwise
          const int type = filter == PNG_FILTER_NONE  ? 0
                           : filter == PNG_FILTER_SUB ? 1
                           : filter == PNG_FILTER_UP  ? 2
                           : filter == PNG_FILTER_AVG ? 3
                                                      : 4;
          EXPECT_EQ(types.count(type), 1u) << filter;
        }
        cv::Mat image;
        ASSERT_TRUE(direct(bytes, &image)) << colour << " " << depth << " " << filter;
        EXPECT_TRUE(Identical(image, cv::imdecode(bytes, cv::IMREAD_UNCHANGED)))
            << colour << " " << depth << " " << filter;
      }
    }
  }
  for (const auto& [name, spec] : PngCases()) {
    const bool common =
        (spec.color_type == PNG_COLOR_TYPE_GRAY || spec.color_type == PNG_COLOR_TYPE_RGB) &&
        spec.bit_depth >= 8 && !spec.interlaced && !spec.trans_color;
    cv::Mat image;
    EXPECT_EQ(direct(EncodePng(spec), &image), common) << name;
  }
  // Wrong data: a flipped bit in the image data, a cut before IEND, a CRC.
  std::vector<std::uint8_t> png;
  ASSERT_TRUE(cv::imencode(".png", RandomImage(24, 31, CV_8UC1, 15), png));
  cv::Mat image;
  ASSERT_TRUE(direct(png, &image));
  std::vector<std::uint8_t> bad = png;
  bad[bad.size() - 20] ^= 0x40;
  EXPECT_FALSE(direct(bad, &image));
  EXPECT_FALSE(direct(std::vector<std::uint8_t>(png.begin(), png.end() - 12), &image));
  bad = png;
  bad[19] = 0;
  EXPECT_FALSE(direct(bad, &image));
}

// What the expansions give, stated without OpenCV: its conversions are the documented ones.
TEST_F(ImageFile, PngExpansionsAreTheDocumentedOnes) {
  PngSpec bits = Spec(PNG_COLOR_TYPE_GRAY, 1, 1, 1);
  bits.rows[0][0] = 0x80;  // first pixel 1, second 0
  std::vector<std::uint8_t> bytes = EncodePng(bits);
  cv::Mat m = DecodeImage(bytes.data(), bytes.size(), "1-bit");
  ASSERT_EQ(m.type(), CV_8UC1);
  EXPECT_EQ(m.at<std::uint8_t>(0, 0), 255);  // scaled to 0..255
  EXPECT_EQ(m.at<std::uint8_t>(0, 1), 0);

  PngSpec grey_alpha = Spec(PNG_COLOR_TYPE_GRAY_ALPHA, 8, 2, 2);
  grey_alpha.rows[0][0] = 77;
  grey_alpha.rows[0][1] = 200;
  bytes = EncodePng(grey_alpha);
  m = DecodeImage(bytes.data(), bytes.size(), "grey+alpha");
  ASSERT_EQ(m.type(), CV_8UC4);
  EXPECT_EQ(m.at<cv::Vec4b>(0, 0), cv::Vec4b(77, 77, 77, 200));

  PngSpec palette = Spec(PNG_COLOR_TYPE_PALETTE, 8, 1, 3);
  palette.palette = {{10, 20, 30}, {40, 50, 60}};
  palette.trans = {128};  // entry 0 half transparent, entry 1 opaque
  for (auto& row : palette.rows) {
    for (auto& b : row)
      b &= 1;
  }
  palette.rows[0][0] = 0;
  palette.rows[0][1] = 1;
  bytes = EncodePng(palette);
  m = DecodeImage(bytes.data(), bytes.size(), "palette");
  ASSERT_EQ(m.type(), CV_8UC4);
  EXPECT_EQ(m.at<cv::Vec4b>(0, 0), cv::Vec4b(30, 20, 10, 128));  // BGRA
  EXPECT_EQ(m.at<cv::Vec4b>(0, 1), cv::Vec4b(60, 50, 40, 255));

  PngSpec wide = Spec(PNG_COLOR_TYPE_GRAY, 16, 1, 4);
  wide.rows[0][0] = 0x12;  // big-endian in the file
  wide.rows[0][1] = 0x34;
  bytes = EncodePng(wide);
  m = DecodeImage(bytes.data(), bytes.size(), "16-bit");
  ASSERT_EQ(m.type(), CV_16UC1);
  EXPECT_EQ(m.at<std::uint16_t>(0, 0), 0x1234);
}

// OpenCV's imgcodecs and ctcal link the same libjpeg-turbo (libjpeg.so.62) with the same settings:
// the pixels are equal, not merely close.
TEST_F(ImageFile, JpegsDecodeAsCvImdecode) {
  const cv::Mat grey = RandomImage(67, 93, CV_8UC1, 5);
  cv::Mat colour = RandomImage(67, 93, CV_8UC3, 6);
  cv::GaussianBlur(colour, colour, cv::Size(5, 5), 1.5);  // some structure beside the noise
  struct Case {
    std::string name;
    cv::Mat image;
    std::vector<int> params;
  };
  const std::vector<Case> cases = {
      {"grey", grey, {}},
      {"colour 4:2:0", colour, {cv::IMWRITE_JPEG_QUALITY, 90}},
      {"colour progressive", colour, {cv::IMWRITE_JPEG_PROGRESSIVE, 1}},
      {"colour restart markers", colour, {cv::IMWRITE_JPEG_RST_INTERVAL, 3}},
      {"colour 4:4:4", colour, {cv::IMWRITE_JPEG_QUALITY, 100}}};
  for (const Case& c : cases) {
    std::vector<std::uint8_t> bytes;
    ASSERT_TRUE(cv::imencode(".jpg", c.image, bytes, c.params)) << c.name;
    const cv::Mat ours = DecodeImage(bytes.data(), bytes.size(), c.name);
    EXPECT_EQ(ours.channels(), c.image.channels()) << c.name;
    EXPECT_TRUE(Identical(ours, cv::imdecode(bytes, cv::IMREAD_UNCHANGED))) << c.name;
    WriteBytes(Path("image.jpg"), bytes);
    EXPECT_TRUE(Identical(ReadImageFile(Path("image.jpg")), ours)) << c.name;
  }
  // Real photos: a camera's JPEG (Kalibr's unit-test checkerboard), OpenCV's sample photos.
  for (const std::string& file : {kAprilDir + "aslam_testImageCheckerboard.jpg",
                                  kOpencvDir + "left01.jpg", kOpencvDir + "lena.jpg"}) {
    if (fs::exists(file)) {
      EXPECT_TRUE(Identical(ReadImageFile(file), cv::imread(file, cv::IMREAD_UNCHANGED))) << file;
    }
  }
}

// The format is told by the bytes: a PNG named .jpg is read, a JPEG named .png too.
TEST_F(ImageFile, FormatIsToldByContentNotName) {
  const cv::Mat image = RandomImage(20, 30, CV_8UC1, 8);
  WritePngFile(Path("really_a_png.jpg"), image);
  EXPECT_TRUE(Identical(ReadImageFile(Path("really_a_png.jpg")), image));
  std::vector<std::uint8_t> jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", image, jpeg));
  WriteBytes(Path("really_a_jpeg.png"), jpeg);
  EXPECT_TRUE(Identical(ReadImageFile(Path("really_a_jpeg.png")),
                        cv::imdecode(jpeg, cv::IMREAD_UNCHANGED)));
}

TEST_F(ImageFile, OtherFormatsAndEmptyDataAreOneClearError) {
  const cv::Mat image = RandomImage(20, 30, CV_8UC1, 9);
  for (const auto& [extension, what] : std::vector<std::pair<std::string, std::string>>{
           {".bmp", "a BMP image"}, {".tiff", "a TIFF image"}, {".pgm", "a PNM (PGM/PPM) image"}}) {
    std::vector<std::uint8_t> bytes;
    ASSERT_TRUE(cv::imencode(extension, image, bytes)) << extension;
    const std::string path = Path("image" + extension);
    WriteBytes(path, bytes);
    EXPECT_EQ(ErrorOf([&] { ReadImageFile(path); }),
              "cannot read image " + path + ": " + what + "; " + kFormats);
    EXPECT_EQ(DecodeError(bytes), "the test's image cannot be decoded: " + what + "; " + kFormats);
  }
  WriteBytes(Path("text.png"), {'n', 'o', 't', ' ', 'a', ' ', 'p', 'n', 'g'});
  EXPECT_EQ(ErrorOf([&] { ReadImageFile(Path("text.png")); }),
            "cannot read image " + Path("text.png") +
                ": neither PNG nor JPEG (it starts with 6e 6f 74 20 61 20 70 6e); " + kFormats);
  WriteBytes(Path("empty.png"), {});
  EXPECT_EQ(ErrorOf([&] { ReadImageFile(Path("empty.png")); }),
            "cannot read image " + Path("empty.png") + ": no data (0 bytes); " + kFormats);
  EXPECT_EQ(DecodeError({}),
            std::string("the test's image cannot be decoded: no data (0 bytes); ") + kFormats);
  EXPECT_EQ(ErrorOf([&] { DecodeImage(nullptr, 10, "null"); }),
            std::string("null cannot be decoded: no data (0 bytes); ") + kFormats);
  EXPECT_EQ(ErrorOf([&] { ReadImageFile(Path("missing.png")); }),
            "cannot read image " + Path("missing.png") + ": No such file or directory");
  EXPECT_EQ(ErrorOf([&] { ReadImageFile(dir_.string()); }),
            "cannot read image " + dir_.string() + ": Is a directory");
}

// `image` as OpenCV encodes it: PNG, baseline JPEG, progressive JPEG.
std::array<std::vector<std::uint8_t>, 3> Encoded(const cv::Mat& image) {
  std::array<std::vector<std::uint8_t>, 3> bytes;
  EXPECT_TRUE(cv::imencode(".png", image, bytes[0]));
  EXPECT_TRUE(cv::imencode(".jpg", image, bytes[1]));
  EXPECT_TRUE(cv::imencode(".jpg", image, bytes[2], {cv::IMWRITE_JPEG_PROGRESSIVE, 1}));
  return bytes;
}

// Every prefix of a PNG and of a JPEG (the whole file but its last byte included) is an error
// naming the format, from memory and from a file.
TEST_F(ImageFile, EveryTruncationIsAnError) {
  const auto [png, jpeg, progressive] = Encoded(RandomImage(24, 31, CV_8UC3, 10));
  // A comment segment between the last scan and the end marker: cut there, every pixel is in,
  // and the file is still truncated.
  std::vector<std::uint8_t> commented(jpeg.begin(), jpeg.end() - 2);
  const std::string comment = "after the pixels";
  commented.insert(commented.end(), {0xFF, 0xFE, 0, static_cast<std::uint8_t>(comment.size() + 2)});
  commented.insert(commented.end(), comment.begin(), comment.end());
  commented.insert(commented.end(), {0xFF, 0xD9});
  for (const auto& [name, whole] : std::vector<std::pair<std::string, std::vector<std::uint8_t>>>{
           {"PNG", png}, {"JPEG", jpeg}, {"JPEG", progressive}, {"JPEG", commented}}) {
    const std::size_t magic = name == "PNG" ? 8 : 3;
    for (std::size_t n = 0; n < whole.size(); ++n) {
      const std::vector<std::uint8_t> part(whole.begin(), whole.begin() + n);
      const std::string error = DecodeError(part);
      if (n >= magic) {
        EXPECT_THAT(error, HasSubstr("cannot be decoded: corrupt or truncated " + name + " ("))
            << n << " of " << whole.size() << " bytes";
        EXPECT_THAT(error, HasSubstr(kFormats));
      } else {
        EXPECT_THAT(error, HasSubstr(kFormats)) << n;
      }
      if (n % 97 == 0 || n + 1 == whole.size()) {  // the file reader, on a sample of lengths
        WriteBytes(Path("cut"), part);
        EXPECT_THAT(ErrorOf([&] { ReadImageFile(Path("cut")); }),
                    StartsWith("cannot read image " + Path("cut") + ": "))
            << n;
      }
    }
    EXPECT_FALSE(DecodeImage(whole.data(), whole.size(), name).empty());
  }
}

TEST_F(ImageFile, CorruptPngIsAnErrorNamingIt) {
  const cv::Mat image = RandomImage(24, 31, CV_8UC1, 12);
  std::vector<std::uint8_t> png;
  ASSERT_TRUE(cv::imencode(".png", image, png));
  std::vector<std::uint8_t> bad = png;
  bad[bad.size() - 20] ^= 0x40;  // inside the image data (zlib's checksum sees it first)
  EXPECT_THAT(DecodeError(bad), HasSubstr("corrupt or truncated PNG (IDAT: incorrect data check)"));
  bad = png;
  bad[19] = 0;  // IHDR's width set to 0, its CRC no longer matching
  EXPECT_THAT(DecodeError(bad), HasSubstr("corrupt or truncated PNG (IHDR: CRC error)"));
}

// Random byte changes: each decoding either gives an image or the one clear error; none crashes
// (the sanitizer build checks the memory too).
TEST_F(ImageFile, RandomCorruptionIsAnErrorOrAnImageNeverACrash) {
  const auto [png, jpeg, progressive] = Encoded(RandomImage(32, 40, CV_8UC3, 13));
  std::mt19937 rng(14);
  int errors = 0, images = 0;
  for (const std::vector<std::uint8_t>* whole : {&png, &jpeg, &progressive}) {
    for (int trial = 0; trial < 1500; ++trial) {
      std::vector<std::uint8_t> bytes = *whole;
      const std::size_t size_at = SofSizeOffset(bytes);
      const int changes = 1 + static_cast<int>(rng() % 4);
      for (int k = 0; k < changes; ++k) {
        // Past the magic bytes, so that the decoders run; not a JPEG's size (a huge progressive
        // one is slow to refuse: HostileSizesAreRefused has those).
        const std::size_t at = 3 + rng() % (bytes.size() - 3);
        if (at < size_at || at >= size_at + 4)
          bytes[at] = static_cast<std::uint8_t>(rng());
      }
      try {
        const cv::Mat m = DecodeImage(bytes.data(), bytes.size(), "mutant");
        EXPECT_FALSE(m.empty());
        ++images;
      } catch (const std::runtime_error& e) {
        EXPECT_THAT(e.what(), StartsWith("mutant cannot be decoded: "));
        ++errors;
      }
    }
  }
  // Most changes break a PNG (CRCs); JPEG has no checksum, so many decode to other pixels.
  EXPECT_GT(errors, 1500);
  EXPECT_GT(images, 0);
}

// A header claiming a huge image is refused before anything is allocated for it.
TEST_F(ImageFile, HostileSizesAreRefused) {
  for (const auto& [width, height] : std::vector<std::pair<std::uint32_t, std::uint32_t>>{
           {70000, 1}, {1, 70000}, {60000, 60000}}) {
    std::vector<std::uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    std::vector<std::uint8_t> ihdr;
    for (std::uint32_t v : {width, height}) {
      for (int shift = 24; shift >= 0; shift -= 8)
        ihdr.push_back(static_cast<std::uint8_t>(v >> shift));
    }
    ihdr.insert(ihdr.end(), {8, 0, 0, 0, 0});  // 8-bit grey, not interlaced
    AppendChunk(&png, "IHDR", ihdr);
    AppendChunk(&png, "IDAT", {});
    EXPECT_THAT(DecodeError(png),
                HasSubstr("a PNG of " + std::to_string(width) + " x " + std::to_string(height) +
                          " pixels (ctcal reads at most 65536 a side and 1 GiB decoded)"));
  }
  // A progressive colour JPEG whose frame header claims 65000 x 65000 pixels.
  std::vector<std::uint8_t> jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", RandomImage(16, 16, CV_8UC3, 15), jpeg,
                           {cv::IMWRITE_JPEG_PROGRESSIVE, 1}));
  const std::size_t at = SofSizeOffset(jpeg);
  ASSERT_LT(at, jpeg.size());
  for (std::size_t k = 0; k < 4; k += 2) {
    jpeg[at + k] = 65000 >> 8;
    jpeg[at + k + 1] = 65000 & 0xFF;
  }
  EXPECT_THAT(DecodeError(jpeg), HasSubstr("a JPEG of 65000 x 65000 pixels (ctcal reads at most"));
}

TEST_F(ImageFile, CmykJpegIsRefusedByName) {
  EXPECT_THAT(DecodeError(EncodeJpeg(4, JCS_CMYK)),
              HasSubstr("a JPEG of 4 colour components (CMYK or YCCK)"));
  EXPECT_EQ(Decode(EncodeJpeg(1, JCS_GRAYSCALE), "grey").type(), CV_8UC1);
}

// A valid progressive JPEG of 694 scans (each AC coefficient alone, one bit at a time): refused
// after 500 (each scan is a pass over the whole image: a crafted file makes thousands).
TEST_F(ImageFile, JpegOfTooManyScansIsRefused) {
  std::vector<jpeg_scan_info> scans;
  const auto add = [&](int ss, int se, int ah, int al) {
    jpeg_scan_info scan{};
    scan.comps_in_scan = 1;
    scan.component_index[0] = 0;
    scan.Ss = ss;
    scan.Se = se;
    scan.Ah = ah;
    scan.Al = al;
    scans.push_back(scan);
  };
  add(0, 0, 0, 0);
  for (int k = 1; k < 64; ++k) {
    add(k, k, 0, 10);
    for (int al = 9; al >= 0; --al)
      add(k, k, al + 1, al);
  }
  ASSERT_EQ(scans.size(), 694u);
  EXPECT_THAT(DecodeError(EncodeJpeg(1, JCS_GRAYSCALE, scans)),
              HasSubstr("corrupt or truncated JPEG (more than 500 progressive scans)"));
  scans.resize(400);  // still a valid script (coefficients 37-63 never sent): read
  EXPECT_EQ(Decode(EncodeJpeg(1, JCS_GRAYSCALE, scans), "400 scans").type(), CV_8UC1);
}

TEST_F(ImageFile, WriteErrorsNameTheFileAndLeaveNothing) {
  EXPECT_EQ(ErrorOf([&] { WritePngFile(Path("no_folder/a.png"), cv::Mat(4, 4, CV_8UC1)); }),
            "cannot write " + Path("no_folder/a.png") + ": No such file or directory");
  EXPECT_THAT(ErrorOf([&] { WritePngFile(Path("float.png"), cv::Mat(4, 4, CV_32FC1)); }),
              StartsWith("cannot write " + Path("float.png") +
                         ": a PNG holds a non-empty 8- or 16-bit image of 1, 3 or 4 channels"));
  EXPECT_THAT(ErrorOf([&] { WritePngFile(Path("two.png"), cv::Mat(4, 4, CV_8UC2)); }),
              HasSubstr("1, 3 or 4 channels"));
  EXPECT_THAT(ErrorOf([&] { WritePngFile(Path("empty.png"), cv::Mat()); }), HasSubstr("non-empty"));
  EXPECT_FALSE(fs::exists(Path("float.png")));
  // A write that fails half-way (the file size limit, as a full disk would): the error says why
  // and the partial file is removed.
  rlimit old_limit{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old_limit), 0);
  rlimit small = old_limit;
  small.rlim_cur = 1000;                                   // the image's PNG is ~4 kB
  const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);  // EFBIG instead of the signal
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
  const std::string error =
      ErrorOf([&] { WritePngFile(Path("big.png"), RandomImage(64, 64, CV_8UC1, 1)); });
  setrlimit(RLIMIT_FSIZE, &old_limit);
  std::signal(SIGXFSZ, old_handler);
  EXPECT_EQ(error, "cannot write " + Path("big.png") + ": File too large");
  EXPECT_FALSE(fs::exists(Path("big.png")));
}

}  // namespace
}  // namespace ctcal
