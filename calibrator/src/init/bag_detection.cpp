#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <filesystem>
#include <memory>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

#include "ctcal/calibrator/init/bag_detection.h"
#include "ctcal/calibrator/spline_calibrator.h"
#include "ctcal/targets/board_tracking.h"
#include "ctcal/targets/detector.h"

namespace ctcal {
namespace {

constexpr const char* kStage = "corner detection";

// One camera's detections, filled by the workers in any order and put in message order at the end.
struct CameraResults {
  CameraDetectionSummary summary;
  std::size_t first_error_index = 0;
  std::map<std::size_t, std::vector<CornerObservation>> corners;  // by message index
  std::size_t done = 0;
};

// A bounded queue between the bag's reader (this thread) and the detection workers. Each camera's
// images go in chunks of DetectorOptions::track_chunk_frames in message order, each tracked by
// one worker from a full detection (BoardTracker): fixed chunks, so that the corners do not depend
// on the thread count. The reader starts filling a chunk only when no other waits, so memory
// holds at most the chunks being detected (whose images are freed as they are) and one more.
class DetectionPipeline {
 public:
  DetectionPipeline(const RigConfig& rig, int threads, bool track, const InitLog& log) : log_(log) {
    const int workers = threads > 0 ? threads : std::max(1u, std::thread::hardware_concurrency());
    DetectorOptions options;
    options.threads = workers;
    options.track = track;
    detector_ = std::make_unique<Detector>(Board(rig.target), options);
    // Untracked, single images: a few per worker queued, as many as keep every worker busy.
    chunk_ = track ? static_cast<std::size_t>(std::max(1, options.track_chunk_frames)) : 1;
    capacity_ = track ? 1 : 2 * static_cast<std::size_t>(workers);
    for (const SensorConfig& s : rig.sensors) {
      if (s.type == SensorType::kCamera)
        cameras_[s.name].summary.camera = s.name;
    }
    for (int i = 0; i < workers; ++i)
      workers_.emplace_back([this] { Work(); });
  }
  ~DetectionPipeline() { Join(); }

  // Called by LoadBagDataset for every image; throws the first worker's fatal error, so that the
  // read stops at once.
  void Push(BagImage&& image) {
    std::vector<BagImage>& pending = pending_[image.camera->name];  // the reader's alone
    // A new chunk is filled only once the queued one is taken: at most one chunk waits.
    if (pending.empty() && chunk_ > 1)
      WaitForRoom(0);
    pending.push_back(std::move(image));
    if (pending.size() >= chunk_)
      Enqueue(std::exchange(pending, {}));
  }

  // Detects the last chunks, waits for the workers; throws a fatal error of theirs.
  void Close() {
    for (auto& [camera, pending] : pending_) {
      if (!pending.empty())
        Enqueue(std::exchange(pending, {}));
    }
    Join();
    if (fatal_)
      std::rethrow_exception(std::exchange(fatal_, nullptr));
  }

  std::map<std::string, CameraResults>& cameras() { return cameras_; }

 private:
  // Waits until at most `queued` chunks are queued; throws a worker's fatal error.
  std::unique_lock<std::mutex> WaitForRoom(std::size_t queued) {
    std::unique_lock<std::mutex> lock(mutex_);
    has_room_.wait(lock, [&] { return queue_.size() <= queued || fatal_; });
    if (fatal_)
      std::rethrow_exception(fatal_);
    return lock;
  }

  void Enqueue(std::vector<BagImage>&& chunk) {
    std::unique_lock<std::mutex> lock = WaitForRoom(capacity_ - 1);
    queue_.push_back(std::move(chunk));
    has_work_.notify_one();
  }

  void Join() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      closed_ = true;
    }
    has_work_.notify_all();
    for (std::thread& t : workers_)
      t.join();
    workers_.clear();
  }

  void Work() {
    for (;;) {
      std::vector<BagImage> chunk;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        has_work_.wait(lock, [&] { return !queue_.empty() || closed_; });
        if (queue_.empty())
          return;
        chunk = std::move(queue_.front());
        queue_.pop_front();
        has_room_.notify_one();
      }
      BoardTracker tracker(*detector_);
      for (BagImage& job : chunk) {
        if (!Detect(job, &tracker))
          break;
      }
    }
  }

  // False after a fatal error (the chunk's other images are not detected).
  bool Detect(BagImage& job, BoardTracker* tracker) {
    const SensorConfig& camera = *job.camera;
    DetectionResult result;
    try {
      const cv::Mat image = RosImageToMat(job.image);
      job.image.data = {};  // the pixels are in `image` now
      if (image.cols != camera.width || image.rows != camera.height) {
        throw InitError(kStage, camera.name,
                        job.where + " is " + std::to_string(image.cols) + "x" +
                            std::to_string(image.rows) + " pixels, the rig's resolution is " +
                            std::to_string(camera.width) + "x" + std::to_string(camera.height));
      }
      result = tracker->Next(image);
    } catch (const InitError&) {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!fatal_)
        fatal_ = std::current_exception();
      has_room_.notify_all();
      return false;
    } catch (const std::exception& e) {
      result.error = job.where + ": " + e.what();
      tracker->Reset();
    }
    CameraDetectionSummary one;
    std::vector<CornerObservation> corners =
        CornersFromDetections({ImageEntry{job.image.t_ns, ""}}, {result}, &one);
    std::lock_guard<std::mutex> lock(mutex_);
    CameraResults& r = cameras_.at(camera.name);
    CameraDetectionSummary& s = r.summary;
    if (one.unreadable && (s.unreadable == 0 || job.index < r.first_error_index)) {
      s.first_error = one.first_error;
      r.first_error_index = job.index;
    }
    s.unreadable += one.unreadable;
    s.with_board += one.with_board;
    s.corners += one.corners;
    s.full_detections += one.full_detections;
    for (const auto& [reason, count] : one.rejected)
      s.rejected[reason] += count;
    // Exactly sized: push_back's spare capacity (up to 2x) over a long recording's ~50 000 views
    // was the stage's largest block of memory.
    corners.shrink_to_fit();
    if (!corners.empty())
      r.corners[job.index] = std::move(corners);
    // Detection is the longest step before the solve on a large recording: a line per tenth.
    ++r.done;
    const std::size_t step = std::max<std::size_t>(1, job.total / 10);
    if (log_ && r.done % step == 0 && r.done < job.total) {
      log_(std::string(kStage) + ": " + camera.name + " " + std::to_string(r.done) + " of " +
           std::to_string(job.total) + " images");
    }
    return true;
  }

  const InitLog& log_;
  std::unique_ptr<Detector> detector_;
  std::size_t chunk_ = 1;
  std::size_t capacity_ = 2;
  std::mutex mutex_;
  std::condition_variable has_work_, has_room_;
  std::deque<std::vector<BagImage>> queue_;
  std::map<std::string, std::vector<BagImage>> pending_;  // per camera
  bool closed_ = false;
  std::exception_ptr fatal_;
  std::vector<std::thread> workers_;
  std::map<std::string, CameraResults> cameras_;
};

}  // namespace

std::map<std::string, SensorData> LoadBagAndDetect(const RigConfig& rig, const std::string& path,
                                                   const std::string& out_dir, int threads,
                                                   Warnings* warnings,
                                                   std::vector<CameraDetectionSummary>* summaries,
                                                   const InitLog& log, bool track) {
  const auto start = std::chrono::steady_clock::now();
  std::map<std::string, SensorData> data;
  DetectionPipeline pipeline(rig, threads, track, log);
  try {
    data = LoadBagDataset(
        path, rig, [&](BagImage&& image) { pipeline.Push(std::move(image)); }, warnings);
    pipeline.Close();
  } catch (const InitError& e) {
    throw CalibrationInputError(e.what());
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (const SensorConfig& s : rig.sensors) {
    if (s.type != SensorType::kCamera)
      continue;
    CameraResults& r = pipeline.cameras().at(s.name);
    r.summary.images = r.done;
    r.summary.seconds = seconds;  // the read and the detection overlap: the whole stage's time
    try {
      FinishCameraDetection(&r.summary, log);
    } catch (const InitError& e) {
      throw CalibrationInputError(e.what());
    }
    SensorData& d = data.at(s.name);
    std::size_t total = 0;
    for (const auto& [index, corners] : r.corners)
      total += corners.size();
    d.corners.reserve(total);  // no doubling: each view's block is freed once copied
    for (auto it = r.corners.begin(); it != r.corners.end(); it = r.corners.erase(it))
      d.corners.insert(d.corners.end(), it->second.begin(), it->second.end());
    d.has_corners = true;
    if (!out_dir.empty()) {
      const std::string file = (std::filesystem::path(out_dir) / s.name / "corners.csv").string();
      WriteCornersCsv(file, d.corners);
      if (log)
        log(std::string(kStage) + ": wrote " + file);
    }
    if (summaries)
      summaries->push_back(r.summary);
  }
  return data;
}

}  // namespace ctcal
