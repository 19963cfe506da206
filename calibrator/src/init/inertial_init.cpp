#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "ctcal/calibrator/init/inertial_init.h"
#include "ctcal/spline/so3.h"

namespace ctcal {

namespace {

double HuberWeight(double r, double k) {
  return r <= k ? 1.0 : k / r;
}

// Index of the last sample with time <= t (samples sorted), or -1.
template <typename Sample>
long Bracket(const std::vector<Sample>& samples, double t) {
  const auto it =
      std::upper_bound(samples.begin(), samples.end(), t,
                       [](double value, const Sample& s) { return value < InitSeconds(s.t_ns); });
  return static_cast<long>(it - samples.begin()) - 1;
}

// Linear interpolation of an IMU's gyro and accelerometer at t; false outside its span.
bool InterpolateImu(const std::vector<ImuSample>& imu, double t, Eigen::Vector3d* w,
                    Eigen::Vector3d* a) {
  const long i = Bracket(imu, t);
  if (i < 0 || i + 1 >= static_cast<long>(imu.size()))
    return false;
  const ImuSample& s0 = imu[static_cast<std::size_t>(i)];
  const ImuSample& s1 = imu[static_cast<std::size_t>(i + 1)];
  const double t0 = InitSeconds(s0.t_ns), t1 = InitSeconds(s1.t_ns);
  const double u = (t - t0) / (t1 - t0);
  if (w)
    *w = (1.0 - u) * s0.w_m + u * s1.w_m;
  if (a)
    *a = (1.0 - u) * s0.a_m + u * s1.a_m;
  return true;
}

// R_W_C at camera time t by slerp between the two views around it (at most 1.5 median frame
// periods apart); false elsewhere.
bool InterpolateCameraRotation(const std::vector<BoardView>& views, double max_gap, double t,
                               Eigen::Quaterniond* q_W_C) {
  const long i = Bracket(views, t);
  if (i < 0 || i + 1 >= static_cast<long>(views.size()))
    return false;
  const BoardView& v0 = views[static_cast<std::size_t>(i)];
  const BoardView& v1 = views[static_cast<std::size_t>(i + 1)];
  const double t0 = InitSeconds(v0.t_ns), t1 = InitSeconds(v1.t_ns);
  if (t1 - t0 > max_gap)
    return false;
  const Eigen::Quaterniond q0(v0.T_C_W.linear().transpose());
  const Eigen::Quaterniond q1(v1.T_C_W.linear().transpose());
  *q_W_C = q0.slerp((t - t0) / (t1 - t0), q1);
  return true;
}

// Velocity of the camera centre at camera time t: the slope of a quadratic least-squares fit of
// p_W_C over the views within `half_window` s of t; false with fewer than 4 such views.
bool CameraVelocity(const std::vector<BoardView>& views, double t, double half_window,
                    Eigen::Vector3d* v_W) {
  Eigen::Matrix3d AtA = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d Atp = Eigen::Matrix3d::Zero();  // one column per coordinate
  int n = 0;
  for (const BoardView& view : views) {
    const double dt = InitSeconds(view.t_ns) - t;
    if (std::abs(dt) > half_window)
      continue;
    const Eigen::Vector3d p_W_C = view.T_C_W.inverse().translation();
    const Eigen::Vector3d a(1.0, dt, dt * dt);
    AtA += a * a.transpose();
    Atp += a * p_W_C.transpose();
    ++n;
  }
  if (n < 4)
    return false;
  const Eigen::Matrix3d coeffs = AtA.ldlt().solve(Atp);
  *v_W = coeffs.row(1).transpose();
  return v_W->allFinite();
}

double MedianFramePeriod(const std::vector<BoardView>& views) {
  std::vector<double> gaps;
  for (std::size_t k = 1; k < views.size(); ++k)
    gaps.push_back(InitSeconds(views[k].t_ns) - InitSeconds(views[k - 1].t_ns));
  if (gaps.empty())
    return 0.0;
  std::nth_element(gaps.begin(), gaps.begin() + static_cast<long>(gaps.size() / 2), gaps.end());
  return gaps[gaps.size() / 2];
}

}  // namespace

HandEyeResult InitRotationHandEye(const std::string& sensor_name,
                                  const std::vector<RateSample>& base_rates,
                                  const std::vector<RateSample>& sensor_rates, double time_offset,
                                  const HandEyeOptions& options, const InitLog& log) {
  return InitRotationHandEye(sensor_name, BaseRateIntegral(base_rates), sensor_rates, time_offset,
                             options, log);
}

HandEyeResult InitRotationHandEye(const std::string& sensor_name, const BaseRateIntegral& base,
                                  const std::vector<RateSample>& sensor_rates, double time_offset,
                                  const HandEyeOptions& options, const InitLog& log) {
  constexpr const char* kStage = "hand-eye rotation";
  std::vector<Eigen::Vector3d> w_B, w_S;
  std::size_t cursor = 0;
  for (const RateSample& r : sensor_rates) {
    const double t = InitSeconds(r.t_ns) + time_offset;
    Eigen::Vector3d w;
    if (!base.RateOver(t - 0.5 * r.span, t + 0.5 * r.span, &w, &cursor))
      continue;
    w_B.push_back(w);
    w_S.push_back(r.w_S);
  }
  const int n = static_cast<int>(w_B.size());
  if (n < options.min_pairs)
    throw InitError(
        kStage, sensor_name,
        FormatInitLine("only %d rate pairs overlap the base gyroscope at time offset %+.1f ms "
                       "(need %d)",
                       n, time_offset * 1e3, options.min_pairs));

  HandEyeResult result;
  result.pairs = n;
  std::vector<double> weight(static_cast<std::size_t>(n), 1.0);
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  // The weighted sums of the next iteration's means, accumulated where the weights are set (the
  // same sums in the same order as a pass of their own); the first iteration's weights are 1.
  double sw = static_cast<double>(n);
  Eigen::Vector3d sum_B = Eigen::Vector3d::Zero(), sum_S = Eigen::Vector3d::Zero();
  for (int k = 0; k < n; ++k) {
    sum_B += w_B[static_cast<std::size_t>(k)];
    sum_S += w_S[static_cast<std::size_t>(k)];
  }
  for (int iteration = 0; iteration < 8; ++iteration) {
    // For a fixed R the best c is the weighted mean of w_B - R w_S, so centring both sides by
    // their weighted means leaves a weighted orthogonal Procrustes problem (Kabsch).
    const Eigen::Vector3d mean_B = sum_B / sw, mean_S = sum_S / sw;
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    for (int k = 0; k < n; ++k)
      H += weight[static_cast<std::size_t>(k)] * (w_B[static_cast<std::size_t>(k)] - mean_B) *
           (w_S[static_cast<std::size_t>(k)] - mean_S).transpose();
    // Dynamic size: GCC 12 misreads the fixed-size SVD's SSE loads as uninitialised.
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(Eigen::MatrixXd(H),
                                                Eigen::ComputeFullU | Eigen::ComputeFullV);
    const Eigen::Matrix3d U = svd.matrixU();
    const Eigen::Matrix3d V = svd.matrixV();
    Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
    if ((U * V.transpose()).determinant() < 0.0)
      S(2, 2) = -1.0;
    R = U * S * V.transpose();
    c = mean_B - R * mean_S;
    result.singular_values = (Eigen::Vector3d(svd.singularValues()) / sw).cwiseSqrt();
    sw = 0.0;
    sum_B.setZero();
    sum_S.setZero();
    for (int k = 0; k < n; ++k) {
      const Eigen::Vector3d& b = w_B[static_cast<std::size_t>(k)];
      const Eigen::Vector3d& v = w_S[static_cast<std::size_t>(k)];
      const double w = HuberWeight((b - R * v - c).norm(), options.huber_rad_s);
      weight[static_cast<std::size_t>(k)] = w;
      sw += w;
      sum_B += w * b;
      sum_S += w * v;
    }
  }
  double sq = 0.0;
  for (int k = 0; k < n; ++k)
    sq +=
        (w_B[static_cast<std::size_t>(k)] - R * w_S[static_cast<std::size_t>(k)] - c).squaredNorm();
  result.R_B_S = R;
  result.c_B = c;
  result.rms_rad_s = std::sqrt(sq / n);
  // A rotation about one axis only leaves the rotation about that axis free: the second
  // singular value of the rate cross-covariance measures the excitation of a second axis.
  if (result.singular_values[1] < options.min_excitation)
    throw InitError(
        kStage, sensor_name,
        FormatInitLine("rotation excites fewer than two axes (rate spread %.3f, %.3f, %.3f "
                       "rad/s; need >= %.3f on the second)",
                       result.singular_values[0], result.singular_values[1],
                       result.singular_values[2], options.min_excitation));
  const Eigen::AngleAxisd aa(R);
  result.summary =
      sensor_name +
      FormatInitLine(
          ": R_B_S angle %.3f deg about [%.3f %.3f %.3f], bias term c_B [%.4f %.4f %.4f] "
          "rad/s, RMS %.4f rad/s, %d pairs, excitation %.2f/%.2f/%.2f rad/s",
          aa.angle() * 180.0 / M_PI, aa.axis().x(), aa.axis().y(), aa.axis().z(), c.x(), c.y(),
          c.z(), result.rms_rad_s, n, result.singular_values[0], result.singular_values[1],
          result.singular_values[2]);
  if (log)
    log(result.summary);
  return result;
}

LeverArmResult InitLeverArm(const std::string& sensor_name, const std::vector<ImuSample>& base,
                            const std::vector<ImuSample>& sensor, const Eigen::Matrix3d& R_B_S,
                            double time_offset, const LeverArmOptions& options,
                            const InitLog& log) {
  constexpr const char* kStage = "lever arm";
  // Rows: A_k [t_B_S; c_B] = y_k with A_k = [alpha_B]x + [w_B]x^2 | -I and
  // y_k = R_B_S a_S - a_B.
  std::vector<Eigen::Matrix<double, 3, 6>> A;
  std::vector<Eigen::Vector3d> y;
  const double h = options.diff_half_window;
  for (const ImuSample& s : sensor) {
    const double t = InitSeconds(s.t_ns) + time_offset;
    Eigen::Vector3d w_B, a_B, w_minus, w_plus;
    if (!InterpolateImu(base, t, &w_B, &a_B) || !InterpolateImu(base, t - h, &w_minus, nullptr) ||
        !InterpolateImu(base, t + h, &w_plus, nullptr))
      continue;
    const Eigen::Vector3d alpha_B = (w_plus - w_minus) / (2.0 * h);
    Eigen::Matrix<double, 3, 6> row;
    const Eigen::Matrix3d W = Hat<double>(w_B);
    row.leftCols<3>() = Hat<double>(alpha_B) + W * W;
    row.rightCols<3>() = -Eigen::Matrix3d::Identity();
    A.push_back(row);
    y.push_back(R_B_S * s.a_m - a_B);
  }
  const int n = static_cast<int>(A.size());
  if (n < 20)
    throw InitError(
        kStage, sensor_name,
        FormatInitLine("only %d accelerometer samples overlap the base IMU at time offset "
                       "%+.1f ms",
                       n, time_offset * 1e3));
  LeverArmResult result;
  result.samples = n;
  std::vector<double> weight(static_cast<std::size_t>(n), 1.0);
  Eigen::Matrix<double, 6, 1> x = Eigen::Matrix<double, 6, 1>::Zero();
  Eigen::Matrix<double, 6, 6> N;
  for (int iteration = 0; iteration < 6; ++iteration) {
    N.setZero();
    Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
    for (int k = 0; k < n; ++k) {
      const auto& Ak = A[static_cast<std::size_t>(k)];
      N += weight[static_cast<std::size_t>(k)] * Ak.transpose() * Ak;
      b += weight[static_cast<std::size_t>(k)] * Ak.transpose() * y[static_cast<std::size_t>(k)];
    }
    x = N.ldlt().solve(b);
    for (int k = 0; k < n; ++k) {
      const double e = (A[static_cast<std::size_t>(k)] * x - y[static_cast<std::size_t>(k)]).norm();
      weight[static_cast<std::size_t>(k)] = HuberWeight(e, options.huber_m_s2);
    }
  }
  // The excitation of t_B_S: the smallest eigenvalue of its block of the normal matrix, per
  // sample, after c_B is eliminated (a constant rotation rate would be absorbed by c_B).
  const Eigen::Matrix3d Ntt = N.topLeftCorner<3, 3>() - N.topRightCorner<3, 3>() *
                                                            N.bottomRightCorner<3, 3>().inverse() *
                                                            N.bottomLeftCorner<3, 3>();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(Ntt);
  double sq = 0.0;
  for (int k = 0; k < n; ++k)
    sq += (A[static_cast<std::size_t>(k)] * x - y[static_cast<std::size_t>(k)]).squaredNorm();
  result.rms_m_s2 = std::sqrt(sq / (3.0 * n));
  result.t_B_S = x.head<3>();
  result.c_B = x.tail<3>();
  // Unweighted covariance sigma^2 N^-1 with the residual scatter (white-noise assumption).
  const Eigen::Matrix<double, 6, 6> cov = result.rms_m_s2 * result.rms_m_s2 * N.inverse();
  result.sigma_t_B_S = cov.diagonal().head<3>().cwiseSqrt();
  const double min_excitation = std::sqrt(std::max(0.0, eig.eigenvalues()[0] / n));
  if (min_excitation < options.min_excitation)
    throw InitError(
        kStage, sensor_name,
        FormatInitLine("rotation does not excite the lever arm in every direction (%.3f < "
                       "%.3f rad/s^2 on the weakest, t_B_S ~ [%.3f %.3f %.3f] m)",
                       min_excitation, options.min_excitation, x[0], x[1], x[2]));
  result.summary =
      sensor_name + FormatInitLine(
                        ": t_B_S [%.4f %.4f %.4f] m (1-sigma [%.4f %.4f %.4f]), accel bias term "
                        "[%.3f %.3f %.3f] m/s^2, RMS %.3f m/s^2, %d samples",
                        x[0], x[1], x[2], result.sigma_t_B_S[0], result.sigma_t_B_S[1],
                        result.sigma_t_B_S[2], x[3], x[4], x[5], result.rms_m_s2, n);
  if (log)
    log(result.summary);
  return result;
}

GravityResult InitGravity(const std::string& base_name, const std::vector<ImuSample>& base,
                          const std::string& camera_name, const std::vector<BoardView>& views,
                          const Eigen::Matrix3d& R_B_C, double cam_time_offset,
                          double gravity_magnitude, const GravityOptions& options,
                          const InitLog& log) {
  constexpr const char* kStage = "gravity";
  const double max_gap = 1.5 * MedianFramePeriod(views);
  // -R_W_B a_B = g_W - acc_W per base sample under the camera's views.
  std::vector<double> t;
  std::vector<Eigen::Vector3d> g;
  std::vector<double> a_norm;
  for (const ImuSample& s : base) {
    const double t_B = InitSeconds(s.t_ns);
    Eigen::Quaterniond q_W_C;
    if (!InterpolateCameraRotation(views, max_gap, t_B - cam_time_offset, &q_W_C))
      continue;
    const Eigen::Matrix3d R_W_B = q_W_C.toRotationMatrix() * R_B_C.transpose();
    t.push_back(t_B);
    g.push_back(-(R_W_B * s.a_m));
    a_norm.push_back(s.a_m.norm());
  }
  const int n = static_cast<int>(g.size());
  if (n < options.min_samples)
    throw InitError(kStage, base_name,
                    FormatInitLine("only %d accelerometer samples lie between views of camera '%s'",
                                   n, camera_name.c_str()));
  // The span to average: everything, or the window with the least accelerometer scatter.
  std::size_t first = 0, last = g.size();
  if (options.method == GravityOptions::Method::kLowMotionWindow) {
    double best = std::numeric_limits<double>::infinity();
    std::size_t j = 0;
    double s1 = 0, s2 = 0;
    for (std::size_t i = 0; i < g.size(); ++i) {
      // Window [i, j) covering `window` seconds; running sums of |a|.
      while (j < g.size() && t[j] - t[i] < options.window) {
        s1 += a_norm[j];
        s2 += a_norm[j] * a_norm[j];
        ++j;
      }
      const double m = static_cast<double>(j - i);
      if (t[j - 1] - t[i] >= 0.9 * options.window && m >= options.min_samples) {
        const double var = s2 / m - (s1 / m) * (s1 / m);
        if (var < best) {
          best = var;
          first = i;
          last = j;
        }
      }
      s1 -= a_norm[i];
      s2 -= a_norm[i] * a_norm[i];
    }
    if (!std::isfinite(best))
      throw InitError(
          kStage, base_name,
          FormatInitLine("no %.1f s window of accelerometer samples under camera '%s' views",
                         options.window, camera_name.c_str()));
  }
  // Samples are at the IMU's (uniform) rate, so their plain mean is the time average.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  double s1 = 0, s2 = 0;
  for (std::size_t i = first; i < last; ++i) {
    mean += g[i];
    s1 += a_norm[i];
    s2 += a_norm[i] * a_norm[i];
  }
  const double m = static_cast<double>(last - first);
  mean /= m;
  // The mean of acc_W over the span is (v(t1) - v(t0)) / T, not zero: a hand-held wave ends at
  // ~0.5 m/s, 0.04 m/s^2 or 0.25 deg of tilt over 12 s. The camera's velocity at both ends
  // removes it (the lever arm's w x r is a few cm/s, under 0.02 deg here).
  Eigen::Vector3d v0, v1;
  const double half_window = 5.0 * MedianFramePeriod(views);
  if (t[last - 1] > t[first] &&
      CameraVelocity(views, t[first] - cam_time_offset, half_window, &v0) &&
      CameraVelocity(views, t[last - 1] - cam_time_offset, half_window, &v1))
    mean += (v1 - v0) / (t[last - 1] - t[first]);
  GravityResult result;
  result.samples = static_cast<int>(m);
  result.t0 = t[first];
  result.t1 = t[last - 1];
  result.accel_std = std::sqrt(std::max(0.0, s2 / m - (s1 / m) * (s1 / m)));
  if (mean.norm() < 0.5 * gravity_magnitude)
    throw InitError(
        kStage, base_name,
        FormatInitLine("mean specific force %.2f m/s^2 is far below gravity %.2f: the camera "
                       "orientation or the rig's R_B_C of '%s' is inconsistent",
                       mean.norm(), gravity_magnitude, camera_name.c_str()));
  result.g_W = gravity_magnitude * mean.normalized();
  result.summary =
      base_name + FormatInitLine(
                      ": g_W [%.4f %.4f %.4f] m/s^2 (mean |f| %.3f) from %.1f-%.1f s, %d "
                      "samples, |a| std %.3f m/s^2",
                      result.g_W.x(), result.g_W.y(), result.g_W.z(), mean.norm(), result.t0,
                      result.t1, result.samples, result.accel_std);
  if (log)
    log(result.summary);
  return result;
}

}  // namespace ctcal
