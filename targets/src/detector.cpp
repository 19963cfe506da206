#include "ctcal/targets/detector.h"

#include <opencv2/imgproc.hpp>

#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "ctcal/targets/board_tracking.h"
#include "ctcal/targets/image_file.h"
#include "detector_internal.h"

namespace ctcal {

using namespace internal;  // NOLINT(build/namespaces): detector_internal.h's passes

const char* ToString(RejectReason reason) {
  switch (reason) {
    case RejectReason::kNearBorder:
      return "near the image border";
    case RejectReason::kDuplicateId:
      return "duplicate id";
    case RejectReason::kUnknownId:
      return "id not on this board";
    case RejectReason::kRefinementJump:
      return "sub-pixel refinement jumped";
    case RejectReason::kBadBorder:
      return "black border not as printed (wrong blackTagBorder?)";
    case RejectReason::kTooSmall:
      return "too small to refine";
    case RejectReason::kOffEdges:
      return "a refined corner off the tag's edges";
    case RejectReason::kNotThisBoard:
      return "corners off this board's grid (another board size in view, or the wrong file?)";
    case RejectReason::kTooFewTags:
      return "too few tags in the view";
  }
  return "?";
}

cv::Mat ToGray8(const cv::Mat& image) {
  if (image.empty())
    throw std::invalid_argument("empty image");
  cv::Mat gray;
  switch (image.channels()) {
    case 1:
      gray = image;
      break;
    case 3:
      cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
      break;
    case 4:
      cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
      break;
    default:
      throw std::invalid_argument("unsupported image with " + std::to_string(image.channels()) +
                                  " channels");
  }
  if (gray.depth() == CV_8U)
    return gray;
  if (gray.depth() != CV_16U)
    throw std::invalid_argument("unsupported image depth (expected 8- or 16-bit)");
  double lo = 0.0, hi = 0.0;
  cv::minMaxLoc(gray, &lo, &hi);
  cv::Mat out;
  const double scale = hi > lo ? 255.0 / (hi - lo) : 1.0;
  gray.convertTo(out, CV_8U, scale, -lo * scale);
  return out;
}

// Immerkaer's estimate (Fast noise variance estimation, CVIU 1996), made robust to edges by a
// median: the mask [1 -2 1; -2 4 -2; 1 -2 1] cancels every locally linear intensity, leaving
// noise of variance 36 sigma^2; the median of its magnitude over the image is 0.6745 * 6 sigma.
// The mask is applied at every other pixel of every other row (90 000 samples at 752x480): 0.52
// -> 0.14 ms per image, a tenth of a tracked frame's detection. The median is a whole number
// (of 0.247 grey levels of sigma), the same as the whole image's on 74 of 76 rendered and real
// views; on the other two, whose median lies at a step, one step off, the step by which the whole
// image's estimate moves between frames of one rendered sequence anyway.
double EstimateNoiseSigma(const cv::Mat& gray) {
  CV_Assert(gray.type() == CV_8UC1);
  if (gray.rows < 3 || gray.cols < 3)
    return 0.0;
  std::vector<int64_t> histogram(16 * 255 + 1, 0);
  int64_t samples = 0;
  for (int v = 1; v + 1 < gray.rows; v += 2) {
    const uint8_t* up = gray.ptr<uint8_t>(v - 1);
    const uint8_t* row = gray.ptr<uint8_t>(v);
    const uint8_t* down = gray.ptr<uint8_t>(v + 1);
    for (int u = 1; u + 1 < gray.cols; u += 2) {
      const int response = up[u - 1] - 2 * up[u] + up[u + 1] - 2 * row[u - 1] + 4 * row[u] -
                           2 * row[u + 1] + down[u - 1] - 2 * down[u] + down[u + 1];
      ++histogram[static_cast<size_t>(std::abs(response))];
      ++samples;
    }
  }
  const int64_t half = samples / 2;
  int64_t count = 0;
  size_t median = 0;
  while (median + 1 < histogram.size() && count + histogram[median] <= half)
    count += histogram[median++];
  return 1.4826 * static_cast<double>(median) / 6.0;
}

// ---------------------------------------------------------------------------------------------
// libapriltag detectors: not thread-safe, so a small pool hands one to each concurrent call.

struct Detector::Pool {
  // The contexts' shared family and the detector that owns its quick-decode table (TagContext):
  // built by the first context, freed after every context.
  internal::TagFamilyPtr family;
  apriltag_detector_t* owner = nullptr;
  std::mutex mutex;
  std::vector<std::unique_ptr<TagContext>> free;
  ~Pool() {
    free.clear();
    if (owner != nullptr)
      apriltag_detector_destroy(owner);  // frees the family's decode table
  }
};

Detector::Detector(const Board& board, const DetectorOptions& options)
    : board_(board), options_(options), pool_(std::make_unique<Pool>()) {}

Detector::~Detector() = default;

std::unique_ptr<Detector::TagContext> Detector::AcquireTagContext() const {
  float decimate = options_.quad_decimate;
  if (decimate <= 0.0f)
    decimate = board_.config().black_tag_border >= 2 ? 2.0f : 1.0f;
  {
    std::lock_guard<std::mutex> lock(pool_->mutex);
    if (!pool_->free.empty()) {
      std::unique_ptr<TagContext> context = std::move(pool_->free.back());
      pool_->free.pop_back();
      return context;
    }
    if (pool_->family == nullptr) {
      // The decode table, once (under the lock: a second caller waits for it instead of
      // building its own).
      internal::TagFamilyPtr family = internal::CreateTag36h11(board_.config().black_tag_border);
      pool_->owner = NewApriltagDetector(family.get(), decimate);
      pool_->family = std::move(family);
    }
  }
  auto context = std::make_unique<TagContext>();
  // The family's table exists: adding the family to another detector only lists it.
  context->detector = NewApriltagDetector(pool_->family.get(), decimate);
  return context;
}

void Detector::ReleaseTagContext(std::unique_ptr<TagContext> context) const {
  std::lock_guard<std::mutex> lock(pool_->mutex);
  pool_->free.push_back(std::move(context));
}

bool Detector::PrepareGray(const cv::Mat& image, cv::Mat* gray, double* noise_sigma,
                           DetectionResult* result) const {
  try {
    *gray = ToGray8(image);
  } catch (const std::exception& e) {
    result->error = e.what();
    return false;
  }
  if (!gray->isContinuous())
    *gray = gray->clone();
  // No board fits in fewer pixels (and libapriltag's decimation needs a few to work on).
  if (gray->cols < kMinImageSide || gray->rows < kMinImageSide)
    return false;
  // The 8-bit quantisation alone is uniform noise of 1/sqrt(12) grey levels.
  *noise_sigma = options_.refine ? std::max(EstimateNoiseSigma(*gray), 1.0 / std::sqrt(12.0)) : 0.0;
  return true;
}

void Detector::FinishView(const cv::Mat& gray, double noise_sigma, DetectionResult* result) const {
  if (!options_.refine || !result->board_found)
    return;
  if (board_.type() == TargetType::kAprilGrid)
    RefineTagCorners(gray, noise_sigma, result);
  if (options_.rectify)
    RefineRectified(gray, noise_sigma, result);
  AddModelError(result);
}

DetectionResult Detector::Detect(const cv::Mat& image) const {
  DetectionResult result;
  cv::Mat gray;
  double noise_sigma = 0.0;
  if (!PrepareGray(image, &gray, &noise_sigma, &result))
    return result;
  switch (board_.type()) {
    case TargetType::kAprilGrid:
      result = DetectAprilGrid(gray, noise_sigma);
      break;
    case TargetType::kCheckerboard:
      result = DetectCheckerboard(gray, noise_sigma);
      break;
    case TargetType::kCharuco:
      result = DetectCharuco(gray, noise_sigma);
      break;
  }
  FinishView(gray, noise_sigma, &result);
  return result;
}

namespace internal {

// The final estimate of a corner refined with a capture window: refined again from there with the
// smaller window `half_window` (the lens' outward pull grows with the window's area, the noise
// falls only with its width; docs/targets.md). A corner the final window moves by more than 0.3
// px keeps the capture estimate (on TUM-VI's blurred fisheye rim the two differ by up to that).
void RefineFinal(const cv::Mat& gray, double noise_sigma, int half_window, DetectedCorner* corner) {
  constexpr double kMaxMovePx = 0.3;
  Eigen::Vector2d uv = corner->uv;
  double sigma = 0.0;
  if (RefineCorner(gray, half_window, &uv, &sigma, noise_sigma) &&
      (uv - corner->uv).norm() <= kMaxMovePx) {
    corner->uv = uv;
    corner->sigma = sigma;
  }
}

}  // namespace internal

// Every accepted tag corner refined once more from its estimate with the final window
// (DetectorOptions::tag_window_borders, smaller than the capture window): the lens' outward pull
// grows with the window's area while the noise only falls with its width (docs/targets.md). The
// detection's decisions (completion, code and edge checks, the grid scatter) all rest on the
// capture window's corners, as before: on TUM-VI's blurred fisheye rim the final window's corners
// differ by up to 0.3 px, which the grid completion's line extrapolation amplifies 7-fold. A
// corner the final window moves by more than that keeps its capture estimate.
void Detector::RefineTagCorners(const cv::Mat& gray, double noise_sigma,
                                DetectionResult* result) const {
  const int border = board_.config().black_tag_border;
  const int cells = 6 + 2 * border;
  std::vector<DetectedCorner>& corners = result->corners;  // sorted by id
  const auto find = [&](int id) -> DetectedCorner* {
    const auto it = std::lower_bound(corners.begin(), corners.end(), id,
                                     [](const DetectedCorner& c, int key) { return c.id < key; });
    return it != corners.end() && it->id == id ? &*it : nullptr;
  };
  for (int tag = 0; tag < board_.NumTags(); ++tag) {
    const std::array<int, 4> ids = board_.TagCornerIds(tag);
    std::array<DetectedCorner*, 4> c{};
    bool whole = true;
    for (size_t k = 0; k < 4; ++k)
      whole &= (c[k] = find(ids[k])) != nullptr;
    if (!whole)
      continue;
    double edge = std::numeric_limits<double>::infinity();
    for (size_t k = 0; k < 4; ++k)
      edge = std::min(edge, (c[k]->uv - c[(k + 1) % 4]->uv).norm());
    const double bit_px = edge / cells;
    const int fine = TagCornerHalfWindow(border, bit_px, options_.tag_window_borders);
    if (fine == TagCornerHalfWindow(border, bit_px, kCaptureWindowBorders))
      continue;
    for (DetectedCorner* corner : c)
      RefineFinal(gray, noise_sigma, fine, corner);
  }
}

// The refinement's sigma propagates image noise only. The corners of a view also carry errors
// that no noise term sees: the refinement's model of an X-junction against the real blurred one,
// the print, the lens' point-spread. Their size shows in how far the corners scatter about a
// smooth grid (EstimateGridScatter); what exceeds the noise is this view's model error, added in
// quadrature to every corner's noise sigma.
void Detector::AddModelError(DetectionResult* result) const {
  const GridScatter scatter = EstimateGridScatter(board_, result->corners);
  double noise2 = 0.0;
  for (const DetectedCorner& c : result->corners)
    noise2 += c.sigma * c.sigma / static_cast<double>(result->corners.size());
  result->grid_scatter_px =
      scatter.windows >= options_.min_scatter_windows ? scatter.sigma_px : 0.0;
  const double model2 = scatter.windows >= options_.min_scatter_windows
                            ? std::max(0.0, scatter.sigma_px * scatter.sigma_px - noise2)
                            : options_.default_model_sigma_px * options_.default_model_sigma_px;
  result->model_sigma_px = std::sqrt(model2);
  for (DetectedCorner& c : result->corners)
    c.sigma = std::max(options_.min_sigma_px, std::sqrt(c.sigma * c.sigma + model2));
  // Corners that scatter by pixels about every row and column are not where this board's file
  // puts them: a board of another size in view (Kalibr's sample grid read with a 6 x 6 file: 29
  // tags, 38 px; with the right 8-column file 2.4 px), whose ids still decode. No observation
  // rather than a wrong one.
  if (result->grid_scatter_px > options_.max_grid_scatter_px) {
    result->rejected.push_back({-1, RejectReason::kNotThisBoard});
    result->corners.clear();
    result->board_found = false;
  }
}

namespace {

// A file read ahead of its chunk's tracker (DetectFiles).
struct ReadSlot {
  static constexpr int kUnread = 0, kReading = 1, kRead = 2;
  std::atomic<int> state{kUnread};
  cv::Mat image;
  std::string error;  // ReadImageFile's message
};

void ReadInto(const std::string& path, cv::Mat* image, std::string* error) {
  try {
    *image = ReadImageFile(path);
  } catch (const std::exception& e) {
    *error = e.what();  // "cannot read image <path>: <why>"
  }
}

}  // namespace

std::vector<DetectionResult> Detector::DetectFiles(
    const std::vector<std::string>& paths,
    const std::function<void(size_t, size_t)>& progress) const {
  std::vector<DetectionResult> results(paths.size());
  // Tracking runs the files in chunks of a fixed length, each from a full detection on one
  // worker: the chunks, and so the results, do not depend on the thread count.
  const size_t chunk =
      options_.track ? static_cast<size_t>(std::max(1, options_.track_chunk_frames)) : 1;
  const size_t chunks = (paths.size() + chunk - 1) / chunk;
  const auto chunk_end = [&](size_t c) { return std::min(paths.size(), (c + 1) * chunk); };
  std::atomic<size_t> next{0};
  std::mutex progress_mutex;
  size_t done = 0;
  // A worker without a chunk left reads the files just ahead of the others' trackers: reading
  // (PNG inflation) is ~40 % of a tracked frame, and the last chunks, each on one worker, are
  // the detection's tail (Kalibr-style 400 images: ~0.1 s on one core of two). At most
  // kReadAhead files per chunk are held; a file's bits do not depend on who reads it.
  constexpr size_t kReadAhead = 4;
  const std::unique_ptr<ReadSlot[]> slots(new ReadSlot[paths.size()]);
  const std::unique_ptr<std::atomic<size_t>[]> position(new std::atomic<size_t>[chunks]);
  for (size_t c = 0; c < chunks; ++c)
    position[c].store(c * chunk);
  const auto take = [&](size_t i, cv::Mat* image, std::string* error) {
    int expected = ReadSlot::kUnread;
    if (slots[i].state.compare_exchange_strong(expected, ReadSlot::kReading)) {
      ReadInto(paths[i], image, error);
      return;
    }
    while (slots[i].state.load(std::memory_order_acquire) != ReadSlot::kRead)
      std::this_thread::yield();  // a helper is reading it: ~1-2 ms
    *image = std::move(slots[i].image);
    *error = std::move(slots[i].error);
  };
  const auto help = [&] {
    for (;;) {
      bool in_flight = false, read = false;
      for (size_t c = 0; c < chunks && !read; ++c) {
        const size_t at = position[c].load(std::memory_order_acquire);
        if (at >= chunk_end(c))
          continue;
        in_flight = true;
        for (size_t j = at + 1; j < std::min(chunk_end(c), at + 1 + kReadAhead) && !read; ++j) {
          int expected = ReadSlot::kUnread;
          if (!slots[j].state.compare_exchange_strong(expected, ReadSlot::kReading))
            continue;
          ReadInto(paths[j], &slots[j].image, &slots[j].error);
          slots[j].state.store(ReadSlot::kRead, std::memory_order_release);
          read = true;
        }
      }
      if (!in_flight)
        return;
      if (!read)  // the trackers hold all they may: wait for one to move on
        std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  };
  auto worker = [&] {
    for (size_t c = next++; c < chunks; c = next++) {
      BoardTracker tracker(*this);
      for (size_t i = c * chunk; i < chunk_end(c); ++i) {
        position[c].store(i, std::memory_order_release);
        cv::Mat image;
        take(i, &image, &results[i].error);
        if (image.empty()) {
          tracker.Reset();
        } else {
          results[i] = tracker.Next(image);
          results[i].image_width = image.cols;
          results[i].image_height = image.rows;
          if (!results[i].error.empty())
            results[i].error = paths[i] + ": " + results[i].error;
        }
        if (progress) {
          std::lock_guard<std::mutex> lock(progress_mutex);
          progress(++done, paths.size());
        }
      }
      position[c].store(chunk_end(c), std::memory_order_release);
    }
    if (options_.track)
      help();
  };
  int threads = options_.threads > 0 ? options_.threads
                                     : static_cast<int>(std::thread::hardware_concurrency());
  threads = std::clamp(threads, 1, std::max<int>(1, static_cast<int>(chunks)));
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t)
    pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool)
    t.join();
  return results;
}

}  // namespace ctcal
