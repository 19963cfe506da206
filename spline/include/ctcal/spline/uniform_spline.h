// What every uniform spline class shares: knot timing, number of knots, and the mapping from a time
// to its segment. The index arithmetic lives here (and in KnotTiming::Locate) and nowhere else.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

#include "ctcal/spline/bspline_basis.h"

namespace ctcal {

template <int N>
class UniformSpline {
 public:
  static constexpr int kOrder = N;

  UniformSpline(KnotTiming timing, int num_knots) : timing_(timing), num_knots_(num_knots) {
    if (timing.dt_ns <= 0) {
      throw std::invalid_argument("spline knot spacing must be positive, got dt_ns = " +
                                  std::to_string(timing.dt_ns));
    }
    if (num_knots < N) {
      throw std::invalid_argument("a spline of order " + std::to_string(N) + " needs at least " +
                                  std::to_string(N) + " knots, got " + std::to_string(num_knots));
    }
  }

  const KnotTiming& timing() const { return timing_; }
  int NumKnots() const { return num_knots_; }
  int NumSegments() const { return num_knots_ - N + 1; }
  std::int64_t MinTimeNs() const { return timing_.t0_ns; }
  std::int64_t MaxTimeNs() const { return timing_.t0_ns + NumSegments() * timing_.dt_ns; }

  // The segment of t = t_ns + offset_s: control points first_index .. first_index + N - 1 and
  // u in [0, 1]. Returns false outside [MinTimeNs(), MaxTimeNs()] (e.g. inside a Ceres residual
  // whose time offset moved the sample off the spline: the residual should then fail, not crash).
  template <typename T>
  bool ComputeIndex(std::int64_t t_ns, const T& offset_s, SegmentLocation<T>* location) const {
    return timing_.Locate(t_ns, offset_s, NumSegments(), location);
  }

  // As ComputeIndex, for callers that consider an out-of-range time a programming error.
  SegmentLocation<double> ComputeIndexOrThrow(std::int64_t t_ns, double offset_s = 0.0) const {
    SegmentLocation<double> location;
    if (!ComputeIndex(t_ns, offset_s, &location)) {
      throw std::out_of_range("spline evaluated at t = " + std::to_string(t_ns) + " ns + " +
                              std::to_string(offset_s) + " s, outside its time range [" +
                              std::to_string(MinTimeNs()) + ", " + std::to_string(MaxTimeNs()) +
                              "] ns");
    }
    return location;
  }

  // Centre of the support of knot k, a natural time at which to initialise it from data.
  std::int64_t KnotCentreTimeNs(int k) const {
    // Knot k influences segments k-N+1 .. k, i.e. [t0 + (k-N+1) dt, t0 + (k+1) dt].
    return timing_.t0_ns + ((2 * k - N + 2) * timing_.dt_ns) / 2;
  }

 private:
  KnotTiming timing_;
  int num_knots_;
};

}  // namespace ctcal
