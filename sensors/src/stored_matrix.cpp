#include "ctcal/sensors/stored_matrix.h"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace ctcal {

namespace {

std::string Num(double x) {
  std::ostringstream s;
  s.precision(9);
  s << x;
  return s.str();
}

const char* const kUpperNames[6] = {"d11", "d12", "d22", "d13", "d23", "d33"};

}  // namespace

void StoreMatrix(MatrixForm f, const Eigen::Matrix3d& M, double* p) {
  for (int k = 0; k < StoredSize(f); ++k)
    p[k] = M(StoredRow(f, k), StoredCol(f, k));
}

std::vector<double> StoredFromMatrix(MatrixForm f, const Eigen::Matrix3d& M) {
  std::vector<double> v(StoredSize(f));
  StoreMatrix(f, M, v.data());
  return v;
}

Eigen::Matrix3d ScaleMatrixInverse(MatrixForm f, const Eigen::Matrix3d& D) {
  if (f == MatrixForm::kAbsent)
    return Eigen::Matrix3d::Identity();
  if (f == MatrixForm::kUpper) {
    // Back substitution written out: the inverse of an upper triangle is an upper triangle.
    const double i11 = 1.0 / D(0, 0), i22 = 1.0 / D(1, 1), i33 = 1.0 / D(2, 2);
    Eigen::Matrix3d T = Eigen::Matrix3d::Zero();
    T(0, 0) = i11;
    T(1, 1) = i22;
    T(2, 2) = i33;
    T(0, 1) = -D(0, 1) * i11 * i22;
    T(1, 2) = -D(1, 2) * i22 * i33;
    T(0, 2) = (D(0, 1) * D(1, 2) - D(0, 2) * D(1, 1)) * i11 * i22 * i33;
    return T;
  }
  return D.inverse();
}

bool IsRepresentable(MatrixForm f, const Eigen::Matrix3d& M, const Eigen::Matrix3d& absent) {
  switch (f) {
    case MatrixForm::kAbsent:
      return M == absent;
    case MatrixForm::kUpper:
      return M(1, 0) == 0.0 && M(2, 0) == 0.0 && M(2, 1) == 0.0;
    case MatrixForm::kFull:
      return true;
  }
  return false;
}

std::string DescribeForm(MatrixForm f) {
  switch (f) {
    case MatrixForm::kAbsent:
      return "absent";
    case MatrixForm::kUpper:
      return "upper-triangular as 6 numbers [d11, d12, d22, d13, d23, d33]";
    case MatrixForm::kFull:
      return "full as 9 numbers, row-major";
  }
  return "?";
}

Eigen::Matrix3d CheckedMatrixFromStored(MatrixForm f, const std::vector<double>& stored,
                                        const std::string& key) {
  if (f == MatrixForm::kAbsent)
    throw std::invalid_argument(key + ": not part of this model");
  if (static_cast<int>(stored.size()) != StoredSize(f)) {
    throw std::invalid_argument(key + ": expected " + std::to_string(StoredSize(f)) + " numbers (" +
                                DescribeForm(f) + "), got " + std::to_string(stored.size()));
  }
  for (int k = 0; k < StoredSize(f); ++k) {
    if (!std::isfinite(stored[k])) {
      const std::string entry =
          f == MatrixForm::kUpper
              ? std::string(kUpperNames[k])
              : "row " + std::to_string(k / 3 + 1) + ", column " + std::to_string(k % 3 + 1);
      throw std::invalid_argument(key + "[" + std::to_string(k) + "] (" + entry +
                                  ") is not finite: " + Num(stored[k]));
    }
  }
  return MatrixFromStored<double>(f, stored.data(), Eigen::Matrix3d::Zero());
}

void CheckScaleMatrix(MatrixForm f, const Eigen::Matrix3d& D, const std::string& key) {
  if (!D.allFinite())
    throw std::invalid_argument(key + ": has a non-finite entry");
  const Eigen::Vector3d s = Eigen::JacobiSVD<Eigen::Matrix3d>(D).singularValues();
  if (!(s(2) > 1e-9 * s(0))) {
    throw std::invalid_argument(key + ": is singular (singular values " + Num(s(0)) + ", " +
                                Num(s(1)) + ", " + Num(s(2)) + "); it must be invertible");
  }
  if (f == MatrixForm::kUpper) {
    for (int i = 0; i < 3; ++i) {
      if (!(D(i, i) > 0.0)) {
        throw std::invalid_argument(
            key + ": diagonal entry d" + std::to_string(i + 1) + std::to_string(i + 1) + " = " +
            Num(D(i, i)) +
            " must be positive (an upper-triangular D with a positive diagonal fixes the frame; "
            "a sign flip would be a reflection)");
      }
    }
  } else if (!(D.determinant() > 0.0)) {
    throw std::invalid_argument(key + ": determinant " + Num(D.determinant()) +
                                " must be positive (a negative one is a reflection)");
  }
}

Eigen::Quaterniond CheckedRotation(const Eigen::Matrix3d& R, const std::string& key) {
  if (!R.allFinite())
    throw std::invalid_argument(key + ": has a non-finite entry");
  const double orthonormality = (R.transpose() * R - Eigen::Matrix3d::Identity()).norm();
  if (!(orthonormality < 1e-6)) {
    throw std::invalid_argument(key + ": is not a rotation (|R^T R - I| = " + Num(orthonormality) +
                                ", tolerance 1e-6)");
  }
  if (!(R.determinant() > 0.0)) {
    throw std::invalid_argument(key + ": is not a rotation (determinant " + Num(R.determinant()) +
                                ", a reflection)");
  }
  // The quaternion of the nearest rotation; Eigen's conversion is exact for an exact rotation.
  Eigen::Quaterniond q(R);
  q.normalize();
  return q;
}

}  // namespace ctcal
