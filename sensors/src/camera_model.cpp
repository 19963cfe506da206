#include "ctcal/sensors/camera_model.h"

#include <sstream>
#include <stdexcept>

#include "ctcal/sensors/mrcal_lens.h"

namespace ctcal {

namespace {

struct TypeName {
  CameraModelType type;
  const char* camera_model;
  const char* distortion_model;
};

constexpr TypeName kTypeNames[] = {
    {CameraModelType::kPinholeRadtan, "pinhole", "radtan"},
    {CameraModelType::kPinholeEquidistant, "pinhole", "equidistant"},
    {CameraModelType::kPinholeNone, "pinhole", "none"},
    {CameraModelType::kOmniRadtan, "omni", "radtan"},
    {CameraModelType::kOmniNone, "omni", "none"},
    {CameraModelType::kDoubleSphere, "ds", "none"},
    {CameraModelType::kEucm, "eucm", "none"},
};
// camera_model "mrcal": its distortion_model is mrcal's lens model name (any).
constexpr const char* kMrcalName = "mrcal";

const TypeName& Lookup(CameraModelType type) {
  static const TypeName mrcal{CameraModelType::kMrcal, kMrcalName, "(mrcal lens model)"};
  if (type == CameraModelType::kMrcal)
    return mrcal;
  for (const TypeName& t : kTypeNames)
    if (t.type == type)
      return t;
  throw std::logic_error("unknown CameraModelType");
}

std::string Describe(CameraModelType type) {
  const TypeName& t = Lookup(type);
  return std::string("camera model '") + t.camera_model + "' with distortion '" +
         t.distortion_model + "'";
}

void CheckResolution(const Eigen::Vector2i& resolution) {
  if (resolution.x() <= 0 || resolution.y() <= 0)
    throw std::invalid_argument("camera resolution must be [width, height] > 0, got [" +
                                std::to_string(resolution.x()) + ", " +
                                std::to_string(resolution.y()) + "]");
}

}  // namespace

CameraModelType ParseCameraModelType(const std::string& camera_model,
                                     const std::string& distortion_model) {
  if (camera_model == kMrcalName) {
    MrcalLens::FromName(distortion_model);  // throws for an unknown or unconfigured name
    return CameraModelType::kMrcal;
  }
  bool known_camera = false;
  for (const TypeName& t : kTypeNames) {
    if (camera_model == t.camera_model) {
      known_camera = true;
      if (distortion_model == t.distortion_model)
        return t.type;
    }
  }
  if (!known_camera)
    throw std::invalid_argument("unknown camera_model '" + camera_model +
                                "' (expected pinhole, omni, ds, eucm or mrcal)");
  std::string accepted;
  for (const TypeName& t : kTypeNames) {
    if (camera_model == t.camera_model)
      accepted += (accepted.empty() ? "" : ", ") + std::string(t.distortion_model);
  }
  throw std::invalid_argument("camera model '" + camera_model +
                              "' does not take distortion_model '" + distortion_model +
                              "' (expected " + accepted + ")");
}

std::string CameraModelName(CameraModelType type) {
  return Lookup(type).camera_model;
}
std::string DistortionModelName(CameraModelType type) {
  return Lookup(type).distortion_model;
}

CameraModel CameraModel::Create(const std::string& camera_model,
                                const std::vector<double>& intrinsics,
                                const std::string& distortion_model,
                                const std::vector<double>& distortion_coeffs,
                                const Eigen::Vector2i& resolution) {
  const CameraModelType type = ParseCameraModelType(camera_model, distortion_model);
  if (type == CameraModelType::kMrcal) {
    if (!distortion_coeffs.empty())
      throw std::invalid_argument(
          "camera model 'mrcal' takes all of mrcal's parameters as "
          "intrinsics; distortion_coeffs must be empty, got " +
          std::to_string(distortion_coeffs.size()));
    return CameraModel(MrcalLens::FromName(distortion_model),
                       Eigen::Map<const Eigen::VectorXd>(
                           intrinsics.data(), static_cast<Eigen::Index>(intrinsics.size())),
                       resolution);
  }
  const auto [n_intrinsics, n_params] = VisitCameraModel(type, [](auto model) {
    using Model = decltype(model);
    return std::pair<int, int>(Model::kNumProjectionParams, Model::kNumParams);
  });
  const int n_coeffs = n_params - n_intrinsics;
  if (static_cast<int>(intrinsics.size()) != n_intrinsics)
    throw std::invalid_argument(Describe(type) + " needs " + std::to_string(n_intrinsics) +
                                " intrinsics, got " + std::to_string(intrinsics.size()));
  if (static_cast<int>(distortion_coeffs.size()) != n_coeffs)
    throw std::invalid_argument(Describe(type) + " needs " + std::to_string(n_coeffs) +
                                " distortion_coeffs, got " +
                                std::to_string(distortion_coeffs.size()));
  Eigen::VectorXd params(n_params);
  for (int i = 0; i < n_intrinsics; ++i)
    params(i) = intrinsics[i];
  for (int i = 0; i < n_coeffs; ++i)
    params(n_intrinsics + i) = distortion_coeffs[i];
  return CameraModel(type, params, resolution);
}

CameraModel::CameraModel(CameraModelType type, const Eigen::VectorXd& params,
                         const Eigen::Vector2i& resolution)
    : type_(type), resolution_(resolution) {
  CheckResolution(resolution);
  SetParams(params);
}

CameraModel::CameraModel(std::shared_ptr<const MrcalLens> lens, const Eigen::VectorXd& params,
                         const Eigen::Vector2i& resolution)
    : type_(CameraModelType::kMrcal), mrcal_lens_(std::move(lens)), resolution_(resolution) {
  if (!mrcal_lens_)
    throw std::invalid_argument("camera model 'mrcal' needs a lens model");
  CheckResolution(resolution);
  SetParams(params);
}

std::string CameraModel::distortion_model() const {
  return mrcal_lens_ ? mrcal_lens_->name() : DistortionModelName(type_);
}

void CameraModel::SetParams(const Eigen::VectorXd& params) {
  if (mrcal_lens_) {
    if (params.size() != mrcal_lens_->NumParams())
      throw std::invalid_argument("mrcal lens model " + mrcal_lens_->name() + " needs " +
                                  std::to_string(mrcal_lens_->NumParams()) + " intrinsics, got " +
                                  std::to_string(params.size()));
    std::string why;
    if (!mrcal_lens_->CheckParams(params.data(), &why))
      throw std::invalid_argument("mrcal lens model " + mrcal_lens_->name() + ": " + why);
    params_ = params;
    return;
  }
  if (type_ == CameraModelType::kMrcal)
    throw std::invalid_argument("camera model 'mrcal' needs a lens model");
  const int n = VisitCameraModel(type_, [](auto model) { return decltype(model)::kNumParams; });
  if (params.size() != n)
    throw std::invalid_argument(Describe(type_) + " needs " + std::to_string(n) +
                                " parameters (intrinsics and distortion_coeffs), got " +
                                std::to_string(params.size()));
  std::string why;
  const bool ok = VisitCameraModel(
      type_, [&](auto model) { return decltype(model)::CheckParams(params.data(), &why); });
  if (!ok)
    throw std::invalid_argument(Describe(type_) + ": " + why);
  params_ = params;
}

int CameraModel::NumIntrinsics() const {
  if (mrcal_lens_)
    return NumParams();
  return VisitCameraModel(type_, [](auto model) { return decltype(model)::kNumProjectionParams; });
}

void CameraModel::ParamBounds(Eigen::VectorXd* lower, Eigen::VectorXd* upper) const {
  lower->resize(NumParams());
  upper->resize(NumParams());
  if (mrcal_lens_) {
    FreeBounds(NumParams(), lower->data(), upper->data());
    return;
  }
  VisitCameraModel(type_,
                   [&](auto model) { decltype(model)::ParamBounds(lower->data(), upper->data()); });
}

std::vector<std::string> CameraModel::ParamNames() const {
  if (mrcal_lens_)
    return mrcal_lens_->ParamNames();
  return VisitCameraModel(type_, [](auto model) {
    const auto names = decltype(model)::ParamNames();
    return std::vector<std::string>(names.begin(), names.end());
  });
}

std::vector<double> CameraModel::intrinsics() const {
  return std::vector<double>(params_.data(), params_.data() + NumIntrinsics());
}

std::vector<double> CameraModel::distortion_coeffs() const {
  return std::vector<double>(params_.data() + NumIntrinsics(), params_.data() + NumParams());
}

bool CameraModel::Project(const Eigen::Vector3d& p_C, Eigen::Vector2d* uv,
                          Eigen::Matrix<double, 2, 3>* J_uv_p,
                          Eigen::Matrix<double, 2, Eigen::Dynamic>* J_uv_params) const {
  if (mrcal_lens_)
    return mrcal_lens_->Project(params_.data(), p_C, uv, J_uv_p, J_uv_params);
  return VisitCameraModel(type_, [&](auto model) {
    using Model = decltype(model);
    if (!J_uv_params)
      return Model::Project(params_.data(), p_C, uv, J_uv_p, nullptr);
    Eigen::Matrix<double, 2, Model::kNumParams> J;
    const bool valid = Model::Project(params_.data(), p_C, uv, J_uv_p, &J);
    *J_uv_params = J;
    return valid;
  });
}

bool CameraModel::Unproject(const Eigen::Vector2d& uv, Eigen::Vector3d* ray_C) const {
  if (mrcal_lens_)
    return mrcal_lens_->Unproject(params_.data(), uv, ray_C);
  return VisitCameraModel(
      type_, [&](auto model) { return decltype(model)::Unproject(params_.data(), uv, ray_C); });
}

bool CameraModel::IsInImage(const Eigen::Vector2d& uv, double border) const {
  return uv.allFinite() && uv.x() >= -0.5 + border && uv.y() >= -0.5 + border &&
         uv.x() <= width() - 0.5 - border && uv.y() <= height() - 0.5 - border;
}

}  // namespace ctcal
