// Se3Spline<N, Rep> (split and joint) at the segment level: every analytic Jacobian against central
// differences with the knots perturbed through their own Ceres manifolds, every time derivative
// against finite differences of the value, and ceres::Jet autodiff against the analytic results.
#include "ctcal/spline/se3_spline.h"

#include <gtest/gtest.h>

#include <memory>

#include "ctcal/spline/so3_manifold.h"
#include "spline_test_utils.h"

namespace ctcal {
namespace {

using testing::CentralDifference;
using testing::RelativeError;

template <int kN, Se3Representation kRep>
struct Config {
  static constexpr int N = kN;
  static constexpr Se3Representation Rep = kRep;
};

enum class Quantity { kR, kP, kW, kAlpha, kV, kA, kF };
constexpr Quantity kAllQuantities[] = {Quantity::kR, Quantity::kP, Quantity::kW, Quantity::kAlpha,
                                       Quantity::kV, Quantity::kA, Quantity::kF};
const char* Name(Quantity q) {
  static const char* names[] = {"R_W_B", "p_W_B", "w_B", "alpha_B", "v_W", "a_W", "a_B"};
  return names[static_cast<int>(q)];
}

// Rotation outputs are compared as Log(R_ref^T R): the right perturbation the Jacobians describe.
template <typename T>
Vec3T<T> Extract(const Se3Kinematics<T>& k, Quantity q, const Eigen::Matrix3d& R_ref,
                 const Vec3T<T>& g_W) {
  switch (q) {
    case Quantity::kR:
      return LogSO3<T>(QuatT<T>(Mat3T<T>(R_ref.cast<T>().transpose() * k.R_W_B)));
    case Quantity::kP:
      return k.p_W_B;
    case Quantity::kW:
      return k.w_B;
    case Quantity::kAlpha:
      return k.alpha_B;
    case Quantity::kV:
      return k.v_W;
    case Quantity::kA:
      return k.a_W;
    case Quantity::kF:
      return k.SpecificForce(g_W);
  }
  return Vec3T<T>::Zero();
}

template <typename C>
class Se3SplineTest : public ::testing::Test {
 protected:
  static constexpr int N = C::N;
  using Spline = Se3Spline<N, C::Rep>;
  using Block = typename Se3Jacobians<double, N>::Block;

  Se3SplineTest() : spline_(KnotTiming{1000, 100'000'000}, N) {}

  // Random knots: rotations within `angle` of each other around a random orientation, positions
  // within `step` of each other.
  void RandomKnots(unsigned seed, double angle, double step) {
    std::mt19937 rng(seed);
    Eigen::Quaterniond q = testing::RandomRotation(&rng, 3.0);
    Eigen::Vector3d p = testing::RandomVector(&rng, 2.0);
    for (int k = 0; k < N; ++k) {
      q = testing::RandomRotation(&rng, angle, q);
      p += testing::RandomVector(&rng, step);
      spline_.KnotRotation(k) = q;
      spline_.KnotPosition(k) = p;
    }
  }

  std::unique_ptr<ceres::Manifold> BlockManifold(int b) const {
    if (C::Rep == Se3Representation::kJoint)
      return std::make_unique<Se3RightManifold>();
    if (b < N)
      return std::make_unique<So3RightManifold>();
    return nullptr;
  }

  // The kinematics with every block b moved by delta's tangent slice on its manifold.
  Se3Kinematics<double> EvaluatePerturbed(const Eigen::VectorXd& delta, double u) const {
    Spline perturbed = spline_;
    auto blocks = perturbed.SegmentBlocks(0);
    for (int b = 0; b < Spline::kNumBlocks; ++b) {
      const double* d = delta.data() + Spline::TangentOffset(b);
      const auto manifold = BlockManifold(b);
      std::vector<double> x(blocks[b], blocks[b] + Spline::AmbientSize(b));
      if (manifold) {
        manifold->Plus(x.data(), d, blocks[b]);
      } else {
        for (int i = 0; i < Spline::AmbientSize(b); ++i)
          blocks[b][i] = x[i] + d[i];
      }
    }
    Se3Kinematics<double> out;
    const auto const_blocks = ConstBlocks(&perturbed);
    Spline::EvaluateSegment(const_blocks.data(), u, inv_dt_, 3, &g_W_, &out);
    return out;
  }

  static std::array<const double*, Spline::kNumBlocks> ConstBlocks(Spline* s) {
    const auto blocks = s->SegmentBlocks(0);
    std::array<const double*, Spline::kNumBlocks> out;
    for (int b = 0; b < Spline::kNumBlocks; ++b)
      out[b] = blocks[b];
    return out;
  }

  void CheckKnotJacobians(double u, double tolerance) {
    Se3Kinematics<double> k;
    std::array<Block, 7> J;
    Se3Jacobians<double, N> jac{&J[0], &J[1], &J[2], &J[3], &J[4], &J[5], &J[6]};
    const auto blocks = ConstBlocks(&spline_);
    Spline::EvaluateSegment(blocks.data(), u, inv_dt_, 3, &g_W_, &k, &jac);
    for (Quantity q : kAllQuantities) {
      const Eigen::MatrixXd J_num = CentralDifference(
          [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
            return Extract<double>(EvaluatePerturbed(d, u), q, k.R_W_B, g_W_);
          },
          6 * N);
      EXPECT_LT(RelativeError(J[static_cast<int>(q)], J_num), tolerance)
          << Name(q) << " at u = " << u << "\nanalytic\n"
          << J[static_cast<int>(q)] << "\nnumeric\n"
          << J_num;
    }
  }

  Spline spline_;
  double inv_dt_ = 10.0;
  Eigen::Vector3d g_W_{0.3, -0.2, -9.81};
};

using Configs =
    ::testing::Types<Config<4, Se3Representation::kSplit>, Config<5, Se3Representation::kSplit>,
                     Config<6, Se3Representation::kSplit>, Config<4, Se3Representation::kJoint>,
                     Config<5, Se3Representation::kJoint>, Config<6, Se3Representation::kJoint>>;
TYPED_TEST_SUITE(Se3SplineTest, Configs);

TYPED_TEST(Se3SplineTest, KnotJacobiansMatchCentralDifferencesAtRandomKnots) {
  for (unsigned seed = 0; seed < 3; ++seed) {
    this->RandomKnots(seed, 0.8, 0.5);
    for (double u : {0.0, 0.37, 0.91})
      this->CheckKnotJacobians(u, 1e-6);
  }
}

TYPED_TEST(Se3SplineTest, KnotJacobiansMatchCentralDifferencesNearIdentity) {
  this->RandomKnots(7, 1e-6, 1e-6);
  for (int k = 0; k < TypeParam::N; ++k) {
    this->spline_.KnotRotation(k) =
        (ExpSO3<double>(Eigen::Vector3d(1e-7 * k, -2e-7, 3e-8 * k))).normalized();
  }
  this->CheckKnotJacobians(0.5, 1e-6);
  // Exactly identical knots: every d_j = 0 (small-angle branches).
  for (int k = 0; k < TypeParam::N; ++k) {
    this->spline_.KnotRotation(k) = Eigen::Quaterniond::Identity();
    this->spline_.KnotPosition(k).setZero();
  }
  this->CheckKnotJacobians(0.25, 1e-6);
}

// d/dt of every quantity equals the next derivative the spline reports.
TYPED_TEST(Se3SplineTest, TimeDerivativesMatchFiniteDifferences) {
  using Spline = typename TestFixture::Spline;
  this->RandomKnots(11, 0.8, 0.5);
  const Eigen::Vector3d g_W = this->g_W_;
  const std::int64_t t_ns = this->spline_.MinTimeNs() + 43'000'000;
  const double h = 1e-6;
  Se3Kinematics<double> k0, kp, km;
  this->spline_.Evaluate(t_ns, 0.0, 3, &g_W, &k0);
  this->spline_.Evaluate(t_ns, h, 3, &g_W, &kp);
  this->spline_.Evaluate(t_ns, -h, 3, &g_W, &km);
  const auto fd = [h](const Eigen::Vector3d& plus, const Eigen::Vector3d& minus) {
    return Eigen::Vector3d((plus - minus) / (2 * h));
  };
  const Eigen::Vector3d w_fd =
      LogSO3<double>(Eigen::Quaterniond(km.R_W_B.transpose() * kp.R_W_B)) / (2 * h);
  EXPECT_LT(RelativeError(k0.w_B, w_fd), 1e-7);
  EXPECT_LT(RelativeError(k0.v_W, fd(kp.p_W_B, km.p_W_B)), 1e-7);
  EXPECT_LT(RelativeError(k0.alpha_B, fd(kp.w_B, km.w_B)), 1e-7);
  EXPECT_LT(RelativeError(k0.a_W, fd(kp.v_W, km.v_W)), 1e-7);
  EXPECT_LT(RelativeError(k0.dalpha_B, fd(kp.alpha_B, km.alpha_B)), 1e-6);
  EXPECT_LT(RelativeError(k0.jerk_W, fd(kp.a_W, km.a_W)), 1e-6);
  EXPECT_LT(
      RelativeError(k0.SpecificForceRate(g_W), fd(kp.SpecificForce(g_W), km.SpecificForce(g_W))),
      1e-6);
  (void)sizeof(Spline);
}

// The identical evaluation on ceres::Jet: derivatives with respect to the 6N knot tangents equal
// the analytic Jacobians (the calibrator's autodiff path).
TYPED_TEST(Se3SplineTest, JetAutodiffEqualsAnalyticJacobians) {
  constexpr int N = TypeParam::N;
  using Spline = typename TestFixture::Spline;
  using Jet = ceres::Jet<double, 6 * N>;
  this->RandomKnots(5, 0.8, 0.5);
  const double u = 0.61;

  // Jet knots: each block moved by a Jet tangent on its manifold (right perturbation).
  std::vector<std::vector<Jet>> jet_blocks(Spline::kNumBlocks);
  auto blocks = this->spline_.SegmentBlocks(0);
  for (int b = 0; b < Spline::kNumBlocks; ++b) {
    const int off = Spline::TangentOffset(b);
    std::vector<Jet>& x = jet_blocks[b];
    x.resize(Spline::AmbientSize(b));
    const bool rotation_first = TypeParam::Rep == Se3Representation::kJoint || b < N;
    Vec3T<Jet> d_rot, d_pos;
    for (int i = 0; i < 3; ++i) {
      if (TypeParam::Rep == Se3Representation::kJoint) {
        d_pos[i] = Jet(0.0, off + i);
        d_rot[i] = Jet(0.0, off + 3 + i);
      } else {
        d_rot[i] = Jet(0.0, off + i);
        d_pos[i] = Jet(0.0, off + i);
      }
    }
    if (rotation_first) {
      const QuatT<Jet> q0 = Eigen::Map<const Eigen::Quaterniond>(blocks[b]).cast<Jet>();
      Eigen::Map<QuatT<Jet>>(x.data()) = q0 * ExpSO3<Jet>(d_rot);
      if (TypeParam::Rep == Se3Representation::kJoint) {
        const PoseT<Jet> step = ExpSE3<Jet>((Vec6T<Jet>() << d_pos, d_rot).finished());
        const Vec3T<Jet> t0 = Eigen::Map<const Eigen::Vector3d>(blocks[b] + 4).cast<Jet>();
        Eigen::Map<Vec3T<Jet>>(x.data() + 4) = t0 + q0 * step.t;
      }
    } else {
      Eigen::Map<Vec3T<Jet>>(x.data()) =
          Eigen::Map<const Eigen::Vector3d>(blocks[b]).cast<Jet>() + d_pos;
    }
  }
  std::array<const Jet*, Spline::kNumBlocks> jet_ptrs;
  for (int b = 0; b < Spline::kNumBlocks; ++b)
    jet_ptrs[b] = jet_blocks[b].data();
  Se3Kinematics<Jet> kj;
  const Vec3T<Jet> g_jet = this->g_W_.template cast<Jet>();
  Spline::EvaluateSegment(jet_ptrs.data(), Jet(u), Jet(this->inv_dt_), 3, &g_jet, &kj);

  Se3Kinematics<double> k;
  std::array<typename TestFixture::Block, 7> J;
  Se3Jacobians<double, N> jac{&J[0], &J[1], &J[2], &J[3], &J[4], &J[5], &J[6]};
  const auto cblocks = TestFixture::ConstBlocks(&this->spline_);
  Spline::EvaluateSegment(cblocks.data(), u, this->inv_dt_, 3, &this->g_W_, &k, &jac);

  for (Quantity q : kAllQuantities) {
    const Vec3T<Jet> value = Extract<Jet>(kj, q, k.R_W_B, g_jet);
    Eigen::Matrix<double, 3, 6 * N> J_jet;
    for (int r = 0; r < 3; ++r)
      J_jet.row(r) = value[r].v.transpose();
    EXPECT_LT(RelativeError(J[static_cast<int>(q)], J_jet), 1e-9) << Name(q);
    EXPECT_LT(RelativeError(Extract<double>(k, q, k.R_W_B, this->g_W_),
                            Vec3T<double>(value[0].a, value[1].a, value[2].a)),
              1e-12)
        << Name(q);
  }
}

// A Jet time offset: derivatives with respect to the offset equal the analytic time derivatives.
TYPED_TEST(Se3SplineTest, JetTimeOffsetGivesAnalyticTimeDerivatives) {
  using Spline = typename TestFixture::Spline;
  using Jet = ceres::Jet<double, 1>;
  this->RandomKnots(3, 0.8, 0.5);
  Spline& s = this->spline_;
  const std::int64_t t_ns = s.MinTimeNs() + 71'000'000;
  Se3Kinematics<double> k;
  s.Evaluate(t_ns, 0.0, 3, &this->g_W_, &k);

  SegmentLocation<Jet> loc;
  ASSERT_TRUE(s.ComputeIndex(t_ns, Jet(0.0, 0), &loc));
  std::vector<Jet> knots(Spline::kKnotSize * TypeParam::N);
  for (int i = 0; i < Spline::kKnotSize * TypeParam::N; ++i)
    knots[i] = Jet(s.KnotData(0)[i]);
  std::array<const Jet*, Spline::kNumBlocks> blocks;
  for (int b = 0; b < Spline::kNumBlocks; ++b) {
    blocks[b] = knots.data() + (s.SegmentBlocks(0)[b] - s.KnotData(0));
  }
  Se3Kinematics<Jet> kj;
  const Vec3T<Jet> g_jet = this->g_W_.template cast<Jet>();
  Spline::EvaluateSegment(blocks.data(), loc.u, loc.inv_dt, 3, &g_jet, &kj);
  const auto d = [](const Vec3T<Jet>& v) {
    return Eigen::Vector3d(v[0].v[0], v[1].v[0], v[2].v[0]);
  };
  EXPECT_LT(RelativeError(d(Extract<Jet>(kj, Quantity::kR, k.R_W_B, g_jet)), k.w_B), 1e-10);
  EXPECT_LT(RelativeError(d(kj.p_W_B), k.v_W), 1e-10);
  EXPECT_LT(RelativeError(d(kj.w_B), k.alpha_B), 1e-10);
  EXPECT_LT(RelativeError(d(kj.v_W), k.a_W), 1e-10);
  EXPECT_LT(RelativeError(d(kj.alpha_B), k.dalpha_B), 1e-10);
  EXPECT_LT(RelativeError(d(kj.a_W), k.jerk_W), 1e-10);
  EXPECT_LT(RelativeError(d(kj.SpecificForce(g_jet)), k.SpecificForceRate(this->g_W_)), 1e-10);
}

// The class-level API is the segment API at ComputeIndex's segment, and out-of-range times throw.
TYPED_TEST(Se3SplineTest, ClassEvaluateUsesTheSegmentOfTheTime) {
  using Spline = typename TestFixture::Spline;
  constexpr int N = TypeParam::N;
  Spline s(KnotTiming{-500'000'000, 50'000'000}, N + 3);
  std::mt19937 rng(9);
  for (int k = 0; k < s.NumKnots(); ++k) {
    s.KnotRotation(k) = testing::RandomRotation(&rng, 3.0);
    s.KnotPosition(k) = testing::RandomVector(&rng, 1.0);
  }
  EXPECT_EQ(s.MaxTimeNs(), -500'000'000 + 4 * 50'000'000);
  const std::int64_t t_ns = -500'000'000 + 2 * 50'000'000 + 20'000'000;
  int first = -1;
  Se3Kinematics<double> k;
  s.Evaluate(t_ns, 0.0, 2, nullptr, &k, nullptr, &first);
  EXPECT_EQ(first, 2);
  Se3Kinematics<double> ks;
  const auto blocks = s.SegmentBlocks(2);
  std::array<const double*, Spline::kNumBlocks> cb;
  for (int b = 0; b < Spline::kNumBlocks; ++b)
    cb[b] = blocks[b];
  Spline::EvaluateSegment(cb.data(), 0.4, 20.0, 2, static_cast<const Eigen::Vector3d*>(nullptr),
                          &ks);
  EXPECT_LT((k.R_W_B - ks.R_W_B).norm(), 1e-12);
  EXPECT_LT((k.a_W - ks.a_W).norm(), 1e-9);
  // Continuity across the segment boundary (C^(N-2) for the value: pose and velocity here).
  Se3Kinematics<double> before, after;
  const std::int64_t boundary = -500'000'000 + 3 * 50'000'000;
  s.Evaluate(boundary, -1e-9, 1, nullptr, &before);
  s.Evaluate(boundary, 1e-9, 1, nullptr, &after);
  EXPECT_LT((before.p_W_B - after.p_W_B).norm(), 1e-6);
  EXPECT_LT((before.w_B - after.w_B).norm(), 1e-5);
  EXPECT_THROW(s.Evaluate(s.MaxTimeNs() + 1), std::out_of_range);
  EXPECT_THROW(s.Evaluate(s.MinTimeNs(), -1e-9, 0, nullptr, &k), std::out_of_range);
  EXPECT_NO_THROW(s.Evaluate(s.MaxTimeNs()));
}

}  // namespace
}  // namespace ctcal
