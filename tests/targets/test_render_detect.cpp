// Rendered boards detected again: the detector's corners against the true projections of the
// board corners, for a pinhole-radtan 752x480 and a pinhole-equidistant 512x512 camera (camera
// models written out here, independent of the sensors library), plus checkerboards and a rolling
// shutter. These tests also pin the pixel convention: the renderer samples pixel (u, v) at its
// centre (SPEC section 4), so a half-pixel error anywhere shows up as a 0.5 px bias.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "ctcal/targets/detector.h"
#include "ctcal/targets/renderer.h"

namespace ctcal {
namespace {

struct Camera {
  virtual ~Camera() = default;
  virtual Eigen::Vector2d Project(const Eigen::Vector3d& p_C) const = 0;
  virtual bool Unproject(const Eigen::Vector2d& uv, Eigen::Vector3d* ray_C) const = 0;
};

// Kalibr's pinhole-radtan (EuRoC cam0's values).
struct RadtanCamera : Camera {
  double fu = 458.654, fv = 457.296, cu = 367.215, cv = 248.375;
  double k1 = -0.28340811, k2 = 0.07395907, r1 = 0.00019359, r2 = 1.76187114e-05;
  Eigen::Vector2d Distort(const Eigen::Vector2d& m) const {
    const double x = m.x(), y = m.y(), rr = x * x + y * y;
    const double radial = 1.0 + k1 * rr + k2 * rr * rr;
    return Eigen::Vector2d(x * radial + 2.0 * r1 * x * y + r2 * (rr + 2.0 * x * x),
                           y * radial + r1 * (rr + 2.0 * y * y) + 2.0 * r2 * x * y);
  }
  Eigen::Vector2d Project(const Eigen::Vector3d& p) const override {
    const Eigen::Vector2d d = Distort(p.head<2>() / p.z());
    return Eigen::Vector2d(fu * d.x() + cu, fv * d.y() + cv);
  }
  bool Unproject(const Eigen::Vector2d& uv, Eigen::Vector3d* ray) const override {
    const Eigen::Vector2d target((uv.x() - cu) / fu, (uv.y() - cv) / fv);
    Eigen::Vector2d m = target;
    for (int i = 0; i < 50; ++i) {  // Gauss-Newton on Distort(m) = target, numeric Jacobian
      const Eigen::Vector2d r = Distort(m) - target;
      Eigen::Matrix2d J;
      const double h = 1e-7;
      J.col(0) =
          (Distort(m + Eigen::Vector2d(h, 0)) - Distort(m - Eigen::Vector2d(h, 0))) / (2 * h);
      J.col(1) =
          (Distort(m + Eigen::Vector2d(0, h)) - Distort(m - Eigen::Vector2d(0, h))) / (2 * h);
      m -= J.inverse() * r;
      if (r.norm() < 1e-12)
        break;
    }
    if ((Distort(m) - target).norm() > 1e-9)
      return false;
    *ray = Eigen::Vector3d(m.x(), m.y(), 1.0);
    return true;
  }
};

// Kalibr's pinhole-equidistant (Kannala-Brandt), TUM-VI-like values.
struct EquidistantCamera : Camera {
  double fu = 190.97, fv = 190.97, cu = 254.93, cv = 256.89;
  double k[4] = {0.0034823894, 0.0007150348, -0.0020532361, 0.0002029367};
  double Theta(double theta) const {
    const double t2 = theta * theta;
    return theta * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))));
  }
  Eigen::Vector2d Project(const Eigen::Vector3d& p) const override {
    const double r = p.head<2>().norm();
    const double theta_d = Theta(std::atan2(r, p.z()));
    const Eigen::Vector2d dir =
        r > 1e-12 ? Eigen::Vector2d(p.head<2>() / r) : Eigen::Vector2d(0, 0);
    return Eigen::Vector2d(fu * theta_d * dir.x() + cu, fv * theta_d * dir.y() + cv);
  }
  bool Unproject(const Eigen::Vector2d& uv, Eigen::Vector3d* ray) const override {
    const Eigen::Vector2d m((uv.x() - cu) / fu, (uv.y() - cv) / fv);
    const double theta_d = m.norm();
    double theta = theta_d;
    for (int i = 0; i < 30; ++i) {
      const double h = 1e-7;
      const double f = Theta(theta) - theta_d;
      theta -= f / ((Theta(theta + h) - Theta(theta - h)) / (2 * h));
    }
    if (!(theta >= 0.0) || theta > 1.5)
      return false;
    const Eigen::Vector2d dir =
        theta_d > 1e-12 ? Eigen::Vector2d(m / theta_d) : Eigen::Vector2d(0, 0);
    *ray = Eigen::Vector3d(std::sin(theta) * dir.x(), std::sin(theta) * dir.y(), std::cos(theta));
    return true;
  }
};

// Camera at p_W looking at target_W, x axis roughly along +x_W, y down (SPEC section 1), and
// rolled by `roll` about its optical axis.
Eigen::Isometry3d LookAt(const Eigen::Vector3d& p_W, const Eigen::Vector3d& target_W, double roll) {
  const Eigen::Vector3d z = (target_W - p_W).normalized();
  Eigen::Vector3d x = Eigen::Vector3d::UnitX() - z * z.x();
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d R_W_C;
  R_W_C << x, y, z;
  Eigen::Isometry3d T_W_C = Eigen::Isometry3d::Identity();
  T_W_C.linear() = R_W_C * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_W_C.translation() = p_W;
  return T_W_C;
}

struct Errors {
  int matched = 0;
  double rms = 0.0;
  double max = 0.0;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
};

Errors Compare(const Board& board, const Camera& camera, const Eigen::Isometry3d& T_W_C,
               const DetectionResult& result) {
  Errors e;
  const Eigen::Isometry3d T_C_W = T_W_C.inverse();
  double sum2 = 0.0;
  for (const DetectedCorner& c : result.corners) {
    const Eigen::Vector2d truth = camera.Project(T_C_W * board.Corner(c.id));
    const Eigen::Vector2d d = c.uv - truth;
    sum2 += d.squaredNorm();
    e.mean += d;
    e.max = std::max(e.max, d.norm());
    ++e.matched;
  }
  if (e.matched > 0) {
    e.rms = std::sqrt(sum2 / e.matched);
    e.mean /= e.matched;
  }
  return e;
}

UnprojectFunction Unprojection(const Camera& camera) {
  return [&camera](const Eigen::Vector2d& uv, Eigen::Vector3d* ray) {
    return camera.Unproject(uv, ray);
  };
}

TargetConfig Grid6x6() {
  return TargetConfig{};
}  // 6x6, 0.088 m, 0.3, 2-bit border

TEST(RenderDetect, RadtanAprilGridCornersWithinATenthOfAPixel) {
  const RadtanCamera camera;
  const Board board(Grid6x6());
  const BoardRenderer renderer(board, 752, 480, Unprojection(camera));
  const Detector detector(board);
  const Eigen::Vector3d centre(0.33, 0.33, 0.0);
  int views = 0;
  for (const auto& [p_W, roll] : std::vector<std::pair<Eigen::Vector3d, double>>{
           {{0.35, 0.30, 0.85}, 0.1}, {{0.05, 0.45, 0.75}, 0.3}, {{0.7, 0.2, 0.9}, 2.5}}) {
    const Eigen::Isometry3d T_W_C = LookAt(p_W, centre, roll);
    const DetectionResult result = detector.Detect(renderer.Render(T_W_C, 7 + views));
    const Errors e = Compare(board, camera, T_W_C, result);
    std::printf("radtan 752x480 view %d: %d corners, RMS %.3f px, max %.3f px, bias (%.3f, %.3f)\n",
                views, e.matched, e.rms, e.max, e.mean.x(), e.mean.y());
    EXPECT_GE(e.matched, 100) << "view " << views;
    EXPECT_LE(e.rms, 0.1) << "view " << views;
    EXPECT_LE(e.max, 0.4) << "view " << views;
    EXPECT_LT(e.mean.norm(), 0.05) << "half-pixel convention bias, view " << views;
    for (const DetectedCorner& c : result.corners) {
      EXPECT_GT(c.sigma, 0.0);
      EXPECT_LT(c.sigma, 0.5);
    }
    ++views;
  }
}

TEST(RenderDetect, EquidistantAprilGridCornersWithinATenthOfAPixel) {
  const EquidistantCamera camera;
  const Board board(Grid6x6());
  const BoardRenderer renderer(board, 512, 512, Unprojection(camera));
  const Detector detector(board);
  const Eigen::Isometry3d T_W_C = LookAt({0.25, 0.4, 0.45}, {0.33, 0.33, 0.0}, 0.4);
  const DetectionResult result = detector.Detect(renderer.Render(T_W_C, 3));
  const Errors e = Compare(board, camera, T_W_C, result);
  std::printf("equidistant 512x512: %d corners, RMS %.3f px, max %.3f px\n", e.matched, e.rms,
              e.max);
  EXPECT_GE(e.matched, 100);
  EXPECT_LE(e.rms, 0.1);
  EXPECT_LT(e.mean.norm(), 0.05);
}

TEST(RenderDetect, OneBitBorderBoard) {
  const RadtanCamera camera;
  TargetConfig config = Grid6x6();
  config.black_tag_border = 1;
  const Board board(config);
  const BoardRenderer renderer(board, 752, 480, Unprojection(camera));
  const Eigen::Isometry3d T_W_C = LookAt({0.3, 0.35, 0.8}, {0.33, 0.33, 0.0}, -0.2);
  const cv::Mat image = renderer.Render(T_W_C, 5);
  const DetectionResult result = Detector(board).Detect(image);
  const Errors e = Compare(board, camera, T_W_C, result);
  EXPECT_EQ(result.tags_accepted, 36);
  for (const TagRejection& r : result.rejected)
    ADD_FAILURE() << "tag " << r.tag_id << ": " << ToString(r.reason);
  EXPECT_LE(e.rms, 0.1);
  // The 2-bit family must not read a 1-bit board (and vice versa).
  TargetConfig wrong = config;
  wrong.black_tag_border = 2;
  const DetectionResult other = Detector(Board(wrong)).Detect(image);
  EXPECT_FALSE(other.board_found) << other.tags_accepted << " tags accepted";
}

TEST(RenderDetect, CheckerboardIdsSurviveAHalfTurn) {
  const RadtanCamera camera;
  TargetConfig config;
  config.type = TargetType::kCheckerboard;
  config.target_rows = 6;
  config.target_cols = 7;  // rows + cols odd: the colours fix the orientation
  config.row_spacing_m = 0.06;
  config.col_spacing_m = 0.06;
  const Board board(config);
  const BoardRenderer renderer(board, 752, 480, Unprojection(camera));
  const Detector detector(board);
  for (double roll : {0.2, 0.2 + M_PI, 1.4, 1.4 + M_PI}) {
    const Eigen::Isometry3d T_W_C = LookAt({0.2, 0.15, 0.7}, {0.15, 0.18, 0.0}, roll);
    const DetectionResult result = detector.Detect(renderer.Render(T_W_C, 11));
    ASSERT_TRUE(result.board_found) << "roll " << roll;
    EXPECT_EQ(static_cast<int>(result.corners.size()), 42);
    const Errors e = Compare(board, camera, T_W_C, result);
    EXPECT_LE(e.rms, 0.1) << "roll " << roll;
  }
}

TEST(RenderDetect, RollingShutterRowsSeeTheirOwnPose) {
  const RadtanCamera camera;
  const Board board(Grid6x6());
  const BoardRenderer renderer(board, 752, 480, Unprojection(camera));
  const Eigen::Isometry3d T_W_C0 = LookAt({0.35, 0.30, 0.85}, {0.33, 0.33, 0.0}, 0.1);
  // The camera slides along x_W by 2 mm per 100 rows while the frame is read out.
  auto pose_of_row = [&](int row) {
    Eigen::Isometry3d T = T_W_C0;
    T.translation().x() += 2e-5 * row;
    return T;
  };
  const DetectionResult result = Detector(board).Detect(renderer.Render(pose_of_row, 1));
  ASSERT_TRUE(result.board_found);
  double sum2_own = 0.0, sum2_global = 0.0;
  for (const DetectedCorner& c : result.corners) {
    const Eigen::Vector3d& p_W = board.Corner(c.id);
    // The row a corner is read at depends on where it lands: iterate v -> pose(v) -> v.
    double v = c.uv.y();
    Eigen::Vector2d uv;
    for (int i = 0; i < 5; ++i) {
      uv = camera.Project(pose_of_row(static_cast<int>(std::lround(v))).inverse() * p_W);
      v = uv.y();
    }
    sum2_own += (c.uv - uv).squaredNorm();
    sum2_global += (c.uv - camera.Project(T_W_C0.inverse() * p_W)).squaredNorm();
  }
  const double n = static_cast<double>(result.corners.size());
  EXPECT_LE(std::sqrt(sum2_own / n), 0.15);
  EXPECT_GT(std::sqrt(sum2_global / n), 0.5);  // the effect is real, not lost in the noise
}

TEST(RenderDetect, RenderingIsDeterministicPerSeed) {
  const RadtanCamera camera;
  const Board board(Grid6x6());
  const BoardRenderer renderer(board, 752, 480, Unprojection(camera));
  const Eigen::Isometry3d T_W_C = LookAt({0.35, 0.30, 0.85}, {0.33, 0.33, 0.0}, 0.1);
  const cv::Mat a = renderer.Render(T_W_C, 42);
  const cv::Mat b = renderer.Render(T_W_C, 42);
  const cv::Mat c = renderer.Render(T_W_C, 43);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a, c, cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace ctcal
