#include "ctcal/sim/perturb.h"

#include <Eigen/Geometry>
#include <cmath>
#include <stdexcept>

#include "ctcal/sensors/camera_model.h"
#include "ctcal/sensors/gyro_intrinsics.h"
#include "ctcal/sensors/imu_intrinsics.h"

namespace ctcal::sim {
namespace {

// The report's Table 4 sigmas.
constexpr double kSigmaScale = 0.003;             // D_w, D_a entries
constexpr double kSigmaImuRotation = 0.003;       // R_I_a / R_I_w, rad
constexpr double kSigmaTg = 0.001;                // T_g entries, (rad/s)/(m/s^2)
constexpr double kSigmaFocalCentre = 1.0;         // px
constexpr double kSigmaOtherCamera = 0.002;       // distortion and other model parameters
constexpr double kSigmaCameraRotation = 0.004;    // rad
constexpr double kSigmaCameraPosition = 0.008;    // m
constexpr double kSigmaCameraOffset = 0.008;      // s
constexpr double kSigmaInertialRotation = 0.003;  // rad
constexpr double kSigmaInertialPosition = 0.005;  // m
constexpr double kSigmaInertialOffset = 0.003;    // s

constexpr double kCoarseMaxAngle = 5.0 * M_PI / 180.0;
constexpr double kCoarseMaxPosition = 0.02;
constexpr double kCoarseFocal = 0.05;

Eigen::Matrix3d Exp(const Eigen::Vector3d& phi) {
  const double angle = phi.norm();
  if (angle == 0.0)
    return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, phi / angle).toRotationMatrix();
}

// A uniformly distributed direction (normalised Gaussian vector).
Eigen::Vector3d RandomDirection(Random& rng) {
  Eigen::Vector3d d = rng.Gaussian3(1.0);
  while (d.norm() < 1e-6)
    d = rng.Gaussian3(1.0);
  return d.normalized();
}

std::vector<double> Repeat(double value, std::size_t n) {
  return std::vector<double>(n, value);
}

void AddGaussian(std::vector<double>* v, double sigma, Random& rng) {
  for (double& x : *v)
    x += rng.Gaussian(sigma);
}

// Keeps the stored D the model has, with identity for an absent key (the truth may omit it).
std::vector<double> StoredOrIdentity(const std::vector<double>& v, MatrixForm f) {
  if (f == MatrixForm::kAbsent)
    return {};
  return v.empty() ? IdentityStored(static_cast<std::size_t>(StoredSize(f))) : v;
}

void PerturbInertialIntrinsics(SensorConfig* s, Perturbation p, Random& rng) {
  MatrixForm f_Dw = MatrixForm::kAbsent, f_Da = MatrixForm::kAbsent, f_Tg = MatrixForm::kAbsent;
  ImuRotation rotation = ImuRotation::kNone;
  if (s->type == SensorType::kImu) {
    const ImuModelLayout layout = ImuModelLayout::Of(s->imu_model, s->g_sensitivity);
    f_Dw = layout.Dw;
    f_Da = layout.Da;
    f_Tg = layout.Tg;
    rotation = layout.rotation;
  } else {
    f_Dw = GyroDwForm(s->gyro_model);
  }
  Eigen::Matrix3d* R = rotation == ImuRotation::kR_I_a
                           ? &s->R_I_a
                           : (rotation == ImuRotation::kR_I_w ? &s->R_I_w : nullptr);
  if (p == Perturbation::kCoarse) {
    s->D_w = StoredOrIdentity({}, f_Dw);
    s->D_a = StoredOrIdentity({}, f_Da);
    s->T_g = f_Tg == MatrixForm::kAbsent ? std::vector<double>{}
                                         : Repeat(0.0, static_cast<std::size_t>(StoredSize(f_Tg)));
    if (R != nullptr)
      R->setIdentity();
    return;
  }
  s->D_w = StoredOrIdentity(s->D_w, f_Dw);
  s->D_a = StoredOrIdentity(s->D_a, f_Da);
  if (f_Tg != MatrixForm::kAbsent && s->T_g.empty())
    s->T_g = Repeat(0.0, static_cast<std::size_t>(StoredSize(f_Tg)));
  AddGaussian(&s->D_w, kSigmaScale, rng);
  AddGaussian(&s->D_a, kSigmaScale, rng);
  AddGaussian(&s->T_g, kSigmaTg, rng);
  if (!s->D_w.empty())
    s->prior_sigma.values["Dw"] = Repeat(kSigmaScale, s->D_w.size());
  if (!s->D_a.empty())
    s->prior_sigma.values["Da"] = Repeat(kSigmaScale, s->D_a.size());
  if (!s->T_g.empty())
    s->prior_sigma.values["Tg"] = Repeat(kSigmaTg, s->T_g.size());
  if (R != nullptr) {
    *R = Exp(rng.Gaussian3(kSigmaImuRotation)) * *R;
    s->prior_sigma.values[rotation == ImuRotation::kR_I_a ? "R_I_a" : "R_I_w"] =
        Repeat(kSigmaImuRotation, 3);
  }
}

void PerturbCameraIntrinsics(SensorConfig* s, Perturbation p, Random& rng) {
  const CameraModel camera =
      CameraModel::Create(s->camera_model, s->intrinsics, s->distortion_model, s->distortion_coeffs,
                          Eigen::Vector2i(s->width, s->height));
  const std::vector<std::string> names = camera.ParamNames();
  const std::size_t n_intr = s->intrinsics.size();
  std::vector<double> sigma_intr(n_intr), sigma_dist(s->distortion_coeffs.size());
  for (std::size_t i = 0; i < names.size(); ++i) {
    double& value = i < n_intr ? s->intrinsics[i] : s->distortion_coeffs[i - n_intr];
    const std::string& name = names[i];
    // Kalibr's symbols, and mrcal's for camera_model mrcal.
    const bool focal = name == "fu" || name == "fv" || name == "fx" || name == "fy";
    const bool centre = name == "pu" || name == "pv" || name == "cx" || name == "cy";
    if (p == Perturbation::kCoarse) {
      if (focal)
        value *= 1.0 + (rng.Bernoulli(0.5) ? kCoarseFocal : -kCoarseFocal);
      else if (centre)
        value = 0.5 * ((name == "pu" || name == "cx" ? s->width : s->height) - 1);
      else if (i >= n_intr || (s->camera_model == "mrcal" && i >= 4))
        value = 0.0;  // the distortion (mrcal's follows its core inside the intrinsics)
      continue;
    }
    const double sigma = (focal || centre) ? kSigmaFocalCentre : kSigmaOtherCamera;
    value += rng.Gaussian(sigma);
    (i < n_intr ? sigma_intr[i] : sigma_dist[i - n_intr]) = sigma;
  }
  if (p == Perturbation::kTable4) {
    s->prior_sigma.values["intrinsics"] = sigma_intr;
    if (!sigma_dist.empty())
      s->prior_sigma.values["distortion_coeffs"] = sigma_dist;
  }
}

void PerturbExtrinsics(SensorConfig* s, Perturbation p, Random& rng) {
  const bool camera = s->type == SensorType::kCamera;
  Eigen::Matrix3d R = s->T_B_S.topLeftCorner<3, 3>();
  Eigen::Vector3d t = s->T_B_S.topRightCorner<3, 1>();
  if (p == Perturbation::kCoarse) {
    R = Exp(RandomDirection(rng) * rng.Uniform(0.0, kCoarseMaxAngle)) * R;
    t += RandomDirection(rng) * rng.Uniform(0.0, kCoarseMaxPosition);
  } else {
    const double sr = camera ? kSigmaCameraRotation : kSigmaInertialRotation;
    const double st = camera ? kSigmaCameraPosition : kSigmaInertialPosition;
    R = Exp(rng.Gaussian3(sr)) * R;
    t += rng.Gaussian3(st);
    s->prior_sigma.values["R_B_S"] = Repeat(sr, 3);
    s->prior_sigma.values["t_B_S"] = Repeat(st, 3);
  }
  // Re-orthonormalise so the file carries an exact rotation.
  s->T_B_S.topLeftCorner<3, 3>() = Eigen::Quaterniond(R).normalized().toRotationMatrix();
  s->T_B_S.topRightCorner<3, 1>() = t;
}

void PerturbTimeOffset(SensorConfig* s, Perturbation p, Random& rng) {
  if (p == Perturbation::kCoarse) {
    s->time_offset = 0.0;
    return;
  }
  const double sigma = s->type == SensorType::kCamera ? kSigmaCameraOffset : kSigmaInertialOffset;
  s->time_offset += rng.Gaussian(sigma);
  s->prior_sigma.values["time_offset"] = {sigma};
}

}  // namespace

Perturbation ParsePerturbation(const std::string& name) {
  if (name == "table4")
    return Perturbation::kTable4;
  if (name == "coarse")
    return Perturbation::kCoarse;
  throw std::invalid_argument("unknown perturbation '" + name + "' (one of: table4, coarse)");
}

std::string ToString(Perturbation p) {
  return p == Perturbation::kTable4 ? "table4" : "coarse";
}

RigConfig PerturbRig(const RigConfig& truth, Perturbation perturbation, Random& rng) {
  RigConfig guess = truth;
  guess.gravity_W.reset();
  guess.sigma_gravity_W.reset();
  guess.solver.reset();
  guess.residuals.clear();
  guess.observability.reset();
  for (std::size_t i = 0; i < guess.sensors.size(); ++i) {
    SensorConfig& s = guess.sensors[i];
    s.sigma.values.clear();
    s.prior_sigma.values.clear();
    // One stream per sensor: a sensor's guess does not depend on the sensors before it.
    Random sensor_rng = rng.Fork(i + 1);
    const bool is_base = s.name == guess.base_imu;
    if (s.Estimates(EstimateItem::kIntrinsics)) {
      if (s.IsInertial())
        PerturbInertialIntrinsics(&s, perturbation, sensor_rng);
      else
        PerturbCameraIntrinsics(&s, perturbation, sensor_rng);
    }
    if (!is_base && s.Estimates(EstimateItem::kExtrinsics))
      PerturbExtrinsics(&s, perturbation, sensor_rng);
    if (!is_base && s.Estimates(EstimateItem::kTimeOffset))
      PerturbTimeOffset(&s, perturbation, sensor_rng);
  }
  return guess;
}

}  // namespace ctcal::sim
