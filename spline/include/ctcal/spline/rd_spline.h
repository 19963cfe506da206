// Uniform B-spline on R^DIM (positions, biases). Knots are plain DIM-vectors (Ceres blocks of DIM
// doubles, no manifold). A Euclidean spline is linear in its knots: p^(k)(t) = sum_i w_i^(k) p_i,
// so the Jacobian of any derivative with respect to knot i is w_i^(k) * I and is returned as the
// N scalars w_i^(k) (w_i = b_i = lambda_i - lambda_{i+1}, differentiated k times in time).
#pragma once

#include <Eigen/Core>
#include <array>
#include <vector>

#include "ctcal/spline/uniform_spline.h"

namespace ctcal {

template <int DIM, int N>
class RdSpline : public UniformSpline<N> {
 public:
  using Vector = Eigen::Matrix<double, DIM, 1>;
  template <typename T>
  using VectorT = Eigen::Matrix<T, DIM, 1>;

  // d^derivative/dt^derivative of the segment (knots[i]: DIM values), and the weights of every
  // local knot (nullptr = not computed): J_value_knot_i = (*weights)[i] * I.
  template <typename T>
  static VectorT<T> EvaluateSegment(const T* const* knots, const T& u, const T& inv_dt,
                                    int derivative, std::array<T, N>* weights = nullptr) {
    std::array<std::array<T, N>, kMaxDerivative + 1> lambda;
    CumulativeBasis<N>::Evaluate(u, inv_dt, derivative, &lambda);
    const std::array<T, N>& l = lambda[derivative];
    VectorT<T> value = VectorT<T>::Zero();
    for (int i = 0; i < N; ++i) {
      const T w = i + 1 < N ? l[i] - l[i + 1] : l[i];
      value += w * Eigen::Map<const VectorT<T>>(knots[i]);
      if (weights != nullptr)
        (*weights)[i] = w;
    }
    return value;
  }

  RdSpline(KnotTiming timing, std::vector<Vector> knots)
      : UniformSpline<N>(timing, static_cast<int>(knots.size())), knots_(std::move(knots)) {}
  RdSpline(KnotTiming timing, int num_knots, const Vector& value = Vector::Zero())
      : RdSpline(timing, std::vector<Vector>(num_knots, value)) {}

  Vector& Knot(int i) { return knots_.at(i); }
  const Vector& Knot(int i) const { return knots_.at(i); }
  double* KnotData(int i) { return knots_.at(i).data(); }

  // Value (derivative = 0) or time derivative at t_ns + offset_s; throws std::out_of_range outside
  // the spline. first_index / weights: the local support (optional).
  Vector Evaluate(std::int64_t t_ns, int derivative = 0, double offset_s = 0.0,
                  int* first_index = nullptr, std::array<double, N>* weights = nullptr) const {
    const SegmentLocation<double> loc = this->ComputeIndexOrThrow(t_ns, offset_s);
    if (first_index != nullptr)
      *first_index = loc.first_index;
    std::array<const double*, N> local;
    for (int i = 0; i < N; ++i)
      local[i] = knots_[loc.first_index + i].data();
    return EvaluateSegment<double>(local.data(), loc.u, loc.inv_dt, derivative, weights);
  }

 private:
  std::vector<Vector> knots_;
};

}  // namespace ctcal
