// A lens model of libmrcal (`camera_model: mrcal`, docs/camera_models.md): the name, parameter
// count, projection with gradients and unprojection all come from mrcal's C API (mrcal_project,
// mrcal_unproject), so ctcal carries no copy of mrcal's formulas. Every lens model mrcal 2.2 has
// is accepted: LENSMODEL_PINHOLE, STEREOGRAPHIC, LONLAT, LATLON, OPENCV4/5/8/12, CAHVOR, CAHVORE
// (projection only: mrcal gives it no gradients and no unprojection) and
// SPLINED_STEREOGRAPHIC_order=.._Nx=.._Ny=.._fov_x_deg=...
//
// Parameters: mrcal's intrinsics vector, core (fx, fy, cx, cy) first for every model that has
// one, then the distortions; pixel (0,0) is the centre of the top-left pixel, as in SPEC.
//
// The type is opaque (mrcal.h stays out of ctcal's headers) and immutable: CameraModel shares it.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

namespace ctcal {

class MrcalLens {
 public:
  // From mrcal's lens model name; throws std::invalid_argument naming the name and, for an unknown
  // one, the accepted families.
  static std::shared_ptr<const MrcalLens> FromName(const std::string& lensmodel);
  ~MrcalLens();

  // The full (configured) name, as mrcal writes it.
  const std::string& name() const { return name_; }
  int NumParams() const { return num_params_; }
  // Whether mrcal computes gradients for the model (all but CAHVORE): the calibrator needs them.
  bool HasGradients() const;
  // LENSMODEL_SPLINED_STEREOGRAPHIC_...: its control points are regularised (Regularization).
  bool IsSplined() const;
  // Whether the first four parameters are fx, fy, cx, cy (every mrcal model but CAHVOR(E), which
  // have them too: mrcal's "core" is present in all 2.2 models).
  bool HasCore() const;

  // Parameter symbols: fx fy cx cy, then OpenCV's k1 k2 p1 p2 k3 ..., CAHVOR's alpha beta r0 r1
  // r2 (+ e0 e1 e2), or the spline's "x[ix,iy]" / "y[ix,iy]" control points.
  std::vector<std::string> ParamNames() const;

  // mrcal_project with its gradients (either may be nullptr; J_uv_params is 2 x NumParams()).
  // False where the point is outside the model's domain: z <= 0 for the pinhole-like models
  // (pinhole, OpenCV, CAHVOR(E)), the -z axis for the stereographic ones, beyond the spline's
  // knots for a splined model (mrcal extrapolates there, a meaningless value), or a non-finite
  // result.
  bool Project(const double* params, const Eigen::Vector3d& p_C, Eigen::Vector2d* uv,
               Eigen::Matrix<double, 2, 3>* J_uv_p = nullptr,
               Eigen::Matrix<double, 2, Eigen::Dynamic>* J_uv_params = nullptr) const;
  // mrcal_unproject, normalised; false when mrcal fails or the ray does not project back onto
  // the pixel within 1e-6 px (the check every ctcal unprojection ends with).
  bool Unproject(const double* params, const Eigen::Vector2d& uv, Eigen::Vector3d* ray_C) const;
  // Finite parameters and positive focal lengths; why says which fails.
  bool CheckParams(const double* params, std::string* why) const;

  // mrcal's regularisation (its optimizer's scheme, reimplemented for Ceres): one whitened
  // residual per distortion parameter, w_d * d_j, and per centre coordinate,
  // w_c * (c - (size - 1) / 2), with the weights chosen so that at a typical distortion value
  // (0.2) and centre offset (50 px) each group adds 0.25 % of the expected cost of the
  // `num_measurements` whitened corner residuals (whose expected square is 1 each). Rational
  // OpenCV denominators (k4..k6 of OPENCV8/12) get 5 w_d: a common factor of numerator and
  // denominator would otherwise leave 0/0. Without it a splined model's control points outside
  // the observed area, and the core's trade against them, are undetermined.
  struct Regularization {
    Eigen::VectorXd weight;  // per parameter; 0 where not regularised
    Eigen::VectorXd target;  // the value each weighted parameter is pulled to
  };
  Regularization MakeRegularization(const Eigen::Vector2i& resolution,
                                    double num_measurements) const;

 private:
  struct Impl;
  explicit MrcalLens(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
  std::string name_;
  int num_params_ = 0;
};

}  // namespace ctcal
