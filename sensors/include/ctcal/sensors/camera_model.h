// The camera models of SPEC section 4 behind one runtime type, the factory from a rig file's
// fields, the compile-time dispatch for the calibrator's hot path, and the rolling-shutter row
// time of SPEC section 2.
//
// Two ways to use a model:
//  - Hot path (residuals, Ceres autodiff): VisitCameraModel(type, f) calls f with a value of the
//    model's struct (PinholeRadtanModel, ...), whose static Project<T>() is templated on the
//    scalar and whose kNumParams is a compile-time constant, e.g.
//      VisitCameraModel(cam.type(), [&](auto model) {
//        using Model = decltype(model);
//        problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Residual<Model>, 2,
//                                 Model::kNumParams, ...>(...), ...);
//      });
//  - Everything else (I/O, simulation, reports): class CameraModel, which owns the parameters and
//    the resolution and dispatches each call with a switch.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "ctcal/sensors/camera_common.h"
#include "ctcal/sensors/camera_distortion.h"
#include "ctcal/sensors/camera_double_sphere.h"
#include "ctcal/sensors/camera_eucm.h"
#include "ctcal/sensors/camera_omni.h"
#include "ctcal/sensors/camera_pinhole.h"

namespace ctcal {

class MrcalLens;  // mrcal_lens.h

// Calls f(Model{}) for the model struct of `type` and returns its result (all branches must
// return the same type). An mrcal lens (kMrcal) has no compile-time model: callers handle it
// before (CameraModel::mrcal_lens()); reaching here with one is a programming error.
template <typename F>
decltype(auto) VisitCameraModel(CameraModelType type, F&& f) {
  switch (type) {
    case CameraModelType::kPinholeRadtan:
      return std::forward<F>(f)(PinholeRadtanModel{});
    case CameraModelType::kPinholeEquidistant:
      return std::forward<F>(f)(PinholeEquidistantModel{});
    case CameraModelType::kPinholeNone:
      return std::forward<F>(f)(PinholeNoneModel{});
    case CameraModelType::kOmniRadtan:
      return std::forward<F>(f)(OmniRadtanModel{});
    case CameraModelType::kOmniNone:
      return std::forward<F>(f)(OmniNoneModel{});
    case CameraModelType::kDoubleSphere:
      return std::forward<F>(f)(DoubleSphereModel{});
    case CameraModelType::kEucm:
      break;
    case CameraModelType::kMrcal:
      throw std::logic_error(
          "an mrcal lens model has no compile-time camera model (use CameraModel's mrcal path)");
  }
  return std::forward<F>(f)(EucmModel{});
}

// All model types of SPEC section 4 (not kMrcal, which needs a lens model name), for loops in
// tests and tools.
inline constexpr CameraModelType kAllCameraModelTypes[] = {
    CameraModelType::kPinholeRadtan, CameraModelType::kPinholeEquidistant,
    CameraModelType::kPinholeNone,   CameraModelType::kOmniRadtan,
    CameraModelType::kOmniNone,      CameraModelType::kDoubleSphere,
    CameraModelType::kEucm,
};

// (camera_model, distortion_model) -> type; throws std::invalid_argument naming the pair and the
// accepted ones.
CameraModelType ParseCameraModelType(const std::string& camera_model,
                                     const std::string& distortion_model);
// Kalibr's names of a type: "pinhole" / "radtan", ...
std::string CameraModelName(CameraModelType type);
std::string DistortionModelName(CameraModelType type);

// SPEC section 2: a corner measured at pixel row v (its measured v coordinate) of an image
// stamped t_S on the camera's clock was read out at t_S + v * line_delay (line_delay 0 for a
// global shutter). Templated so that line_delay can be a Ceres Jet.
template <typename T>
T RollingShutterRowTime(const T& t_S, double v, const T& line_delay) {
  return t_S + T(v) * line_delay;
}

class CameraModel {
 public:
  // Factory from a rig file's fields (SPEC sections 4, 7). Throws std::invalid_argument with one
  // clear message (unknown names, wrong counts such as "camera model 'pinhole' with distortion
  // 'radtan' needs 4 distortion_coeffs, got 3", parameters outside the model's domain, resolution
  // not positive); callers prefix the file and sensor name.
  static CameraModel Create(const std::string& camera_model, const std::vector<double>& intrinsics,
                            const std::string& distortion_model,
                            const std::vector<double>& distortion_coeffs,
                            const Eigen::Vector2i& resolution);

  // camera_model "mrcal" takes mrcal's lens model name as its distortion_model (the rig file's
  // `lensmodel:` key) and mrcal's whole intrinsics vector (core then distortions) as intrinsics;
  // its distortion_coeffs are empty.

  // params = intrinsics followed by distortion_coeffs (SPEC order); throws like Create.
  // (Not for kMrcal, which needs its lens: Create or the constructor below.)
  CameraModel(CameraModelType type, const Eigen::VectorXd& params,
              const Eigen::Vector2i& resolution);
  // An mrcal camera: its lens and mrcal's intrinsics vector; throws like Create.
  CameraModel(std::shared_ptr<const MrcalLens> lens, const Eigen::VectorXd& params,
              const Eigen::Vector2i& resolution);

  CameraModelType type() const { return type_; }
  std::string camera_model() const { return CameraModelName(type_); }
  // For kMrcal: mrcal's lens model name (LENSMODEL_OPENCV8, ...).
  std::string distortion_model() const;
  // The mrcal lens of a kMrcal camera (projection through libmrcal); nullptr for the others.
  const MrcalLens* mrcal_lens() const { return mrcal_lens_.get(); }
  const std::shared_ptr<const MrcalLens>& shared_mrcal_lens() const { return mrcal_lens_; }

  int NumParams() const { return static_cast<int>(params_.size()); }
  // Length of the `intrinsics` part (the rest are `distortion_coeffs`).
  int NumIntrinsics() const;
  int NumDistortionCoeffs() const { return NumParams() - NumIntrinsics(); }
  // The box on which the model's formulas hold (omni xi >= 0, ds xi in [-1, 1] and alpha in
  // [0, 1], eucm alpha in [0, 1] and beta >= 1e-8; +-inf elsewhere), for Ceres' parameter bounds.
  void ParamBounds(Eigen::VectorXd* lower, Eigen::VectorXd* upper) const;
  // Kalibr's symbol of each parameter ("fu", "xi", "k1", ...), in parameter order.
  std::vector<std::string> ParamNames() const;

  const Eigen::VectorXd& params() const { return params_; }
  // Contiguous storage for a Ceres parameter block; its validity is the caller's business.
  double* mutable_params() { return params_.data(); }
  // Replaces the parameters; throws if the count is wrong or the values are outside the domain.
  void SetParams(const Eigen::VectorXd& params);
  std::vector<double> intrinsics() const;
  std::vector<double> distortion_coeffs() const;

  const Eigen::Vector2i& resolution() const { return resolution_; }
  int width() const { return resolution_.x(); }
  int height() const { return resolution_.y(); }

  // Projects a point of the camera frame; false where the model is not valid (the outputs are
  // then unspecified). Jacobians optional (nullptr = not computed); J_uv_params is resized to
  // 2 x NumParams().
  bool Project(const Eigen::Vector3d& p_C, Eigen::Vector2d* uv,
               Eigen::Matrix<double, 2, 3>* J_uv_p = nullptr,
               Eigen::Matrix<double, 2, Eigen::Dynamic>* J_uv_params = nullptr) const;
  // Unit ray of a pixel; false where the pixel has no (unique) ray in the model's valid region or
  // an iteration did not converge.
  bool Unproject(const Eigen::Vector2d& uv, Eigen::Vector3d* ray_C) const;
  // Whether a pixel lies on the sensor, at least `border` px inside its edges
  // (pixel centres 0 .. width-1, so the sensor spans [-0.5, width - 0.5]).
  bool IsInImage(const Eigen::Vector2d& uv, double border = 0.0) const;

 private:
  CameraModelType type_;
  std::shared_ptr<const MrcalLens> mrcal_lens_;  // kMrcal only
  Eigen::VectorXd params_;
  Eigen::Vector2i resolution_;
};

}  // namespace ctcal
