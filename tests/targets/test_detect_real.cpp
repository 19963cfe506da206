// The detector on real photos: Kalibr-printed AprilGrids (shared/data/aprilgrid, its README's tag
// counts), EuRoC's calibration images (ids checked through EuRoC's published calibration),
// OpenCV's checkerboard photos (opencv-doc) and ViSP's AprilTag photo (visp-images-data); and bad
// input. Tests whose data is absent skip with the reason.
#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <tuple>

#include "ctcal/targets/detector.h"

namespace ctcal {
namespace {

namespace fs = std::filesystem;

const std::string kAprilDir = std::string(CTCAL_SHARED_DATA_DIR) + "/aprilgrid/";
const std::string kEurocDir = std::string(CTCAL_SHARED_DATA_DIR) + "/euroc_cam_april/";
const std::string kOpencvDir = "/usr/share/doc/opencv-doc/examples/data/";
const std::string kVispDir = "/usr/share/visp-images-data/ViSP-images/AprilTag/";

#define SKIP_UNLESS_EXISTS(path) \
  if (!fs::exists(path))         \
  GTEST_SKIP() << (path) << " is absent (shared data folder or Debian package not installed)"

Board Euroc6x6() {
  return Board(TargetConfig{});
}  // 6x6, 0.088 m, 0.3, Kalibr's 2-bit border

DetectionResult DetectFile(const Detector& detector, const std::string& path) {
  return detector.Detect(cv::imread(path, cv::IMREAD_UNCHANGED));
}

// Detected corners, undistorted with EuRoC cam0's published pinhole-radtan calibration, must lie
// on one homography of the board plane: a wrong id or corner order costs tens of pixels.
double HomographyRmsPx(const Board& board, const DetectionResult& result) {
  const cv::Matx33d K(458.654, 0, 367.215, 0, 457.296, 248.375, 0, 0, 1);
  const std::vector<double> dist = {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05};
  std::vector<cv::Point2f> pixels, board_xy;
  for (const DetectedCorner& c : result.corners) {
    pixels.emplace_back(static_cast<float>(c.uv.x()), static_cast<float>(c.uv.y()));
    const Eigen::Vector3d& p = board.Corner(c.id);
    board_xy.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  }
  std::vector<cv::Point2f> undistorted;
  cv::undistortPoints(pixels, undistorted, K, dist, cv::noArray(), K);
  const cv::Mat H = cv::findHomography(board_xy, undistorted, 0);
  std::vector<cv::Point2f> predicted;
  cv::perspectiveTransform(board_xy, predicted, H);
  double sum2 = 0.0;
  for (size_t i = 0; i < predicted.size(); ++i) {
    const cv::Point2f d = predicted[i] - undistorted[i];
    sum2 += d.dot(d);
  }
  return std::sqrt(sum2 / static_cast<double>(predicted.size()));
}

TEST(DetectReal, EurocAprilGridAllTagsWithConsistentIds) {
  SKIP_UNLESS_EXISTS(kAprilDir + "EuRoC.png");
  const Board board = Euroc6x6();
  const Detector detector(board);
  for (const std::string& path :
       {kAprilDir + "EuRoC.png", kEurocDir + "cam0_1403709395937837056.png"}) {
    SKIP_UNLESS_EXISTS(path);
    const DetectionResult result = DetectFile(detector, path);
    EXPECT_EQ(result.tags_accepted, 36) << path;
    EXPECT_EQ(result.corners.size(), 144u) << path;
    EXPECT_TRUE(result.rejected.empty()) << path;
    const double rms = HomographyRmsPx(board, result);
    double mean_sigma = 0.0;
    for (const DetectedCorner& c : result.corners)
      mean_sigma += c.sigma / static_cast<double>(result.corners.size());
    std::printf("%s: homography RMS %.3f px after undistortion, mean sigma %.3f px\n",
                fs::path(path).filename().c_str(), rms, mean_sigma);
    EXPECT_LT(rms, 0.35) << path;
    for (const DetectedCorner& c : result.corners) {
      EXPECT_GE(c.sigma, detector.options().min_sigma_px);
      EXPECT_LT(c.sigma, 0.5);
    }
  }
}

// TUM-VI's 16-bit fisheye views of the same grid: the README states 36 tags each. libapriltag's
// straight-edge quads find fewer under the strongest distortion and grid completion recovers
// them (top.png's four tags at the rim through the line extrapolation, docs/targets.md); every
// corner must also lie on a smooth grid (a wrong junction or id costs pixels).
TEST(DetectReal, TumVi16BitFisheyeViews) {
  const Detector detector(Euroc6x6());
  const std::map<std::string, int> floor = {{"TUM_VI.png", 36},
                                            {"right.png", 36},
                                            {"r45.png", 36},
                                            {"top.png", 36},
                                            {"top_right.png", 36}};
  for (const auto& [name, min_tags] : floor) {
    SKIP_UNLESS_EXISTS(kAprilDir + name);
    const cv::Mat image = cv::imread(kAprilDir + name, cv::IMREAD_UNCHANGED);
    ASSERT_EQ(image.depth(), CV_16U) << name;
    const DetectionResult result = detector.Detect(image);
    EXPECT_GE(result.tags_accepted, min_tags) << name;
    EXPECT_EQ(result.corners.size(), 4u * static_cast<size_t>(result.tags_accepted)) << name;
    EXPECT_LT(result.grid_scatter_px, 0.1) << name;
    // Worst corner against its row and column neighbours: a cubic through the 4 nearest on each
    // side predicts it within a fraction of a pixel; a corner on the wrong junction is a bit off.
    std::map<int, Eigen::Vector2d> uv_of;
    for (const DetectedCorner& c : result.corners)
      uv_of[c.id] = c.uv;
    const Board& board = detector.board();
    for (const auto& [id, uv] : uv_of) {
      const int r = id / board.cols(), c = id % board.cols();
      for (const auto& [dr, dc] : std::vector<std::pair<int, int>>{{0, 1}, {1, 0}}) {
        // Four neighbours on one line with this corner in the middle or at an end.
        std::vector<int> line;
        for (int s = -2; s <= 2; ++s) {
          const int rr = r + s * dr, cc = c + s * dc;
          if (s != 0 && rr >= 0 && cc >= 0 && rr < board.rows() && cc < board.cols() &&
              uv_of.count(rr * board.cols() + cc))
            line.push_back(rr * board.cols() + cc);
        }
        if (line.size() != 4)
          continue;
        const Eigen::Vector3d axis = dr == 0 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
        const double scale = board.config().tag_size;
        Eigen::Matrix4d A;
        Eigen::Matrix<double, 4, 2> b;
        for (int k = 0; k < 4; ++k) {
          const double s = (board.Corner(line[k]) - board.Corner(id)).dot(axis) / scale;
          A.row(k) << 1.0, s, s * s, s * s * s;
          b.row(k) = uv_of.at(line[k]).transpose();
        }
        const Eigen::Matrix<double, 4, 2> x = A.fullPivLu().solve(b);
        EXPECT_LT((x.row(0).transpose() - uv).norm(), 1.0) << name << " corner " << id;
      }
    }
  }
}

TEST(DetectReal, ColourPhotosOfGridsOnAMonitor) {
  SKIP_UNLESS_EXISTS(kAprilDir + "iphone.png");
  // iphone.png shows an 11 x 6 grid (66 tags), two_boards.png two 6 x 6 grids with ids 0..71,
  // i.e. one 6-column grid of 12 rows as far as positions go; the grid scatter tells the layout
  // (other column counts scatter by 30-140 px).
  for (const auto& [name, cols, rows, tags] : std::vector<std::tuple<std::string, int, int, int>>{
           {"iphone.png", 11, 6, 66}, {"two_boards.png", 6, 12, 72}}) {
    const cv::Mat image = cv::imread(kAprilDir + name, cv::IMREAD_UNCHANGED);
    ASSERT_EQ(image.channels(), 3) << name;
    TargetConfig big;
    big.tag_rows = rows;
    big.tag_cols = cols;
    const DetectionResult result = Detector(Board(big)).Detect(image);
    EXPECT_EQ(result.tags_detected, tags) << name;
    EXPECT_EQ(result.tags_accepted, tags) << name;
    EXPECT_LT(result.grid_scatter_px, 0.15) << name;
  }
}

// A board of another size in view: the 6 x 6 file on the photo of the 11 x 6 grid reports the ids
// beyond its 36 tags, and refuses the view, since tags 0..35 sit elsewhere on an 11-column grid
// than on a 6-column one (corners at the wrong board positions would poison a calibration).
TEST(DetectReal, LargerBoardInViewReportsUnknownIds) {
  SKIP_UNLESS_EXISTS(kAprilDir + "iphone.png");
  const DetectionResult result = DetectFile(Detector(Euroc6x6()), kAprilDir + "iphone.png");
  EXPECT_FALSE(result.board_found);
  EXPECT_TRUE(result.corners.empty());
  int unknown = 0, refused = 0;
  for (const TagRejection& r : result.rejected) {
    if (r.reason == RejectReason::kUnknownId) {
      EXPECT_GE(r.tag_id, 36);
      ++unknown;
    } else {
      EXPECT_EQ(r.reason, RejectReason::kNotThisBoard);
      ++refused;
    }
  }
  EXPECT_EQ(unknown, 30);
  EXPECT_EQ(refused, 1);
}

// Kalibr's sample images show a grid larger than 6 x 6 (ids up to 47). Read with a 6 x 6 file,
// tags 0..35 still decode but sit elsewhere on that grid: the view must be refused, not turned
// into corners at the wrong board positions.
TEST(DetectReal, AnotherBoardSizeInViewIsRefused) {
  for (const char* name :
       {"kalibr_sampledata_img000100_0_0.png", "kalibr_sampledata_img000100_0_1.png"}) {
    SKIP_UNLESS_EXISTS(kAprilDir + name);
    const DetectionResult result = DetectFile(Detector(Euroc6x6()), kAprilDir + name);
    EXPECT_FALSE(result.board_found) << name;
    EXPECT_TRUE(result.corners.empty()) << name;
    bool refused = false;
    for (const TagRejection& r : result.rejected)
      refused |= r.reason == RejectReason::kNotThisBoard;
    EXPECT_TRUE(refused) << name;
    // With the right file (8 columns; Kalibr's sample grid) the view is kept.
    TargetConfig eight;
    eight.tag_cols = 8;
    eight.tag_rows = 6;
    EXPECT_TRUE(DetectFile(Detector(Board(eight)), kAprilDir + name).board_found) << name;
  }
}

std::vector<std::string> OpencvLeftImages() {
  std::vector<std::string> paths;
  for (int i = 1; i <= 14; ++i) {
    if (i == 10)
      continue;  // there is no left10.jpg
    char name[32];
    std::snprintf(name, sizeof(name), "left%02d.jpg", i);
    paths.push_back(kOpencvDir + name);
  }
  return paths;
}

TargetConfig Opencv9x6() {
  TargetConfig t;
  t.type = TargetType::kCheckerboard;
  t.target_rows = 6;
  t.target_cols = 9;
  t.row_spacing_m = 0.025;
  t.col_spacing_m = 0.025;
  return t;
}

TEST(DetectReal, OpencvCheckerboardsCalibrateLikeOpencv) {
  SKIP_UNLESS_EXISTS(kOpencvDir + "left01.jpg");
  const Board board(Opencv9x6());
  DetectorOptions options;
  options.threads = 2;
  const Detector detector(board, options);
  const std::vector<DetectionResult> results = detector.DetectFiles(OpencvLeftImages());
  std::vector<std::vector<cv::Point3f>> object;
  std::vector<std::vector<cv::Point2f>> image;
  for (const DetectionResult& r : results) {
    ASSERT_TRUE(r.board_found);
    ASSERT_EQ(r.corners.size(), 54u);
    object.emplace_back();
    image.emplace_back();
    for (const DetectedCorner& c : r.corners) {
      const Eigen::Vector3d& p = board.Corner(c.id);
      object.back().emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), 0.0f);
      image.back().emplace_back(static_cast<float>(c.uv.x()), static_cast<float>(c.uv.y()));
    }
  }
  ASSERT_EQ(results.size(), 13u);
  cv::Mat K, dist;
  std::vector<cv::Mat> rvecs, tvecs;
  const double rms = cv::calibrateCamera(object, image, cv::Size(640, 480), K, dist, rvecs, tvecs);
  // opencv-doc's reference: RMS 0.41 px, fx = fy = 536.0, cx = 342.4, cy = 235.5 (its tutorial's
  // cornerSubPix corners); these corners fit better (0.18 px).
  EXPECT_LT(rms, 0.3);
  EXPECT_NEAR(K.at<double>(0, 0), 536.0, 5.0);
  EXPECT_NEAR(K.at<double>(1, 1), 536.0, 5.0);
  EXPECT_NEAR(K.at<double>(0, 2), 342.4, 3.0);
  EXPECT_NEAR(K.at<double>(1, 2), 235.5, 3.0);
  std::printf(
      "opencv-doc left*.jpg: calibrateCamera RMS %.3f px, fx %.1f fy %.1f cx %.1f cy %.1f\n", rms,
      K.at<double>(0, 0), K.at<double>(1, 1), K.at<double>(0, 2), K.at<double>(1, 2));
}

// The sigma written to corners.csv against the residuals of a calibrated camera: opencv-doc's 13
// checkerboard views calibrated together (OpenCV's 5-parameter radtan), and each real EuRoC view
// calibrated on its own (pinhole-radtan from EuRoC's published values, k3 fixed). Whitened
// residual RMS per coordinate, corrected for the parameters fitted: 1 if the sigma is honest.
double WhitenedRms(const std::vector<std::vector<cv::Point3f>>& object,
                   const std::vector<std::vector<cv::Point2f>>& image,
                   const std::vector<std::vector<double>>& sigma, const cv::Size& size, cv::Mat K,
                   cv::Mat dist, int flags, int intrinsics, double* rms_px) {
  std::vector<cv::Mat> rvecs, tvecs;
  cv::calibrateCamera(object, image, size, K, dist, rvecs, tvecs, flags);
  double sum2 = 0.0, raw2 = 0.0;
  int n = 0;
  for (size_t v = 0; v < object.size(); ++v) {
    std::vector<cv::Point2f> projected;
    cv::projectPoints(object[v], rvecs[v], tvecs[v], K, dist, projected);
    for (size_t i = 0; i < projected.size(); ++i) {
      const cv::Point2f d = projected[i] - image[v][i];
      sum2 += d.dot(d) / (sigma[v][i] * sigma[v][i]);
      raw2 += d.dot(d);
      n += 2;
    }
  }
  const int parameters = intrinsics + 6 * static_cast<int>(object.size());
  *rms_px = std::sqrt(raw2 / (n - parameters));
  return std::sqrt(sum2 / (n - parameters));
}

void AddView(const Board& board, const DetectionResult& r,
             std::vector<std::vector<cv::Point3f>>* object,
             std::vector<std::vector<cv::Point2f>>* image,
             std::vector<std::vector<double>>* sigma) {
  object->emplace_back();
  image->emplace_back();
  sigma->emplace_back();
  for (const DetectedCorner& c : r.corners) {
    const Eigen::Vector3d& p = board.Corner(c.id);
    object->back().emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), 0.0f);
    image->back().emplace_back(static_cast<float>(c.uv.x()), static_cast<float>(c.uv.y()));
    sigma->back().push_back(c.sigma);
  }
}

TEST(DetectReal, SigmaIsHonestOnCalibratedRealViews) {
  SKIP_UNLESS_EXISTS(kOpencvDir + "left01.jpg");
  {
    const Board board(Opencv9x6());
    const std::vector<DetectionResult> results = Detector(board).DetectFiles(OpencvLeftImages());
    std::vector<std::vector<cv::Point3f>> object;
    std::vector<std::vector<cv::Point2f>> image;
    std::vector<std::vector<double>> sigma;
    double mean_sigma = 0.0;
    for (const DetectionResult& r : results) {
      ASSERT_TRUE(r.board_found);
      AddView(board, r, &object, &image, &sigma);
      for (const DetectedCorner& c : r.corners)
        mean_sigma += c.sigma / (54.0 * static_cast<double>(results.size()));
    }
    double rms = 0.0;
    const double whitened =
        WhitenedRms(object, image, sigma, cv::Size(640, 480), cv::Mat(), cv::Mat(), 0, 9, &rms);
    std::printf(
        "opencv-doc left*.jpg: residual %.3f px per coordinate, mean sigma %.3f px, "
        "whitened RMS %.2f\n",
        rms, mean_sigma, whitened);
    EXPECT_GT(whitened, 0.7);
    EXPECT_LT(whitened, 2.0);
  }
  const Board board = Euroc6x6();
  for (const std::string& path :
       {kAprilDir + "EuRoC.png", kEurocDir + "cam0_1403709395937837056.png",
        kEurocDir + "cam1_1403709395937837056.png"}) {
    SKIP_UNLESS_EXISTS(path);
    const DetectionResult r = DetectFile(Detector(board), path);
    ASSERT_EQ(r.corners.size(), 144u) << path;
    std::vector<std::vector<cv::Point3f>> object;
    std::vector<std::vector<cv::Point2f>> image;
    std::vector<std::vector<double>> sigma;
    AddView(board, r, &object, &image, &sigma);
    const cv::Mat K = (cv::Mat_<double>(3, 3) << 458.654, 0, 367.215, 0, 457.296, 248.375, 0, 0, 1);
    const cv::Mat dist =
        (cv::Mat_<double>(1, 5) << -0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.0);
    double rms = 0.0;
    const double whitened = WhitenedRms(object, image, sigma, cv::Size(752, 480), K, dist,
                                        cv::CALIB_USE_INTRINSIC_GUESS | cv::CALIB_FIX_K3, 8, &rms);
    std::printf(
        "%s: residual %.3f px per coordinate, scatter %.3f px, sigma %.3f px, whitened "
        "RMS %.2f\n",
        fs::path(path).filename().c_str(), rms, r.grid_scatter_px, r.corners[0].sigma, whitened);
    EXPECT_GT(whitened, 0.7) << path;
    EXPECT_LT(whitened, 2.0) << path;
  }
}

TEST(DetectReal, ParallelDetectionIsDeterministic) {
  SKIP_UNLESS_EXISTS(kOpencvDir + "left01.jpg");
  DetectorOptions one_thread;
  one_thread.threads = 1;
  DetectorOptions three_threads;
  three_threads.threads = 3;
  const Board board(Opencv9x6());
  const auto a = Detector(board, one_thread).DetectFiles(OpencvLeftImages());
  const auto b = Detector(board, three_threads).DetectFiles(OpencvLeftImages());
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].corners.size(), b[i].corners.size());
    for (size_t k = 0; k < a[i].corners.size(); ++k) {
      EXPECT_EQ(a[i].corners[k].id, b[i].corners[k].id);
      EXPECT_EQ(a[i].corners[k].uv, b[i].corners[k].uv);  // bit-identical
      EXPECT_EQ(a[i].corners[k].sigma, b[i].corners[k].sigma);
    }
  }
}

// AprilGrids on 16-bit fisheye photos (every pass, painting and completion run): one thread or
// two, bit-identical corners.
TEST(DetectReal, ParallelAprilGridDetectionIsDeterministic) {
  SKIP_UNLESS_EXISTS(kAprilDir + "r45.png");
  std::vector<std::string> paths;
  for (const char* name : {"r45.png", "top.png", "EuRoC.png", "right.png"})
    paths.push_back(kAprilDir + name);
  DetectorOptions one_thread;
  one_thread.threads = 1;
  DetectorOptions two_threads;
  two_threads.threads = 2;
  const auto a = Detector(Euroc6x6(), one_thread).DetectFiles(paths);
  const auto b = Detector(Euroc6x6(), two_threads).DetectFiles(paths);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].corners.size(), b[i].corners.size()) << paths[i];
    for (size_t k = 0; k < a[i].corners.size(); ++k) {
      EXPECT_EQ(a[i].corners[k].id, b[i].corners[k].id);
      EXPECT_EQ(a[i].corners[k].uv, b[i].corners[k].uv);
      EXPECT_EQ(a[i].corners[k].sigma, b[i].corners[k].sigma);
    }
  }
}

// ViSP's file holds its own detector's corners (libapriltag's convention: pixel (0,0) is the
// top-left pixel's corner), in (row, col) order, per "36h11_id:_<id>".
TEST(DetectReal, VispAprilTagPhotoStandardTags) {
  SKIP_UNLESS_EXISTS(kVispDir + "AprilTag.pgm");
  std::ifstream file(kVispDir + "ground_truth_detection.txt");
  std::map<int, std::vector<Eigen::Vector2d>> truth;
  std::string line;
  int id = -1;
  while (std::getline(file, line)) {
    if (line.rfind("36h11_id:_", 0) == 0) {
      id = std::stoi(line.substr(10));
    } else if (id >= 0 && !line.empty()) {
      std::istringstream in(line);
      double row = 0, col = 0;
      in >> row >> col;
      truth[id].emplace_back(col - 0.5, row - 0.5);  // to SPEC section 4 pixels
    }
  }
  ASSERT_EQ(truth.size(), 12u);
  const std::vector<TagDetection> tags =
      DetectTags36h11(cv::imread(kVispDir + "AprilTag.pgm", cv::IMREAD_UNCHANGED), 1);
  ASSERT_EQ(tags.size(), truth.size());
  double worst = 0.0;
  for (const TagDetection& tag : tags) {
    ASSERT_TRUE(truth.count(tag.id)) << tag.id;
    ASSERT_EQ(truth[tag.id].size(), 4u);
    for (size_t k = 0; k < 4; ++k)
      worst = std::max(worst, (tag.corners[k] - truth[tag.id][k]).norm());
  }
  EXPECT_LT(worst, 0.5);
}

TEST(DetectReal, BadInputGivesMessagesNotCrashes) {
  const Detector detector(Euroc6x6());
  EXPECT_FALSE(detector.Detect(cv::Mat()).error.empty());
  EXPECT_FALSE(detector.Detect(cv::Mat(10, 10, CV_32FC1, cv::Scalar(0.5))).error.empty());
  EXPECT_FALSE(detector.Detect(cv::Mat(10, 10, CV_8UC2, cv::Scalar(0))).error.empty());
  const DetectionResult tiny = detector.Detect(cv::Mat(3, 2, CV_8UC1, cv::Scalar(0)));
  EXPECT_TRUE(tiny.error.empty());
  EXPECT_FALSE(tiny.board_found);
  const std::string missing = "/nonexistent/image.png";
  const std::string not_an_image = std::string(CTCAL_SOURCE_DIR) + "/CMakeLists.txt";
  const auto results = detector.DetectFiles({missing, not_an_image});
  ASSERT_EQ(results.size(), 2u);
  EXPECT_NE(results[0].error.find(missing), std::string::npos);
  EXPECT_NE(results[1].error.find(not_an_image), std::string::npos);
  EXPECT_FALSE(results[0].board_found);
  // A checkerboard of another size in view is no board, not a wrong one.
  if (fs::exists(kOpencvDir + "left01.jpg")) {
    TargetConfig other = Opencv9x6();
    other.target_cols = 8;
    const DetectionResult r = DetectFile(Detector(Board(other)), kOpencvDir + "left01.jpg");
    EXPECT_TRUE(r.error.empty());
    EXPECT_FALSE(r.board_found);
  }
}

}  // namespace
}  // namespace ctcal
