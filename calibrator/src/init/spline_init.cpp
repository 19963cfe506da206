#include "ctcal/calibrator/spline_init.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <optional>
#include <utility>

#include "ctcal/sensors/parallel_for.h"
#include "ctcal/spline/so3.h"

namespace ctcal {
namespace {

// Smallest outlier gate on the normalised plane (~0.1 deg, a pixel or more for any lens).
constexpr double kInlierThreshold = 0.002;

// The board point p_W seen on the normalised plane of the camera at T_C_W = (R, t).
Eigen::Vector2d Project(const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                        const cv::Point3d& p_W) {
  const Eigen::Vector3d p_C = R * Eigen::Vector3d(p_W.x, p_W.y, p_W.z) + t;
  return p_C.head<2>() / p_C.z();
}

// Sum of the squared normalised-plane errors at (R, t); infinite with a point behind the camera.
double PlaneCost(const std::vector<cv::Point3d>& object, const std::vector<cv::Point2d>& image,
                 const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  double cost = 0.0;
  for (std::size_t k = 0; k < object.size(); ++k) {
    const Eigen::Vector3d p_C = R * Eigen::Vector3d(object[k].x, object[k].y, object[k].z) + t;
    if (!(p_C.z() > 1e-9))
      return std::numeric_limits<double>::infinity();
    cost += (p_C.head<2>() / p_C.z() - Eigen::Vector2d(image[k].x, image[k].y)).squaredNorm();
  }
  return cost;
}

// Refines T_C_W = (R, t) to the minimum of F = sum_k |pi(R p_k + t) - m_k|^2 over the corners'
// normalised-plane points m_k, pi(X) = (x / z, y / z): the objective of OpenCV's
// SOLVEPNP_ITERATIVE with K = I, which this replaces (its general Levenberg-Marquardt made the
// board-pose stage ~0.7 s CPU of the 60 s demo; docs/performance.md step 7c). Perturbing
// R <- Exp(dtheta) R, t <- t + dt moves X_k = R p_k + t by -[R p_k]x dtheta + dt, so the
// residual's Jacobian is dpi/dX [-[R p_k]x | I] with dpi/dX = [1/z 0 -x/z^2; 0 1/z -y/z^2].
// Gauss-Newton on the 6x6 normal equations, damped (Levenberg-Marquardt) only when a step does
// not lower F; from IPPE's start it converges in 2-4 steps. False when F is not finite.
bool RefinePoseOnPlane(const std::vector<cv::Point3d>& object,
                       const std::vector<cv::Point2d>& image, Eigen::Matrix3d* R,
                       Eigen::Vector3d* t) {
  constexpr int kMaxIterations = 20;
  // Converged: a step below 1e-10 (rad, normalised-plane units; ~1e-7 px) or a decrease below
  // 1e-12 of the cost (the next Gauss-Newton step is then far below the first).
  constexpr double kStepTolerance = 1e-10;
  constexpr double kRelativeDecrease = 1e-12;
  double cost = PlaneCost(object, image, *R, *t);
  if (!std::isfinite(cost))
    return false;
  double lambda = 0.0;
  for (int it = 0; it < kMaxIterations; ++it) {
    Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
    for (std::size_t k = 0; k < object.size(); ++k) {
      const Eigen::Vector3d Rp = *R * Eigen::Vector3d(object[k].x, object[k].y, object[k].z);
      const Eigen::Vector3d X = Rp + *t;
      const double iz = 1.0 / X.z();
      Eigen::Matrix<double, 2, 3> J_pi_X;
      J_pi_X << iz, 0.0, -X.x() * iz * iz, 0.0, iz, -X.y() * iz * iz;
      Eigen::Matrix<double, 2, 6> J;
      J.leftCols<3>() = -J_pi_X * Hat<double>(Rp);
      J.rightCols<3>() = J_pi_X;
      const Eigen::Vector2d e = X.head<2>() * iz - Eigen::Vector2d(image[k].x, image[k].y);
      // Fixed-size products, unrolled: Eigen's rankUpdate dispatches a 6x6 update of rank 2 to
      // its blocked general kernel, which was most of the board poses' time.
      H.noalias() += J.transpose() * J;
      g.noalias() += J.transpose() * e;
    }
    bool improved = false;
    for (int attempt = 0; attempt < 10 && !improved; ++attempt) {
      Eigen::Matrix<double, 6, 6> A = H;
      A.diagonal() *= 1.0 + lambda;
      const Eigen::Matrix<double, 6, 1> step = -A.ldlt().solve(g);
      if (!step.allFinite() || step.norm() < kStepTolerance)
        return true;
      const Eigen::Matrix3d R_new = ExpSO3<double>(step.head<3>()).toRotationMatrix() * *R;
      const Eigen::Vector3d t_new = *t + step.tail<3>();
      const double cost_new = PlaneCost(object, image, R_new, t_new);
      if (cost_new <= cost) {
        improved = true;
        *R = R_new;
        *t = t_new;
        const bool converged = cost - cost_new <= kRelativeDecrease * cost;
        cost = cost_new;
        lambda = 0.0;
        if (converged)
          return true;
      } else {
        lambda = lambda == 0.0 ? 1e-6 : 10.0 * lambda;
      }
    }
    if (!improved)
      return true;  // no descent left at rounding level: the minimum
  }
  return true;
}

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
  // The board is planar: IPPE on every corner, the pose refined (RefinePoseOnPlane), then the
  // corners beyond a robust gate (5 x the median error, at least kInlierThreshold) are dropped
  // and the pose refined again on the rest.
  if (!cv::solvePnP(object, image, K, cv::noArray(), rvec, tvec, false, cv::SOLVEPNP_IPPE))
    return std::nullopt;
  cv::Mat R_cv;
  cv::Rodrigues(rvec, R_cv);
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  cv::cv2eigen(R_cv, R);
  cv::cv2eigen(tvec, t);
  if (!RefinePoseOnPlane(object, image, &R, &t))
    return std::nullopt;
  std::vector<double> err(object.size());
  for (std::size_t k = 0; k < object.size(); ++k)
    err[k] = (Project(R, t, object[k]) - Eigen::Vector2d(image[k].x, image[k].y)).norm();
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
  // Without a corner dropped the pose is already the optimum of the same objective.
  if (obj_in.size() < object.size() && !RefinePoseOnPlane(obj_in, img_in, &R, &t))
    return std::nullopt;
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
