// Shared helpers of the inertial-model tests: random intrinsics and central differences.
#pragma once

#include <Eigen/Core>
#include <random>

#include "ctcal/sensors/imu_intrinsics.h"

namespace ctcal::test {

inline Eigen::Matrix3d RandomMatrix(std::mt19937& rng, double scale) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix3d M;
  for (int i = 0; i < 9; ++i)
    M(i / 3, i % 3) = scale * u(rng);
  return M;
}

inline Eigen::Vector3d RandomVector(std::mt19937& rng, double scale) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  return Eigen::Vector3d(scale * u(rng), scale * u(rng), scale * u(rng));
}

// A rotation of up to ~70 degrees, so the rotation terms are far from their small-angle forms.
inline Eigen::Matrix3d RandomRotation(std::mt19937& rng) {
  return ExpSO3<double>(RandomVector(rng, 0.7)).toRotationMatrix();
}

// D = I + a few percent of scale error and misalignment, in the form f.
inline Eigen::Matrix3d RandomScaleMatrix(std::mt19937& rng, MatrixForm f) {
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity() + RandomMatrix(rng, 0.05);
  if (f == MatrixForm::kUpper)
    D = Eigen::Matrix3d(D.triangularView<Eigen::Upper>());
  return D;
}

inline ImuIntrinsics RandomImuIntrinsics(ImuModel m, GSensitivity g, std::mt19937& rng) {
  ImuIntrinsics x(m, g);
  const ImuModelLayout& L = x.layout();
  if (L.Dw != MatrixForm::kAbsent)
    x.SetD_w(RandomScaleMatrix(rng, L.Dw));
  if (L.Da != MatrixForm::kAbsent)
    x.SetD_a(RandomScaleMatrix(rng, L.Da));
  if (L.Tg != MatrixForm::kAbsent) {
    Eigen::Matrix3d T = RandomMatrix(rng, 0.01);
    if (L.Tg == MatrixForm::kUpper)
      T = Eigen::Matrix3d(T.triangularView<Eigen::Upper>());
    x.SetT_g(T);
  }
  if (L.HasRotation())
    x.SetRotation(RandomRotation(rng));
  return x;
}

// Central differences of f (R^n -> R^m, evaluated through a perturbation callback) with step h:
// perturb(k, +h) / perturb(k, -h) return f at the k-th tangent direction displaced by +-h.
template <int Rows, typename F>
Eigen::Matrix<double, Rows, Eigen::Dynamic> CentralDifferences(int n, double h, F f) {
  Eigen::Matrix<double, Rows, Eigen::Dynamic> J(Rows, n);
  for (int k = 0; k < n; ++k)
    J.col(k) = (f(k, h) - f(k, -h)) / (2.0 * h);
  return J;
}

}  // namespace ctcal::test
