// Uniform cumulative B-spline on SO(3): orientation R_W_B(t), body angular velocity w_B, body
// angular acceleration and its time derivative, with Jacobians with respect to the N local knots.
//
// Knots: Ceres blocks of 4 doubles, an Eigen quaternion (x, y, z, w) R_W_Bk. Perturbation: RIGHT,
// R_k = R_k_hat * Exp(delta_k) (delta in the knot's body frame), manifold So3RightManifold. The
// Jacobian of the orientation is of its right perturbation too: R(t) = R_hat(t) * Exp(J delta).
// The Jacobian with respect to time of each quantity is the next derivative (d R/dt = w_B in the
// same right tangent, d w_B/dt = alpha_B, d alpha_B/dt = dalpha_B).
#pragma once

#include <Eigen/Geometry>
#include <vector>

#include "ctcal/spline/cumulative_lie_segment.h"
#include "ctcal/spline/uniform_spline.h"

namespace ctcal {

template <int N>
class So3Spline : public UniformSpline<N> {
 public:
  using Segment = CumulativeLieSegment<So3Group, N>;
  template <typename T>
  using Output = typename Segment::template Output<T>;  // value = R_W_B, velocity = w_B, ...
  template <typename T>
  using Jacobians = typename Segment::template Jacobians<T>;

  // Segment level: knots[i] -> 4 doubles of local knot i. See CumulativeLieSegment::Evaluate.
  template <typename T>
  static void EvaluateSegment(const T* const* knots, const T& u, const T& inv_dt,
                              int max_derivative, bool want_value, Output<T>* out,
                              const Jacobians<T>* J = nullptr) {
    Segment::Evaluate(knots, u, inv_dt, max_derivative, want_value, out, J);
  }

  So3Spline(KnotTiming timing, std::vector<Eigen::Quaterniond> knots)
      : UniformSpline<N>(timing, static_cast<int>(knots.size())), knots_(std::move(knots)) {}
  So3Spline(KnotTiming timing, int num_knots)
      : So3Spline(timing,
                  std::vector<Eigen::Quaterniond>(num_knots, Eigen::Quaterniond::Identity())) {}

  Eigen::Quaterniond& Knot(int i) { return knots_.at(i); }
  const Eigen::Quaterniond& Knot(int i) const { return knots_.at(i); }
  double* KnotData(int i) { return knots_.at(i).coeffs().data(); }

  // Class level: everything up to max_derivative at t_ns + offset_s (throws std::out_of_range
  // outside the spline); first_index receives the first knot of the local support.
  void Evaluate(std::int64_t t_ns, double offset_s, int max_derivative, Output<double>* out,
                const Jacobians<double>* J = nullptr, int* first_index = nullptr) const {
    const SegmentLocation<double> loc = this->ComputeIndexOrThrow(t_ns, offset_s);
    if (first_index != nullptr)
      *first_index = loc.first_index;
    std::array<const double*, N> local;
    for (int i = 0; i < N; ++i)
      local[i] = knots_[loc.first_index + i].coeffs().data();
    Segment::Evaluate(local.data(), loc.u, loc.inv_dt, max_derivative, true, out, J);
  }

  Eigen::Quaterniond Orientation(std::int64_t t_ns) const {
    Output<double> out;
    Evaluate(t_ns, 0.0, 0, &out);
    return Eigen::Quaterniond(out.value);
  }
  Eigen::Vector3d AngularVelocity(std::int64_t t_ns) const {
    Output<double> out;
    Evaluate(t_ns, 0.0, 1, &out);
    return out.velocity;
  }
  Eigen::Vector3d AngularAcceleration(std::int64_t t_ns) const {
    Output<double> out;
    Evaluate(t_ns, 0.0, 2, &out);
    return out.acceleration;
  }

 private:
  std::vector<Eigen::Quaterniond> knots_;
};

}  // namespace ctcal
