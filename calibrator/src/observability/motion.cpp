// Degenerate-motion detection by chi-square tests on raw inertial readings (see the header and
// docs/observability.md for the statistics).
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <cmath>
#include <map>
#include <optional>
#include <stdexcept>

#include "ctcal/calibrator/observability/motion_primitives.h"

namespace ctcal {
namespace {

// Running sums of the readings (about the first sample, against cancellation), so that the mean
// and covariance of any index range cost O(1): windows and their unions are tested many times.
class RangeMoments {
 public:
  explicit RangeMoments(const std::vector<Eigen::Vector3d>& x) {
    if (x.empty())
      return;
    ref_ = x.front();
    s1_.assign(x.size() + 1, Eigen::Vector3d::Zero());
    s2_.assign(x.size() + 1, Eigen::Matrix3d::Zero());
    for (std::size_t i = 0; i < x.size(); ++i) {
      const Eigen::Vector3d d = x[i] - ref_;
      s1_[i + 1] = s1_[i] + d;
      s2_[i + 1] = s2_[i] + d * d.transpose();
    }
  }
  bool empty() const { return s1_.empty(); }
  Eigen::Vector3d Mean(std::size_t i0, std::size_t i1) const {
    return ref_ + (s1_[i1] - s1_[i0]) / static_cast<double>(i1 - i0);
  }
  // Sample covariance (divided by n - 1).
  Eigen::Matrix3d Covariance(std::size_t i0, std::size_t i1) const {
    const double n = static_cast<double>(i1 - i0);
    const Eigen::Vector3d s = s1_[i1] - s1_[i0];
    return (s2_[i1] - s2_[i0] - s * s.transpose() / n) / (n - 1.0);
  }

 private:
  Eigen::Vector3d ref_ = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> s1_;
  std::vector<Eigen::Matrix3d> s2_;
};

// The tests, one per primitive key; keys 0-2 are per gyroscope axis, 3-5 per accelerometer axis.
enum Key : int {
  kWx = 0,
  kWy = 1,
  kWz = 2,
  kAx = 3,
  kAy = 4,
  kAz = 5,
  kAdir = 6,
  kNoRot = 7,
  kOneAxis = 8,
  kPlane = 9,
  kNumKeys = 10
};

Eigen::Vector3d SignFixed(Eigen::Vector3d u) {
  Eigen::Index i = 0;
  u.cwiseAbs().maxCoeff(&i);
  return u(i) < 0.0 ? Eigen::Vector3d(-u) : u;
}

class Tester {
 public:
  Tester(const InertialSeries& s, const MotionOptions& o, double alpha)
      : s_(s),
        o_(o),
        alpha_(alpha),
        walk_quantile_(boost::math::quantile(
            boost::math::complement(boost::math::chi_squared(1.0), 0.5 * alpha))),
        w_(s.w_m),
        a_(s.a_m) {}

  bool HasAccel() const { return !a_.empty(); }

  // The axis of the primitive when it holds on samples [i0, i1), else nothing.
  std::optional<Eigen::Vector3d> Evaluate(int key, std::size_t i0, std::size_t i1) const {
    const double n = static_cast<double>(i1 - i0);
    const double span = s_.t[i1 - 1] - s_.t[i0];
    const InertialNoise& q = s_.noise;
    // Under H0 a component is white noise (sigma_d^2 per sample) plus a bias walk whose spread
    // about the window mean has its own heavy-tailed law (BiasWalkBound).
    const Noise w{std::pow(q.GyroSampleSigma(), 2), BiasWalkBound(q.gyroscope_random_walk, span)};
    const Eigen::Matrix3d C_w = w_.Covariance(i0, i1);
    Eigen::Matrix3d C_a = Eigen::Matrix3d::Zero();
    Noise a;
    if (HasAccel()) {
      C_a = a_.Covariance(i0, i1);
      a = {std::pow(q.AccelSampleSigma(), 2), BiasWalkBound(q.accelerometer_random_walk, span)};
    }
    const double kappa2 = o_.axis_coupling * o_.axis_coupling;
    // g-sensitivity leaks the specific force's variation into every gyroscope component.
    const double leak_g = o_.g_sensitivity * o_.g_sensitivity * C_a.trace();

    if (key <= kWz) {
      const int j = key;
      const double leak = kappa2 * (C_w.trace() - C_w(j, j)) + leak_g;
      if (!Constant(n, 1, 0.0, C_w(j, j), w, leak))
        return std::nullopt;
      return Eigen::Vector3d::Unit(j);
    }
    if (key <= kAz) {
      if (!HasAccel())
        return std::nullopt;
      const int j = key - kAx;
      const double leak = kappa2 * (C_a.trace() - C_a(j, j));
      if (!Constant(n, 1, 0.0, C_a(j, j), a, leak))
        return std::nullopt;
      return Eigen::Vector3d::Unit(j);
    }
    if (key == kAdir) {
      if (!HasAccel())
        return std::nullopt;
      // Total least squares: the smallest eigenvalue of the covariance is the residual variance
      // about the best plane; fitting its normal costs 2 degrees of freedom.
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(C_a);
      if (!Constant(n, 1, 2.0, eig.eigenvalues()(0), a, 0.0))
        return std::nullopt;
      return SignFixed(eig.eigenvectors().col(0));
    }
    const bool all_constant = Constant(n, 3, 0.0, C_w.trace(), w, 3.0 * leak_g);
    const Eigen::Vector3d mean_w = w_.Mean(i0, i1);
    const bool below_bias = mean_w.norm() <= o_.max_gyro_bias;
    if (key == kNoRot) {
      if (all_constant && below_bias)
        return Eigen::Vector3d::Zero();
      return std::nullopt;
    }
    // kOneAxis and kPlane.
    std::optional<Eigen::Vector3d> axis;
    if (all_constant) {
      // A constant spin about a fixed axis; below a bias it is no rotation at all.
      if (below_bias)
        return std::nullopt;
      axis = SignFixed(mean_w.normalized());
    } else {
      // w_m = b + s(t) u + noise: the two smallest eigenvalues are the scatter about the line,
      // whose direction costs 2 degrees of freedom.
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(C_w);
      const double off_line = eig.eigenvalues()(0) + eig.eigenvalues()(1);
      if (!Constant(n, 2, 2.0, off_line, w, 2.0 * leak_g))
        return std::nullopt;
      axis = SignFixed(eig.eigenvectors().col(2));
    }
    if (key == kOneAxis)
      return axis;
    if (!HasAccel())
      return std::nullopt;
    // Planar: u stays fixed in the world, so the specific force along it is constant.
    const double along = axis->dot(C_a * *axis);
    if (!Constant(n, 1, 0.0, along, a, kappa2 * C_a.trace()))
      return std::nullopt;
    return axis;
  }

 private:
  struct Noise {
    double white = 0.0;  // variance of one sample's white noise
    double walk = 0.0;   // bound on the bias walk's spread about the window mean (variance)
  };

  // The spread v = (1/T) integral (b - mean b)^2 of a Wiener process of density sigma over T is,
  // by its Karhunen-Loeve expansion, sigma^2 T sum_k X_k / (pi k)^2 with X_k ~ chi2(1) (mean
  // sigma^2 T / 6). It is dominated by k = 1, so at tail probability alpha/2 it is bounded by
  // the k = 1 term's quantile plus the mean of the rest.
  double BiasWalkBound(double sigma, double span) const {
    const double kPi2 = M_PI * M_PI;
    return sigma * sigma * span * (walk_quantile_ + kPi2 / 6.0 - 1.0) / kPi2;
  }

  // H0 "constant": `m` components of summed sample variance `variance` over n samples, of
  // which `fitted` degrees of freedom went into a fitted direction, read as white noise (a
  // chi-square of (n-1) m - fitted degrees of freedom, scaled by the white variance plus the
  // leakage) plus at most m bias walks. The two parts share the test's alpha (union bound).
  bool Constant(double n, int m, double fitted, double variance, const Noise& noise,
                double leakage) const {
    const double dof = (n - 1.0) * m - fitted;
    if (dof < 1.0)
      return false;
    const double white_part = (n - 1.0) * (variance - m * noise.walk);
    return white_part <= (m * noise.white + leakage) / m * ChiSquareQuantile(dof);
  }

  double ChiSquareQuantile(double dof) const {
    auto it = quantiles_.find(dof);
    if (it == quantiles_.end()) {
      const boost::math::chi_squared chi2(dof);
      it = quantiles_
               .emplace(dof, boost::math::quantile(boost::math::complement(chi2, 0.5 * alpha_)))
               .first;
    }
    return it->second;
  }

  const InertialSeries& s_;
  const MotionOptions& o_;
  double alpha_;
  double walk_quantile_;
  RangeMoments w_;
  RangeMoments a_;
  mutable std::map<double, double> quantiles_;
};

const char* PrimitiveName(int key) {
  if (key <= kWz)
    return kConstantAngularVelocity;
  if (key <= kAdir)
    return kConstantSpecificForce;
  if (key == kNoRot)
    return kNoRotation;
  if (key == kOneAxis)
    return kOneAxisRotation;
  return kPlanar;
}

// Keys a key is implied by: a reported primitive is dropped when one of these holds over a
// superset of its interval (no rotation implies every angular-velocity primitive, a constant
// axis component of the specific force its direction form, planar motion one-axis rotation).
std::vector<int> ImpliedBy(int key) {
  if (key <= kWz || key == kOneAxis)
    return key == kOneAxis ? std::vector<int>{kNoRot, kPlane} : std::vector<int>{kNoRot};
  if (key == kAdir)
    return {kAx, kAy, kAz};
  if (key == kPlane)
    return {kNoRot};
  return {};
}

struct Found {
  int key;
  std::size_t i0, i1;  // sample range [i0, i1)
  Eigen::Vector3d axis;
};

bool Covers(const Found& outer, const Found& inner) {
  return outer.i0 <= inner.i0 && inner.i1 <= outer.i1;
}

}  // namespace

MotionDetection DetectMotionPrimitives(const InertialSeries& series, const MotionOptions& options) {
  const std::string where = "motion analysis of " + series.sensor + ": ";
  const std::size_t n = series.t.size();
  if (n < 10)
    throw std::invalid_argument(where + "fewer than 10 inertial samples");
  if (series.w_m.size() != n || (!series.a_m.empty() && series.a_m.size() != n))
    throw std::invalid_argument(where + "timestamps and readings differ in length");
  if (!(options.window_s > 0.0) || !(options.false_alarm_probability > 0.0) ||
      !(options.false_alarm_probability < 1.0) || !(options.axis_coupling >= 0.0) ||
      !(options.g_sensitivity >= 0.0) || !(options.max_gyro_bias >= 0.0))
    throw std::invalid_argument(where + "invalid MotionOptions");
  series.noise.Validate(!series.a_m.empty());

  // Windows of window_s advancing by half of it, the last one ending at the last sample.
  std::vector<std::pair<std::size_t, std::size_t>> windows;
  const double t_first = series.t.front();
  const double t_last = series.t.back();
  if (t_last - t_first > options.window_s) {
    for (double t0 = t_first;; t0 += 0.5 * options.window_s) {
      const double t1 = std::min(t0 + options.window_s, t_last);
      const std::size_t i0 =
          std::lower_bound(series.t.begin(), series.t.end(), t1 - options.window_s) -
          series.t.begin();
      const std::size_t i1 =
          std::upper_bound(series.t.begin(), series.t.end(), t1) - series.t.begin();
      if (i1 - i0 >= 10)
        windows.emplace_back(i0, i1);
      if (t1 >= t_last)
        break;
    }
  }

  // Bonferroni: one test per key on the whole recording, on each window, and on each union a
  // segment grows into (at most one per window).
  const double num_tests = kNumKeys * (1.0 + 2.0 * static_cast<double>(windows.size()));
  const Tester tester(series, options, options.false_alarm_probability / num_tests);

  std::vector<Found> whole;
  std::vector<Found> segments;
  for (int key = 0; key < kNumKeys; ++key) {
    if (const auto axis = tester.Evaluate(key, 0, n)) {
      whole.push_back({key, 0, n, *axis});
      continue;
    }
    // Grow a segment from each window where the primitive holds while the union still passes.
    for (std::size_t k = 0; k < windows.size();) {
      auto axis = tester.Evaluate(key, windows[k].first, windows[k].second);
      if (!axis) {
        ++k;
        continue;
      }
      std::size_t end = k;
      while (end + 1 < windows.size()) {
        const auto grown = tester.Evaluate(key, windows[k].first, windows[end + 1].second);
        if (!grown)
          break;
        axis = grown;
        ++end;
      }
      segments.push_back({key, windows[k].first, windows[end].second, *axis});
      k = end + 1;
    }
  }

  const auto implied = [&](const Found& f) {
    for (const int by : ImpliedBy(f.key)) {
      for (const auto* list : {&whole, &segments})
        for (const Found& g : *list)
          if (g.key == by && Covers(g, f))
            return true;
    }
    return false;
  };
  MotionDetection result;
  const auto emit = [&](const std::vector<Found>& list, std::vector<MotionPrimitive>* out) {
    for (const Found& f : list) {
      if (implied(f))
        continue;
      MotionPrimitive p;
      p.primitive = PrimitiveName(f.key);
      p.sensor = series.sensor;
      p.axis = f.axis;
      p.t0 = series.t[f.i0];
      p.t1 = series.t[f.i1 - 1];
      out->push_back(p);
    }
  };
  emit(whole, &result.whole);
  emit(segments, &result.segments);
  return result;
}

}  // namespace ctcal
