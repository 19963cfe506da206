// Shared helpers of the spline tests: random knots, central differences on manifolds.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <functional>
#include <random>
#include <vector>

#include "ctcal/spline/se3.h"

namespace ctcal::testing {

// Random unit quaternion within `angle` (rad) of `q_around`, right-multiplied.
inline Eigen::Quaterniond RandomRotation(
    std::mt19937* rng, double angle,
    const Eigen::Quaterniond& q_around = Eigen::Quaterniond::Identity()) {
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  const Eigen::Vector3d axis(uni(*rng), uni(*rng), uni(*rng));
  const Eigen::Vector3d phi = axis.normalized() * angle * std::abs(uni(*rng));
  return (q_around * ExpSO3<double>(phi)).normalized();
}

inline Eigen::Vector3d RandomVector(std::mt19937* rng, double scale) {
  std::uniform_real_distribution<double> uni(-scale, scale);
  return Eigen::Vector3d(uni(*rng), uni(*rng), uni(*rng));
}

// Central difference of f: R^n -> R^m at 0, f(0) subtracted implicitly by symmetry.
inline Eigen::MatrixXd CentralDifference(
    const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& f, int n, double h = 1e-6) {
  Eigen::MatrixXd J;
  for (int k = 0; k < n; ++k) {
    Eigen::VectorXd d = Eigen::VectorXd::Zero(n);
    d[k] = h;
    const Eigen::VectorXd fp = f(d);
    const Eigen::VectorXd fm = f(-d);
    if (k == 0)
      J.resize(fp.size(), n);
    J.col(k) = (fp - fm) / (2 * h);
  }
  return J;
}

// Largest absolute entry of a - b relative to max(1, largest entry of b).
inline double RelativeError(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).cwiseAbs().maxCoeff() / std::max(1.0, b.cwiseAbs().maxCoeff());
}

}  // namespace ctcal::testing
