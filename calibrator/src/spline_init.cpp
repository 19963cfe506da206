#include "ctcal/calibrator/spline_init.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <optional>
#include <utility>

#include "ctcal/sensors/parallel_for.h"

namespace ctcal {
namespace {

// Smallest outlier gate on the normalised plane (~0.1 deg, a pixel or more for any lens).
constexpr double kInlierThreshold = 0.002;

// The board pose of the frame made of corners [i, j) (one stamp), if it has one.
std::optional<BoardView> EstimateBoardView(const CameraModel& camera, const Board& board,
                                           const std::vector<CornerObservation>& corners,
                                           std::size_t i, std::size_t j, int min_corners) {
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  for (std::size_t k = i; k < j; ++k) {
    Eigen::Vector3d ray;
    if (!camera.Unproject(Eigen::Vector2d(corners[k].u, corners[k].v), &ray) || ray.z() < 0.05)
      continue;
    const Eigen::Vector3d& p = board.Corner(corners[k].corner_id);
    object.emplace_back(p.x(), p.y(), p.z());
    image.emplace_back(ray.x() / ray.z(), ray.y() / ray.z());
  }
  BoardView view;
  view.t_ns = corners[i].t_ns;
  view.corners = static_cast<int>(j - i);
  if (static_cast<int>(object.size()) < min_corners)
    return std::nullopt;
  const cv::Matx33d K = cv::Matx33d::eye();
  cv::Mat rvec, tvec;
  // The board is planar: IPPE on every corner, Levenberg-Marquardt refinement, then the corners
  // beyond a robust gate (5 x the median error, at least kInlierThreshold) are dropped and the
  // pose refined again on the rest.
  if (!cv::solvePnP(object, image, K, cv::noArray(), rvec, tvec, false, cv::SOLVEPNP_IPPE))
    return std::nullopt;
  cv::solvePnP(object, image, K, cv::noArray(), rvec, tvec, true, cv::SOLVEPNP_ITERATIVE);
  std::vector<cv::Point2d> projected;
  cv::projectPoints(object, rvec, tvec, K, cv::noArray(), projected);
  std::vector<double> err(object.size());
  for (std::size_t k = 0; k < object.size(); ++k)
    err[k] = std::hypot(projected[k].x - image[k].x, projected[k].y - image[k].y);
  std::vector<double> sorted = err;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2),
                   sorted.end());
  const double gate = std::max(kInlierThreshold, 5.0 * sorted[sorted.size() / 2]);
  std::vector<cv::Point3d> obj_in;
  std::vector<cv::Point2d> img_in;
  for (std::size_t k = 0; k < object.size(); ++k) {
    if (err[k] <= gate) {
      obj_in.push_back(object[k]);
      img_in.push_back(image[k]);
    }
  }
  if (static_cast<int>(obj_in.size()) < min_corners)
    return std::nullopt;
  cv::solvePnP(obj_in, img_in, K, cv::noArray(), rvec, tvec, true, cv::SOLVEPNP_ITERATIVE);
  cv::Mat R_cv;
  cv::Rodrigues(rvec, R_cv);
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  cv::cv2eigen(R_cv, R);
  cv::cv2eigen(tvec, t);
  view.T_C_W = Eigen::Isometry3d::Identity();
  view.T_C_W.linear() = R;
  view.T_C_W.translation() = t;
  double sq = 0.0;
  bool in_front = true;
  for (std::size_t k = 0; k < obj_in.size(); ++k) {
    const Eigen::Vector3d p_C = view.T_C_W * Eigen::Vector3d(obj_in[k].x, obj_in[k].y, obj_in[k].z);
    if (p_C.z() <= 0.0) {
      in_front = false;
      break;
    }
    sq +=
        std::pow(p_C.x() / p_C.z() - img_in[k].x, 2) + std::pow(p_C.y() / p_C.z() - img_in[k].y, 2);
  }
  if (!in_front)
    return std::nullopt;
  view.inliers = static_cast<int>(obj_in.size());
  view.rms_ray_error = std::sqrt(sq / (2.0 * static_cast<double>(obj_in.size())));
  return view;
}

}  // namespace

std::vector<BoardView> EstimateBoardViews(const CameraModel& camera, const Board& board,
                                          const std::vector<CornerObservation>& corners,
                                          int min_corners, int threads) {
  // Frames are runs of equal stamps; each frame's pose is independent of the others.
  std::vector<std::pair<std::size_t, std::size_t>> frames;
  for (std::size_t i = 0, j = 0; i < corners.size(); i = j) {
    j = i;
    while (j < corners.size() && corners[j].t_ns == corners[i].t_ns)
      ++j;
    frames.emplace_back(i, j);
  }
  std::vector<std::optional<BoardView>> found(frames.size());
  ParallelFor(threads, frames.size(), [&](std::size_t f) {
    found[f] =
        EstimateBoardView(camera, board, corners, frames[f].first, frames[f].second, min_corners);
  });
  std::vector<BoardView> views;
  for (const std::optional<BoardView>& v : found) {
    if (v)
      views.push_back(*v);
  }
  return views;
}

std::vector<TimedPose> BasePosesFromViews(const std::vector<BoardView>& views,
                                          const Eigen::Isometry3d& T_B_C, double time_offset) {
  std::vector<TimedPose> poses;
  poses.reserve(views.size());
  const Eigen::Isometry3d T_C_B = T_B_C.inverse();
  for (const BoardView& v : views) {
    const Eigen::Isometry3d T_W_B = v.T_C_W.inverse() * T_C_B;
    TimedPose p;
    p.t_ns = v.t_ns + static_cast<std::int64_t>(std::llround(time_offset * 1e9));
    p.q_W_B = Eigen::Quaterniond(T_W_B.linear()).normalized();
    p.p_W_B = T_W_B.translation();
    poses.push_back(p);
  }
  return poses;
}

}  // namespace ctcal
