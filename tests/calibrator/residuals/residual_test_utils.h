// Shared helpers of the residual tests: a smooth synthetic trajectory, bias splines, camera
// parameters per model, and the check every residual passes: analytic residual and Jacobians
// equal the Jet autodiff ones, and both match central differences taken on each block's manifold.
#pragma once

#include <ceres/ceres.h>
#include <ceres/sphere_manifold.h>
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "ctcal/sensors/camera_model.h"
#include "ctcal/sensors/gyro_intrinsics.h"
#include "ctcal/sensors/imu_intrinsics.h"
#include "ctcal/sensors/inertial_noise.h"
#include "ctcal/sensors/model_names.h"
#include "ctcal/spline/rd_spline.h"
#include "ctcal/spline/se3_spline.h"
#include "ctcal/spline/so3_manifold.h"

namespace ctcal::testing {

template <int kN, Se3Representation kRep>
struct TrajectoryConfig {
  static constexpr int N = kN;
  static constexpr Se3Representation Rep = kRep;
};

// A trajectory configuration with the order of the bias splines.
template <int kN, Se3Representation kRep, int kNb>
struct InertialConfig {
  static constexpr int N = kN;
  static constexpr Se3Representation Rep = kRep;
  static constexpr int Nb = kNb;
};

// Orders 4-6, both representations, bias orders 2-4 (each appears in both representations).
using InertialConfigs = ::testing::Types<InertialConfig<4, Se3Representation::kSplit, 4>,
                                         InertialConfig<5, Se3Representation::kSplit, 2>,
                                         InertialConfig<6, Se3Representation::kSplit, 3>,
                                         InertialConfig<4, Se3Representation::kJoint, 2>,
                                         InertialConfig<5, Se3Representation::kJoint, 3>,
                                         InertialConfig<6, Se3Representation::kJoint, 4>>;

inline constexpr std::int64_t kT0Ns = 1'000'000'000;

inline Eigen::Vector3d RandomVector(std::mt19937* rng, double scale) {
  std::uniform_real_distribution<double> uni(-scale, scale);
  return Eigen::Vector3d(uni(*rng), uni(*rng), uni(*rng));
}

inline Eigen::Quaterniond RandomRotation(std::mt19937* rng, double angle) {
  return ExpSO3<double>(RandomVector(rng, angle)).normalized();
}

// A hand-waved trajectory: knots on a smooth motion (~1 rad, ~1 m) plus random jitter, so that
// every velocity, acceleration and jerk of the spline is far from zero.
template <int N, Se3Representation Rep>
Se3Spline<N, Rep> MakeTrajectory(int num_knots, std::int64_t dt_ns, unsigned seed) {
  std::mt19937 rng(seed);
  Se3Spline<N, Rep> spline(KnotTiming{kT0Ns, dt_ns}, num_knots);
  for (int k = 0; k < num_knots; ++k) {
    const double t = 1e-9 * static_cast<double>(k * dt_ns);
    const Eigen::Vector3d phi(0.6 * std::sin(1.1 * t), 0.5 * std::cos(0.7 * t), 0.4 * t);
    spline.KnotRotation(k) = (ExpSO3<double>(phi) * RandomRotation(&rng, 0.05)).normalized();
    spline.KnotPosition(k) =
        Eigen::Vector3d(std::sin(0.9 * t), 0.5 * std::cos(1.3 * t), 0.2 * t - 1.0) +
        RandomVector(&rng, 0.02);
  }
  return spline;
}

template <int Nb>
RdSpline<3, Nb> MakeBias(int num_knots, std::int64_t dt_ns, double scale, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<Eigen::Vector3d> knots;
  for (int k = 0; k < num_knots; ++k)
    knots.push_back(RandomVector(&rng, scale));
  return RdSpline<3, Nb>(KnotTiming{kT0Ns, dt_ns}, knots);
}

// The knot pointers of the segment starting at first_index (Ceres order) as a vector.
template <class Spline>
std::vector<double*> SegmentBlocks(Spline* spline, int first_index) {
  const auto blocks = spline->SegmentBlocks(first_index);
  return std::vector<double*>(blocks.begin(), blocks.end());
}

template <int Nb>
std::vector<double*> BiasBlocks(RdSpline<3, Nb>* bias, int first_index) {
  std::vector<double*> blocks;
  for (int i = 0; i < Nb; ++i)
    blocks.push_back(bias->KnotData(first_index + i));
  return blocks;
}

// The trajectory blocks' manifolds (nullptr = Euclidean), as the pipeline sets them.
template <int N, Se3Representation Rep>
std::vector<const ceres::Manifold*> TrajectoryManifolds() {
  static const So3RightManifold so3;
  static const Se3RightManifold se3;
  std::vector<const ceres::Manifold*> m;
  for (int b = 0; b < Se3Spline<N, Rep>::kNumBlocks; ++b) {
    if (Rep == Se3Representation::kJoint)
      m.push_back(&se3);
    else
      m.push_back(b < N ? &so3 : nullptr);
  }
  return m;
}

inline const ceres::Manifold* LeftRotationManifold() {
  static const So3LeftManifold m;
  return &m;
}
inline const ceres::Manifold* GravityManifold() {
  static const ceres::SphereManifold<3> m;
  return &m;
}

// Orders 4-6 in both representations.
using TrajectoryConfigs = ::testing::Types<
    TrajectoryConfig<4, Se3Representation::kSplit>, TrajectoryConfig<5, Se3Representation::kSplit>,
    TrajectoryConfig<6, Se3Representation::kSplit>, TrajectoryConfig<4, Se3Representation::kJoint>,
    TrajectoryConfig<5, Se3Representation::kJoint>, TrajectoryConfig<6, Se3Representation::kJoint>>;

// What the camera residuals read besides their corners: a trajectory with knots every 0.1 s and
// one camera's extrinsics and clock (time offset, line delay).
inline constexpr std::int64_t kCameraKnotDtNs = 100'000'000;
template <int N, Se3Representation Rep>
struct CameraState {
  CameraState(double offset, double line_delay)
      : spline_(MakeTrajectory<N, Rep>(12, kCameraKnotDtNs, 7)),
        offset_(offset),
        line_delay_(line_delay) {
    std::mt19937 rng(11);
    q_B_C_ = RandomRotation(&rng, 0.5);
    t_B_C_ = Eigen::Vector3d(0.05, -0.02, 0.01);
  }

  // Points the blocks every camera residual has (trajectory segment, extrinsics, time offset,
  // intrinsics) of its Parameters p at this state.
  template <class Parameters>
  void SetCameraBlocks(int first, double* params, Parameters* p) {
    p->traj = SegmentBlocks(&spline_, first);
    p->q_B_C = q_B_C_.coeffs().data();
    p->t_B_C = t_B_C_.data();
    p->time_offset = &offset_;
    p->params = params;
  }

  Se3Spline<N, Rep> spline_;
  Eigen::Quaterniond q_B_C_;
  Eigen::Vector3d t_B_C_;
  double offset_;
  double line_delay_;
};

// Plausible parameters of every model, with noticeable distortion.
inline Eigen::VectorXd CameraParams(CameraModelType type) {
  Eigen::VectorXd p;
  switch (type) {
    case CameraModelType::kPinholeRadtan:
      p.resize(8);
      p << 460, 455, 320, 245, -0.25, 0.08, 1e-3, -5e-4;
      break;
    case CameraModelType::kPinholeEquidistant:
      p.resize(8);
      p << 380, 385, 325, 238, 0.02, -0.01, 0.003, -0.001;
      break;
    case CameraModelType::kPinholeNone:
      p.resize(4);
      p << 460, 455, 320, 245;
      break;
    case CameraModelType::kOmniRadtan:
      p.resize(9);
      p << 0.9, 760, 755, 320, 245, -0.2, 0.05, 1e-3, -5e-4;
      break;
    case CameraModelType::kOmniNone:
      p.resize(5);
      p << 0.9, 760, 755, 320, 245;
      break;
    case CameraModelType::kDoubleSphere:
      p.resize(6);
      p << -0.2, 0.6, 350, 352, 320, 245;
      break;
    case CameraModelType::kEucm:
      p.resize(6);
      p << 0.6, 1.1, 380, 382, 320, 245;
      break;
    case CameraModelType::kMrcal:  // not a compile-time model: the residuals take it elsewhere
      break;
  }
  return p;
}

inline constexpr ImuModel kAllImuModels[] = {ImuModel::kNone, ImuModel::kImu1, ImuModel::kImu2,
                                             ImuModel::kImu3, ImuModel::kImu4};
inline constexpr GSensitivity kAllGSensitivities[] = {GSensitivity::kNone, GSensitivity::kUpper,
                                                      GSensitivity::kFull};

// base + uniform(-scale, scale) on the entries a matrix of form f stores.
inline Eigen::Matrix3d RandomMatrix(std::mt19937* rng, MatrixForm f, const Eigen::Matrix3d& base,
                                    double scale) {
  std::uniform_real_distribution<double> uni(-scale, scale);
  Eigen::Matrix3d M = base;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      if (f == MatrixForm::kFull || (f == MatrixForm::kUpper && c >= r))
        M(r, c) += uni(*rng);
    }
  }
  return M;
}

// Intrinsics of a model with every block it has away from identity (percent scale errors,
// milliradian misalignments, g-sensitivity of 1e-3 rad/s per m/s^2).
inline ImuIntrinsics RandomImuIntrinsics(ImuModel model, GSensitivity g_sensitivity,
                                         unsigned seed) {
  std::mt19937 rng(seed);
  ImuIntrinsics x(model, g_sensitivity);
  const ImuModelLayout& L = x.layout();
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  if (L.Dw != MatrixForm::kAbsent)
    x.SetD_w(RandomMatrix(&rng, L.Dw, I, 0.02));
  if (L.Da != MatrixForm::kAbsent)
    x.SetD_a(RandomMatrix(&rng, L.Da, I, 0.02));
  if (L.Tg != MatrixForm::kAbsent)
    x.SetT_g(RandomMatrix(&rng, L.Tg, Eigen::Matrix3d::Zero(), 1e-3));
  if (L.HasRotation())
    x.SetRotation(RandomRotation(&rng, 0.01).toRotationMatrix());
  return x;
}

// The manifolds of an IMU's intrinsic blocks in residual order (only the rotation has one).
inline void AppendImuIntrinsicManifolds(const ImuModelLayout& L,
                                        std::vector<const ceres::Manifold*>* m) {
  for (const MatrixForm f : {L.Dw, L.Da, L.Tg}) {
    if (f != MatrixForm::kAbsent)
      m->push_back(nullptr);
  }
  if (L.HasRotation())
    m->push_back(LeftRotationManifold());
}

// Calls check(name, &intrinsics) for every IMU model x g_sensitivity, with intrinsics drawn from
// `seed` (RandomImuIntrinsics) and the pair's name traced.
template <class Check>
void ForEveryImuModel(unsigned seed, const Check& check) {
  for (const ImuModel model : kAllImuModels) {
    for (const GSensitivity gs : kAllGSensitivities) {
      const std::string name = ToString(model) + " g_sensitivity " + ToString(gs);
      SCOPED_TRACE(name);
      ImuIntrinsics intrinsics = RandomImuIntrinsics(model, gs, seed);
      check(name, &intrinsics);
    }
  }
}

// What the base and auxiliary IMU residuals read besides their own sensor: a trajectory with
// knots every 50 ms, gravity, and gyroscope and accelerometer bias splines with knots every 0.4 s,
// drawn from seed, seed + 1 and seed + 2.
inline constexpr std::int64_t kInertialKnotDtNs = 50'000'000;
template <int N, Se3Representation Rep, int Nb>
struct InertialState {
  static constexpr std::int64_t kBiasDtNs = 400'000'000;

  InertialState(unsigned seed, const Eigen::Vector3d& g_direction)
      : spline_(MakeTrajectory<N, Rep>(16, kInertialKnotDtNs, seed)),
        bg_(MakeBias<Nb>(6, kBiasDtNs, 0.01, seed + 1)),
        ba_(MakeBias<Nb>(6, kBiasDtNs, 0.1, seed + 2)),
        g_W_(g_direction.normalized() * 9.81) {}

  // Points the blocks every IMU residual has (trajectory and bias segments, gravity, intrinsics)
  // of its Parameters p at this state.
  template <class Parameters>
  void SetSharedBlocks(int first, int bias_first, ImuIntrinsics* intrinsics, Parameters* p) {
    p->traj = SegmentBlocks(&spline_, first);
    p->g_W = g_W_.data();
    p->bg = BiasBlocks(&bg_, bias_first);
    p->ba = BiasBlocks(&ba_, bias_first);
    p->intrinsics = intrinsics;
  }

  Se3Spline<N, Rep> spline_;
  RdSpline<3, Nb> bg_;
  RdSpline<3, Nb> ba_;
  Eigen::Vector3d g_W_;
};

// A cost function evaluated at the current parameter values: residual and ambient Jacobians.
struct Evaluation {
  bool ok = false;
  Eigen::VectorXd r;
  std::vector<Eigen::MatrixXd> J;  // ambient, one per block
};

inline Evaluation EvaluateCost(const ceres::CostFunction& cost, const std::vector<double*>& blocks,
                               bool with_jacobians = true) {
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const int m = cost.num_residuals();
  const std::vector<int32_t>& sizes = cost.parameter_block_sizes();
  EXPECT_EQ(sizes.size(), blocks.size());
  Evaluation e;
  e.r.resize(m);
  std::vector<RowMajor> J;
  std::vector<double*> J_ptr;
  for (const int32_t size : sizes) {
    J.emplace_back(m, size);
    J_ptr.push_back(J.back().data());
  }
  e.ok = cost.Evaluate(blocks.data(), e.r.data(), with_jacobians ? J_ptr.data() : nullptr);
  if (with_jacobians) {
    for (const RowMajor& j : J)
      e.J.push_back(j);
  }
  return e;
}

// Both paths of a residual, make(analytic) for analytic and Jet autodiff, are zero at `blocks`
// to within tol: the check of a noise-free truth.
template <class Make>
void ExpectZeroOnBothPaths(const Make& make, const std::vector<double*>& blocks, double tol) {
  for (const bool analytic : {true, false}) {
    const std::unique_ptr<ceres::CostFunction> cost(make(analytic));
    const Evaluation e = EvaluateCost(*cost, blocks, false);
    ASSERT_TRUE(e.ok);
    EXPECT_LT(e.r.norm(), tol) << (analytic ? "analytic " : "autodiff ") << e.r.transpose();
  }
}

// The zero-at-truth check of an IMU residual over every IMU model x g_sensitivity at one stamp,
// for a fixture with Truth(intrinsics, stamp, &first, &bias_first), Blocks(first, bias_first,
// &intrinsics) and a static MakeResidual(analytic, setup).
template <class Fixture>
void ExpectZeroAtTruthForEveryImuModel(Fixture* fixture, std::int64_t stamp_ns, unsigned seed) {
  ForEveryImuModel(seed, [&](const std::string&, ImuIntrinsics* intrinsics) {
    int first = 0, bias_first = 0;
    const auto setup = fixture->Truth(*intrinsics, stamp_ns, &first, &bias_first);
    ExpectZeroOnBothPaths([&](bool analytic) { return Fixture::MakeResidual(analytic, setup); },
                          fixture->Blocks(first, bias_first, intrinsics), 1e-7);
  });
}

// J_ambient * PlusJacobian: the Jacobian with respect to the block's tangent (what Ceres uses).
inline Eigen::MatrixXd TangentJacobian(const Eigen::MatrixXd& J_ambient,
                                       const ceres::Manifold* manifold, const double* x) {
  if (manifold == nullptr)
    return J_ambient;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> P(manifold->AmbientSize(),
                                                                           manifold->TangentSize());
  manifold->PlusJacobian(x, P.data());
  return J_ambient * P;
}

// Central differences of the residual along the tangent of block b.
inline Eigen::MatrixXd NumericTangentJacobian(const ceres::CostFunction& cost,
                                              const std::vector<double*>& blocks, int b,
                                              const ceres::Manifold* manifold, double h) {
  const int ambient = cost.parameter_block_sizes()[b];
  const int tangent = manifold != nullptr ? manifold->TangentSize() : ambient;
  const std::vector<double> x0(blocks[b], blocks[b] + ambient);
  Eigen::MatrixXd J(cost.num_residuals(), tangent);
  for (int k = 0; k < tangent; ++k) {
    Eigen::VectorXd r[2];
    for (int s = 0; s < 2; ++s) {
      Eigen::VectorXd delta = Eigen::VectorXd::Zero(tangent);
      delta[k] = s == 0 ? h : -h;
      if (manifold != nullptr) {
        manifold->Plus(x0.data(), delta.data(), blocks[b]);
      } else {
        for (int i = 0; i < ambient; ++i)
          blocks[b][i] = x0[i] + delta[i];
      }
      const Evaluation e = EvaluateCost(cost, blocks, false);
      EXPECT_TRUE(e.ok);
      r[s] = e.r;
    }
    J.col(k) = (r[0] - r[1]) / (2.0 * h);
  }
  std::copy(x0.begin(), x0.end(), blocks[b]);
  return J;
}

inline double MaxAbs(const Eigen::MatrixXd& m) {
  return m.size() ? m.cwiseAbs().maxCoeff() : 0.0;
}

// The check of every residual type (see the file comment). manifolds[b] = nullptr: Euclidean.
// Errors are relative to the largest entry of the residual's tangent Jacobian (at least 1).
// steps[b] > 0 overrides the central-difference step 1e-6 of block b (e.g. a line delay, whose
// unit step moves the sample by hundreds of rows).
inline void ExpectAnalyticMatchesAutoDiffAndNumeric(
    const ceres::CostFunction& analytic, const ceres::CostFunction& autodiff,
    const std::vector<double*>& blocks, const std::vector<const ceres::Manifold*>& manifolds,
    const std::string& what, const std::vector<double>& steps = {}, double tol_autodiff = 1e-8,
    double tol_numeric = 2e-6) {
  SCOPED_TRACE(what);
  ASSERT_EQ(analytic.parameter_block_sizes(), autodiff.parameter_block_sizes());
  ASSERT_EQ(analytic.num_residuals(), autodiff.num_residuals());
  ASSERT_EQ(blocks.size(), manifolds.size());
  const Evaluation a = EvaluateCost(analytic, blocks);
  const Evaluation d = EvaluateCost(autodiff, blocks);
  ASSERT_TRUE(a.ok);
  ASSERT_TRUE(d.ok);
  EXPECT_LE(MaxAbs(a.r - d.r), tol_autodiff * std::max(1.0, MaxAbs(d.r))) << "residual";

  std::vector<Eigen::MatrixXd> J_a, J_d;
  double scale = 1.0;
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    J_a.push_back(TangentJacobian(a.J[b], manifolds[b], blocks[b]));
    J_d.push_back(TangentJacobian(d.J[b], manifolds[b], blocks[b]));
    scale = std::max(scale, MaxAbs(J_d.back()));
  }
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    EXPECT_LE(MaxAbs(J_a[b] - J_d[b]), tol_autodiff * scale) << "block " << b << " analytic\n"
                                                             << J_a[b] << "\nautodiff\n"
                                                             << J_d[b];
    const Eigen::MatrixXd J_n =
        NumericTangentJacobian(analytic, blocks, static_cast<int>(b), manifolds[b],
                               b < steps.size() && steps[b] > 0.0 ? steps[b] : 1e-6);
    EXPECT_LE(MaxAbs(J_a[b] - J_n), tol_numeric * scale) << "block " << b << " analytic\n"
                                                         << J_a[b] << "\nnumeric\n"
                                                         << J_n;
  }
}

}  // namespace ctcal::testing
