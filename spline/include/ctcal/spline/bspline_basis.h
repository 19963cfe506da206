// Uniform B-spline basis of order N (degree N-1) in cumulative form, and the one place where a time
// becomes (first control point index, normalised time u). See docs/spline.md for the derivation.
//
// On a segment with local control points p_0 .. p_{N-1} and u in [0, 1]:
//   p(u) = sum_j b_j(u) p_j = p_0 + sum_{j>=1} lambda_j(u) (p_j - p_{j-1}),
//   b_j(u) = sum_k M(k, j) u^k            (blending matrix of Qin 2000, row = power of u),
//   lambda_j(u) = sum_{s>=j} b_s(u)        (cumulative basis, lambda_0 = 1).
// Time derivatives: d/dt = inv_dt * d/du with inv_dt = 1 / dt in 1/s.
#pragma once

#include <ceres/jet.h>

#include <array>
#include <cmath>
#include <cstdint>

namespace ctcal {

// The value part of a scalar (the real part of a ceres::Jet), for branching and indexing.
inline double ScalarPart(double x) {
  return x;
}
template <typename S, int K>
double ScalarPart(const ceres::Jet<S, K>& x) {
  return ScalarPart(x.a);
}

namespace internal {

constexpr double Binomial(int n, int k) {
  double r = 1.0;
  for (int i = 1; i <= k; ++i)
    r = r * (n - k + i) / i;
  return r;
}

constexpr double IntPow(double x, int e) {
  double r = 1.0;
  for (int i = 0; i < e; ++i)
    r *= x;
  return r;
}

constexpr double Factorial(int n) {
  double r = 1.0;
  for (int i = 2; i <= n; ++i)
    r *= i;
  return r;
}

// Qin (2000), "General matrix representations for B-splines":
//   M(i, j) = 1/(N-1)! C(N-1, i) sum_{s=j}^{N-1} (-1)^(s-j) C(N, s-j) (N-s-1)^(N-1-i).
template <int N>
constexpr std::array<std::array<double, N>, N> BlendingMatrix() {
  std::array<std::array<double, N>, N> m{};
  for (int i = 0; i < N; ++i) {
    for (int j = 0; j < N; ++j) {
      double sum = 0.0;
      for (int s = j; s < N; ++s) {
        const double sign = ((s - j) % 2 == 0) ? 1.0 : -1.0;
        sum += sign * Binomial(N, s - j) * IntPow(N - s - 1, N - 1 - i);
      }
      m[i][j] = Binomial(N - 1, i) * sum / Factorial(N - 1);
    }
  }
  return m;
}

// C(j, k): lambda_j(u) = sum_k C(j, k) u^k.
template <int N>
constexpr std::array<std::array<double, N>, N> CumulativeCoefficients() {
  const auto m = BlendingMatrix<N>();
  std::array<std::array<double, N>, N> c{};
  for (int j = 0; j < N; ++j) {
    for (int k = 0; k < N; ++k) {
      double sum = 0.0;
      for (int s = j; s < N; ++s)
        sum += m[k][s];
      c[j][k] = sum;
    }
  }
  return c;
}

}  // namespace internal

// Highest time derivative any evaluation needs: value, velocity, acceleration, jerk (jerk is the
// time derivative of the acceleration, needed for d(specific force)/d(time offset)).
inline constexpr int kMaxDerivative = 3;

template <int N>
struct CumulativeBasis {
  static_assert(N >= 2, "a B-spline needs order >= 2");
  static constexpr std::array<std::array<double, N>, N> kBlending = internal::BlendingMatrix<N>();
  static constexpr std::array<std::array<double, N>, N> kCumulative =
      internal::CumulativeCoefficients<N>();

  // lambda[k][j] = d^k lambda_j / dt^k for k = 0 .. max_derivative (time, not u: inv_dt applied).
  template <typename T>
  static void Evaluate(const T& u, const T& inv_dt, int max_derivative,
                       std::array<std::array<T, N>, kMaxDerivative + 1>* lambda) {
    // d^k/du^k u^i = i!/(i-k)! u^(i-k): build the power vector once, differentiate it k times.
    std::array<T, N> powers;
    powers[0] = T(1);
    for (int i = 1; i < N; ++i)
      powers[i] = powers[i - 1] * u;
    T scale = T(1);
    for (int k = 0; k <= max_derivative; ++k) {
      for (int j = 0; j < N; ++j) {
        T sum = T(0);
        for (int i = k; i < N; ++i) {
          sum += (kCumulative[j][i] * internal::Factorial(i) / internal::Factorial(i - k)) *
                 powers[i - k];
        }
        (*lambda)[k][j] = sum * scale;
      }
      scale = scale * inv_dt;
    }
  }
};

// Where a time falls on a uniform spline: control points first_index .. first_index + N - 1,
// normalised time u in [0, 1], and 1/dt (s^-1) to turn d/du into d/dt.
template <typename T>
struct SegmentLocation {
  int first_index = 0;
  T u = T(0);
  T inv_dt = T(0);
};

// Knot timing of a uniform spline: the segment of control points 0..N-1 starts at t0_ns and every
// segment lasts dt_ns. Times are int64 nanoseconds so that long recordings keep ns resolution; a
// differentiable offset in seconds (double or Jet: time offsets, rolling-shutter line times) is
// added on top without ever forming t_ns as a double.
struct KnotTiming {
  std::int64_t t0_ns = 0;
  std::int64_t dt_ns = 1;

  double dt_s() const { return 1e-9 * static_cast<double>(dt_ns); }

  // Segment of t = t_ns + offset_s on a spline with num_segments segments. Returns false when t
  // lies outside [t0, t0 + num_segments * dt]; the end point belongs to the last segment (u = 1).
  template <typename T>
  bool Locate(std::int64_t t_ns, const T& offset_s, int num_segments,
              SegmentLocation<T>* location) const {
    const std::int64_t rel_ns = t_ns - t0_ns;
    // Floor division in integers keeps the index exact for any recording length.
    std::int64_t index = rel_ns / dt_ns;
    if (rel_ns % dt_ns != 0 && rel_ns < 0)
      --index;
    const double inv_dt = 1.0 / dt_s();
    T u = T(static_cast<double>(rel_ns - index * dt_ns) / static_cast<double>(dt_ns)) +
          offset_s * inv_dt;
    const double shift = std::floor(ScalarPart(u));
    index += static_cast<std::int64_t>(shift);
    u -= T(shift);
    if (index == num_segments && ScalarPart(u) == 0.0) {
      index = num_segments - 1;
      u += T(1);
    }
    if (index < 0 || index >= num_segments)
      return false;
    location->first_index = static_cast<int>(index);
    location->u = u;
    location->inv_dt = T(inv_dt);
    return true;
  }
};

}  // namespace ctcal
