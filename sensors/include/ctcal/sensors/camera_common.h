// Pieces shared by the camera projection models (camera_pinhole.h, camera_omni.h,
// camera_double_sphere.h, camera_eucm.h): the model enumeration, the Jacobian out-pointer type and
// the final check of every unprojection.
//
// Conventions of SPEC sections 1, 2 and 4: camera frame x right, y down, z forward; pixel (0,0)
// is the centre of the top-left pixel, so the image covers [-0.5, width-0.5] x [-0.5, height-0.5].
// A model's parameter vector is its Kalibr `intrinsics` followed by its `distortion_coeffs`, one
// contiguous block (one Ceres parameter block per camera).
#pragma once

#include <Eigen/Core>
#include <limits>
#include <type_traits>

namespace ctcal {

// Every (camera_model, distortion_model) pair of SPEC section 4, and kMrcal: any lens model of
// libmrcal (`camera_model: mrcal` with its `lensmodel:`, docs/camera_models.md), whose parameter
// count is known at run time only (mrcal_lens.h).
enum class CameraModelType {
  kPinholeRadtan,
  kPinholeEquidistant,
  kPinholeNone,
  kOmniRadtan,
  kOmniNone,
  kDoubleSphere,
  kEucm,
  kMrcal,
};

// Out-pointer for a Jacobian d out / d in with the scalar of the call. The scalar sits in a
// non-deduced context so that a literal nullptr ("don't compute") can be passed.
template <typename T, int Rows, int Cols>
using JacobianPtr = typename std::common_type<Eigen::Matrix<T, Rows, Cols>>::type*;

// Box bounds of a model's parameters for the solver (Ceres' SetParameterLowerBound/UpperBound):
// the closed domain on which the model's formulas hold; +-infinity where a parameter is free.
// Positive focal lengths are not bounded: a solver that drives one through 0 has diverged anyway,
// and CameraModel::SetParams reports it.
inline void FreeBounds(int n, double* lower, double* upper) {
  for (int i = 0; i < n; ++i) {
    lower[i] = -std::numeric_limits<double>::infinity();
    upper[i] = std::numeric_limits<double>::infinity();
  }
}

// Whether every coordinate of a point is finite; written with comparisons so that it works on the
// value of a ceres::Jet as well. Every Project starts with it: a NaN or infinite point is invalid,
// whatever the formula would make of it.
template <typename T>
bool IsFinitePoint(const Eigen::Matrix<T, 3, 1>& p) {
  const T inf(std::numeric_limits<double>::infinity());
  return p(0) > -inf && p(0) < inf && p(1) > -inf && p(1) < inf && p(2) > -inf && p(2) < inf;
}

// Closed-form and iterative unprojections alike end with this check: the ray must project back
// (validly) onto the pixel it came from. It catches a ray on the wrong branch of a model (e.g. the
// second intersection of omni's sphere for xi > 1) and any iteration that stopped early. The
// tolerance is loose on purpose: it separates right from wrong answers; the accuracy of a correct
// one is ~1e-12 px (tests/cameras).
inline constexpr double kUnprojectionCheckPx = 1e-6;

template <class Model>
bool ReprojectsOnto(const double* params, const Eigen::Vector3d& ray_C, const Eigen::Vector2d& uv) {
  Eigen::Vector2d uv_back;
  if (!ray_C.allFinite() || !Model::Project(params, ray_C, &uv_back))
    return false;
  return (uv_back - uv).norm() <= kUnprojectionCheckPx;
}

}  // namespace ctcal
