// The stored forms of the inertial intrinsic matrices (SPEC section 3) and their validation.
//
// An upper-triangular 3x3 matrix is stored as 6 numbers, column by column:
//   [d11, d12, d22, d13, d23, d33]
// (so that the first k(k+1)/2 numbers describe the leading k x k block); a full one as 9 numbers,
// row-major. These arrays are exactly the Ceres parameter blocks of D_w, D_a and T_g, so a
// Jacobian column k belongs to stored entry k.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "ctcal/spline/so3.h"

namespace ctcal {

// kAbsent: the model has no such block (D is the identity, T_g zero).
enum class MatrixForm { kAbsent, kUpper, kFull };

inline constexpr int StoredSize(MatrixForm f) {
  return f == MatrixForm::kUpper ? 6 : (f == MatrixForm::kFull ? 9 : 0);
}

// Row and column of stored entry k (0-based) of a kUpper or kFull matrix.
inline constexpr int StoredRow(MatrixForm f, int k) {
  // Upper, column-wise: k = 0 | 1 2 | 3 4 5  ->  rows 0 | 0 1 | 0 1 2.
  return f == MatrixForm::kFull ? k / 3 : (k < 1 ? 0 : (k < 3 ? k - 1 : k - 3));
}
inline constexpr int StoredCol(MatrixForm f, int k) {
  return f == MatrixForm::kFull ? k % 3 : (k < 1 ? 0 : (k < 3 ? 1 : 2));
}

// The matrix a stored block describes; `absent` is returned for kAbsent (identity for D, zero
// for T_g), so that a model without the block needs no special case.
template <typename T>
Mat3T<T> MatrixFromStored(MatrixForm f, const T* p, const Mat3T<T>& absent) {
  if (f == MatrixForm::kAbsent)
    return absent;
  Mat3T<T> M = Mat3T<T>::Zero();
  for (int k = 0; k < StoredSize(f); ++k)
    M(StoredRow(f, k), StoredCol(f, k)) = p[k];
  return M;
}

// Writes the entries of M that form f stores (the strictly lower part of an upper form is
// dropped; callers check representability with IsRepresentable first).
void StoreMatrix(MatrixForm f, const Eigen::Matrix3d& M, double* p);
std::vector<double> StoredFromMatrix(MatrixForm f, const Eigen::Matrix3d& M);

// D^-1 of a scale matrix in form f (the identity for kAbsent); an upper triangle is inverted in
// closed form (its inverse is again an upper triangle).
Eigen::Matrix3d ScaleMatrixInverse(MatrixForm f, const Eigen::Matrix3d& D);

// True when M has exactly the zero pattern f demands (absent: M equals `absent` exactly).
bool IsRepresentable(MatrixForm f, const Eigen::Matrix3d& M, const Eigen::Matrix3d& absent);

// Human words for a form, used in error messages: "upper-triangular as 6 numbers [d11, ...]".
std::string DescribeForm(MatrixForm f);

// Checks of the stored forms. Each throws std::invalid_argument whose message starts with `key`
// (the rig-file key: "Dw", "Da", "Tg", "R_I_a", ...) so the file reader can prefix file and sensor.
//
// Count and finiteness of a stored vector, then the matrix it describes.
Eigen::Matrix3d CheckedMatrixFromStored(MatrixForm f, const std::vector<double>& stored,
                                        const std::string& key);
// A scale/misalignment matrix D: finite, not singular (smallest singular value above 1e-9 of
// the largest), and orientation-preserving: a positive diagonal for the upper form (that is what
// fixes the frame uniquely), a positive determinant for the full form (a negative one would be a
// reflection, which no frame change can absorb).
void CheckScaleMatrix(MatrixForm f, const Eigen::Matrix3d& D, const std::string& key);
// A rotation matrix: finite, orthonormal to 1e-6 (files carry ~9 digits) and determinant +1.
// Returns its unit quaternion (exact for an exact rotation; for one orthonormal to within the
// tolerance, the normalised quaternion of Eigen's conversion, within about that tolerance of R).
Eigen::Quaterniond CheckedRotation(const Eigen::Matrix3d& R, const std::string& key);

}  // namespace ctcal
