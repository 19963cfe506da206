// InertialBlockResidual (the compressed block of one inertial sensor's samples over a run of
// spline segments) against the per-sample blocks it replaces, for the base IMU, an auxiliary IMU
// and an auxiliary gyroscope at 1 kHz on 20 ms knots (20 samples per segment), runs that cross
// bias segments: the cost, the gradient and the Gauss-Newton Hessian of a Ceres problem (tangent
// space, as Ceres sees them) are equal to 1e-9 relative, in L2 and with the Huber loss, also with
// intrinsic blocks held constant; and the run length rule compresses a 1 kHz IMU but not the demo's
// 250 Hz one.
#include "ctcal/calibrator/residuals/inertial_block_residual.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <memory>
#include <random>

#include "ctcal/calibrator/residuals/aux_gyro_residual.h"
#include "ctcal/calibrator/residuals/aux_imu_residual.h"
#include "ctcal/calibrator/residuals/base_imu_residual.h"
#include "ctcal/calibrator/residuals/inertial_row_groups.h"
#include "residual_test_utils.h"

namespace ctcal {
namespace {

constexpr std::int64_t kDtNs = 20'000'000;       // trajectory knots, 20 ms
constexpr std::int64_t kBiasDtNs = 130'000'000;  // bias knots: runs cross bias segments
constexpr std::int64_t kSampleDtNs = 1'000'000;  // 1 kHz
constexpr int kNumKnots = 24;

enum class Kind { kBaseImu, kAuxImu, kAuxGyro };

const char* Name(Kind k) {
  return k == Kind::kBaseImu ? "base IMU" : k == Kind::kAuxImu ? "aux IMU" : "aux gyro";
}

template <typename C>
class InertialBlockTest : public ::testing::Test {
 protected:
  static constexpr int N = C::N;
  static constexpr Se3Representation Rep = C::Rep;
  static constexpr int Nb = C::Nb;
  using Spline = Se3Spline<N, Rep>;
  using Base = BaseImuResidual<N, Rep, Nb>;
  using AuxImu = AuxImuResidual<N, Rep, Nb>;
  using AuxGyro = AuxGyroResidual<N, Rep, Nb>;

  InertialBlockTest()
      : spline_(testing::MakeTrajectory<N, Rep>(kNumKnots, kDtNs, 31)),
        bg_(testing::MakeBias<Nb>(8, kBiasDtNs, 0.01, 32)),
        ba_(testing::MakeBias<Nb>(8, kBiasDtNs, 0.1, 33)),
        g_W_(Eigen::Vector3d(-0.2, 0.1, -9.7).normalized() * 9.81),
        imu_(testing::RandomImuIntrinsics(ImuModel::kImu2, GSensitivity::kFull, 34)),
        gyro_(GyroModel::kUpper) {
    std::mt19937 rng(35);
    q_B_S_ = testing::RandomRotation(&rng, 2.0);
    t_B_S_ = Eigen::Vector3d(0.12, -0.07, 0.05);
    noise_.gyroscope_noise_density = 1.7e-4;
    noise_.gyroscope_random_walk = 2e-5;
    noise_.accelerometer_noise_density = 2e-3;
    noise_.accelerometer_random_walk = 3e-3;
    noise_.update_rate = 1000.0;
  }

  // Stamps of the samples: 1 kHz over the spline's range minus a margin for the time offset.
  std::vector<std::int64_t> Stamps() const {
    std::vector<std::int64_t> t;
    const std::int64_t end = testing::kT0Ns + (kNumKnots - N) * kDtNs - 15'000'000;
    for (std::int64_t s = testing::kT0Ns + 12'000'000; s < end; s += kSampleDtNs)
      t.push_back(s);
    return t;
  }

  int SegmentOf(std::int64_t t_ns, double shift) const {
    const double s = (1e-9 * static_cast<double>(t_ns - testing::kT0Ns) + shift) / (1e-9 * kDtNs);
    return std::min(std::max(static_cast<int>(std::floor(s)), 0), spline_.NumSegments() - 1);
  }
  int BiasSegmentOf(std::int64_t t_ns) const {
    return static_cast<int>((t_ns - testing::kT0Ns) / kBiasDtNs);
  }

  // One sensor's samples as functors of R with their segments, measurements = the model's
  // prediction at the current values plus white noise (sigma 1 after whitening) and, every
  // 50th sample, a 10-sigma outlier (the Huber case).
  template <class R>
  struct Samples {
    std::vector<typename R::Functor> functors;
    std::vector<typename InertialBlockResidual<R>::Raw> raw;  // the same samples, raw
    std::vector<int> seg, bseg;
    std::vector<int> sizes;
  };

  template <class R, class MakeSetup>
  Samples<R> MakeSamples(double shift, std::vector<int> sizes, MakeSetup make_setup) {
    std::mt19937 rng(36);
    std::normal_distribution<double> gauss(0.0, 1.0);
    Samples<R> out;
    out.sizes = std::move(sizes);
    int i = 0;
    for (const std::int64_t t : Stamps()) {
      const int seg = SegmentOf(t, shift);
      const int bseg = BiasSegmentOf(t);
      typename R::Setup setup = make_setup();
      setup.clock = SegmentClock::At(t, spline_.timing(), seg);
      setup.bias_clock = SegmentClock::At(t, bg_.timing(), bseg);
      // r = W (z - pred): with z = 0 the residual gives the prediction.
      double r[R::kNumResiduals];
      const std::vector<double*> blocks = BlocksOf<R>(seg, bseg);
      EXPECT_TRUE(
          R::Analytic::EvaluateSample(typename R::Functor{setup}, blocks.data(), r, nullptr));
      for (int k = 0; k < R::kNumResiduals; ++k) {
        const double outlier = (i % 50 == 7) ? 10.0 : 0.0;
        Measured(&setup, k) =
            -r[k] / Whitening(setup, k) + (gauss(rng) + outlier) / Whitening(setup, k);
      }
      out.functors.push_back(typename R::Functor{setup});
      out.raw.push_back(RawOf(t, setup));
      out.seg.push_back(seg);
      out.bseg.push_back(bseg);
      ++i;
    }
    return out;
  }

  static ImuSample RawOf(std::int64_t t_ns, const ImuSampleSetup& s) {
    ImuSample z;
    z.t_ns = t_ns;
    z.w_m = s.z.w_m;
    z.a_m = s.z.a_m;
    return z;
  }
  static GyroSample RawOf(std::int64_t t_ns, const GyroSampleSetup& s) {
    GyroSample z;
    z.t_ns = t_ns;
    z.w_m = s.w_m;
    return z;
  }
  static double& Measured(ImuSampleSetup* s, int k) {
    return k < 3 ? s->z.w_m(k) : s->z.a_m(k - 3);
  }
  static double& Measured(GyroSampleSetup* s, int k) { return s->w_m(k); }
  static double Whitening(const ImuSampleSetup& s, int k) {
    return k < 3 ? s.W.inv_sigma_gyro : s.W.inv_sigma_accel;
  }
  static double Whitening(const GyroSampleSetup& s, int) { return s.inv_sigma; }

  template <class R>
  std::vector<double*> BlocksOf(int seg, int bseg) {
    typename R::Parameters p;
    p.traj = testing::SegmentBlocks(&spline_, seg);
    p.bg = testing::BiasBlocks(&bg_, bseg);
    if constexpr (std::is_same_v<R, AuxGyro>) {
      p.q_B_S = q_B_S_.coeffs().data();
      p.time_offset = &offset_;
      p.intrinsics = &gyro_;
    } else {
      p.g_W = g_W_.data();
      p.ba = testing::BiasBlocks(&ba_, bseg);
      p.intrinsics = &imu_;
      if constexpr (std::is_same_v<R, AuxImu>) {
        p.q_B_S = q_B_S_.coeffs().data();
        p.t_B_S = t_B_S_.data();
        p.time_offset = &offset_;
      }
    }
    return R::Blocks(p);
  }

  // Every parameter block with its manifold, in one fixed order (the columns of both problems).
  void AddParameters(ceres::Problem* P) {
    for (int k = 0; k < spline_.NumKnots(); ++k) {
      double* d = spline_.KnotData(k);
      if constexpr (Rep == Se3Representation::kJoint) {
        P->AddParameterBlock(d, 7, &se3_);
      } else {
        P->AddParameterBlock(d, 4, &so3_);
        P->AddParameterBlock(d + 4, 3);
      }
    }
    P->AddParameterBlock(g_W_.data(), 3, &sphere_);
    P->AddParameterBlock(q_B_S_.coeffs().data(), 4, &left_);
    P->AddParameterBlock(t_B_S_.data(), 3);
    P->AddParameterBlock(&offset_, 1);
    for (int k = 0; k < bg_.NumKnots(); ++k) {
      P->AddParameterBlock(bg_.KnotData(k), 3);
      P->AddParameterBlock(ba_.KnotData(k), 3);
    }
    for (double* b : {imu_.Dw(), imu_.Da(), imu_.Tg()}) {
      if (b != nullptr)
        P->AddParameterBlock(b, SizeOf(b));
    }
    if (imu_.q_rotation() != nullptr)
      P->AddParameterBlock(imu_.q_rotation(), 4, &left_);
    P->AddParameterBlock(gyro_.Dw(), gyro_.DwSize());
  }

  int SizeOf(const double* b) const {
    const ImuModelLayout& L = imu_.layout();
    if (b == imu_.Dw())
      return StoredSize(L.Dw);
    if (b == imu_.Da())
      return StoredSize(L.Da);
    return StoredSize(L.Tg);
  }

  // Per-sample blocks (K = 0) or compressed (stacked: uncompressed) blocks of K segments over the
  // same samples, owning their functors or (held) reading the raw samples.
  // groups: each compressed block as its row groups (inertial_row_groups.h; the problem must
  // have point_in_memory_ as its evaluation callback).
  template <class R>
  void AddSamples(ceres::Problem* P, const Samples<R>& s, int K, double huber, bool stacked = false,
                  bool held = false, bool groups = false) {
    const std::size_t n = s.functors.size();
    if (K == 0) {
      for (std::size_t i = 0; i < n; ++i) {
        P->AddResidualBlock(new typename R::Analytic(s.functors[i].s),
                            huber > 0.0 ? new ceres::HuberLoss(huber) : nullptr,
                            BlocksOf<R>(s.seg[i], s.bseg[i]));
      }
      return;
    }
    std::size_t begin = 0;
    while (begin < n) {
      std::size_t end = begin + 1;
      while (end < n && s.bseg[end] == s.bseg[begin] && s.seg[end] - s.seg[begin] < K)
        ++end;
      const int first = s.seg[begin];
      const int segments = s.seg[end - 1] - first + 1;
      std::vector<typename R::Functor> f(s.functors.begin() + static_cast<std::ptrdiff_t>(begin),
                                         s.functors.begin() + static_cast<std::ptrdiff_t>(end));
      std::vector<std::uint8_t> offsets;
      for (std::size_t i = begin; i < end; ++i)
        offsets.push_back(static_cast<std::uint8_t>(s.seg[i] - first));
      const std::vector<double*> sample = BlocksOf<R>(first, s.bseg[begin]);
      std::vector<double*> blocks =
          InertialBlockResidual<R>::TrajectoryBlocks(spline_, first, segments);
      std::vector<const ceres::Manifold*> manifolds;
      for (std::size_t b = R::kNumTrajBlocks; b < sample.size(); ++b) {
        blocks.push_back(sample[b]);
        const bool rotation = sample[b] == q_B_S_.coeffs().data() || sample[b] == imu_.q_rotation();
        manifolds.push_back(rotation ? &left_ : nullptr);
      }
      std::unique_ptr<InertialBlockResidual<R>> block;
      if (held) {
        HeldInertialSamples<typename InertialBlockResidual<R>::Raw> h;
        h.samples = s.raw.data() + begin;
        h.trajectory = spline_.timing();
        h.first_segment = first;
        h.bias = bg_.timing();
        h.bias_segment = s.bseg[begin];
        block = std::make_unique<InertialBlockResidual<R>>(
            s.functors[begin], h, std::move(offsets), segments, s.sizes, manifolds, huber, stacked);
      } else {
        block = std::make_unique<InertialBlockResidual<R>>(
            std::move(f), std::move(offsets), segments, s.sizes, manifolds, huber, stacked);
      }
      begin = end;
      if (!groups) {
        P->AddResidualBlock(block.release(), nullptr, blocks);
        continue;
      }
      const auto layout = InertialRowGroups(block->TangentColumns(),
                                            static_cast<int>(blocks.size() - manifolds.size()),
                                            block->num_residuals());
      EXPECT_GE(layout.size(), 2u);
      const auto run = std::make_shared<SharedInertialRun>(std::move(block), blocks,
                                                           &point_in_memory_.generation);
      for (const InertialRowGroupLayout& g : layout) {
        P->AddResidualBlock(new InertialRowGroup(run, g.first_block, g.row0, g.rows,
                                                 static_cast<int>(layout.size())),
                            nullptr,
                            std::vector<double*>(blocks.begin() + g.first_block, blocks.end()));
      }
    }
  }

  struct Eval {
    double cost_only = 0.0;
    double cost = 0.0;
    Eigen::VectorXd gradient;
    Eigen::MatrixXd H;
    Eigen::VectorXd residuals;
    Eigen::MatrixXd J;
  };

  // Two evaluations of the same rows: residuals and a non-zero Jacobian equal to the last bit.
  static void ExpectSameRowsToTheBit(const Eval& a, const Eval& b) {
    ASSERT_EQ(a.residuals.size(), b.residuals.size());
    ASSERT_EQ(a.J.rows(), b.J.rows());
    ASSERT_EQ(a.J.cols(), b.J.cols());
    EXPECT_GT(testing::MaxAbs(a.J), 0.0);
    EXPECT_EQ(testing::MaxAbs(a.residuals - b.residuals), 0.0);
    EXPECT_EQ(testing::MaxAbs(a.J - b.J), 0.0);
  }

  template <class R>
  Eval Evaluate(const Samples<R>& s, int K, double huber, bool intrinsics_constant,
                bool stacked = false, bool held = false, bool groups = false) {
    ceres::Problem::Options po;
    po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    po.evaluation_callback = groups ? &point_in_memory_ : nullptr;
    ceres::Problem P(po);
    AddParameters(&P);
    AddSamples<R>(&P, s, K, huber, stacked, held, groups);
    if (intrinsics_constant) {
      for (double* b : {imu_.Dw(), imu_.Da(), imu_.Tg(), imu_.q_rotation(), gyro_.Dw()}) {
        if (b != nullptr)
          P.SetParameterBlockConstant(b);
      }
    }
    ceres::Problem::EvaluateOptions eo;
    std::vector<double*> all;
    P.GetParameterBlocks(&all);
    for (double* b : all) {
      std::vector<ceres::ResidualBlockId> users;
      P.GetResidualBlocksForParameterBlock(b, &users);
      if (!users.empty())
        eo.parameter_blocks.push_back(b);  // the same columns in both problems
    }
    eo.num_threads = 2;  // the row groups of a run meet on both threads
    Eval e;
    std::vector<double> g, residuals;
    ceres::CRSMatrix crs;
    // The cost alone first (the row groups' residual-only path), then everything.
    EXPECT_TRUE(P.Evaluate(eo, &e.cost_only, nullptr, nullptr, nullptr));
    EXPECT_TRUE(P.Evaluate(eo, &e.cost, &residuals, &g, &crs));
    e.residuals = Eigen::Map<const Eigen::VectorXd>(residuals.data(),
                                                    static_cast<Eigen::Index>(residuals.size()));
    e.gradient = Eigen::Map<const Eigen::VectorXd>(g.data(), static_cast<Eigen::Index>(g.size()));
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
    for (int r = 0; r < crs.num_rows; ++r) {
      for (int i = crs.rows[r]; i < crs.rows[r + 1]; ++i)
        J(r, crs.cols[i]) = crs.values[i];
    }
    e.H = J.transpose() * J;
    e.J = std::move(J);
    return e;
  }

  // Cost, gradient and Hessian equal; the Hessian compared after scaling by its diagonal, so
  // that the small intrinsic and bias entries are held to the same relative tolerance as the
  // knots'.
  template <class R>
  void ExpectEqual(const Samples<R>& s, int K, double huber, bool constant, const char* what) {
    SCOPED_TRACE(std::string(what) + " K " + std::to_string(K) + " huber " + std::to_string(huber) +
                 (constant ? " intrinsics constant" : ""));
    const Eval a = Evaluate<R>(s, 0, huber, constant);
    const Eval b = Evaluate<R>(s, K, huber, constant);
    EXPECT_GT(a.cost, 0.3 * static_cast<double>(s.functors.size()));  // noise: far from zero
    EXPECT_NEAR(b.cost, a.cost, 1e-10 * a.cost);
    ASSERT_EQ(a.gradient.size(), b.gradient.size());
    EXPECT_LT((b.gradient - a.gradient).cwiseAbs().maxCoeff(),
              1e-9 * a.gradient.cwiseAbs().maxCoeff());
    const Eigen::VectorXd d = a.H.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
    const Eigen::MatrixXd diff = d.asDiagonal() * (b.H - a.H) * d.asDiagonal();
    EXPECT_LT(testing::MaxAbs(diff), 1e-9);
    EXPECT_LT(testing::MaxAbs(a.H.diagonal() - b.H.diagonal()),
              1e-9 * testing::MaxAbs(a.H.diagonal()));
  }

  template <class R>
  void ExpectStackedSame(const Samples<R>& s, const char* what) {
    for (const int K : {1, 3}) {
      for (const bool constant : {false, true}) {
        SCOPED_TRACE(std::string(what) + " K " + std::to_string(K) +
                     (constant ? " intrinsics constant" : ""));
        const Eval a = Evaluate<R>(s, 0, 0.0, constant);
        const Eval b = Evaluate<R>(s, K, 0.0, constant, true);
        ASSERT_EQ(a.residuals.size(), b.residuals.size());
        ASSERT_EQ(a.J.rows(), b.J.rows());
        ASSERT_EQ(a.J.cols(), b.J.cols());
        EXPECT_EQ(testing::MaxAbs(a.residuals - b.residuals), 0.0);
        EXPECT_EQ(testing::MaxAbs(a.J - b.J), 0.0);
        EXPECT_NEAR(b.cost, a.cost, 1e-12 * a.cost);
      }
    }
  }

  // Held samples (placed on their segments by the block) against owned functors: residuals and
  // Jacobian equal to the last bit, compressed (L2, Huber) and stacked.
  template <class R>
  void ExpectHeldSame(const Samples<R>& s, const char* what) {
    for (const bool stacked : {false, true}) {
      for (const double huber : {0.0, 3.0}) {
        if (stacked && huber > 0.0)
          continue;
        SCOPED_TRACE(std::string(what) + (stacked ? " stacked" : " compressed") + " huber " +
                     std::to_string(huber));
        const Eval a = Evaluate<R>(s, 3, huber, false, stacked, false);
        const Eval b = Evaluate<R>(s, 3, huber, false, stacked, true);
        ExpectSameRowsToTheBit(a, b);
        EXPECT_EQ(a.cost, b.cost);
      }
    }
  }

  // Row groups (the rows of each compressed block cut at block boundaries, each group over the
  // blocks from its first) against the whole blocks: residuals and Jacobian equal to the last
  // bit, the cost with and without Jacobians to rounding; L2 and Huber, intrinsics free and
  // constant, owned and held samples.
  template <class R>
  void ExpectRowGroupsSame(const Samples<R>& s, const char* what) {
    for (const double huber : {0.0, 3.0}) {
      for (const bool constant : {false, true}) {
        for (const bool held : {false, true}) {
          SCOPED_TRACE(std::string(what) + " huber " + std::to_string(huber) +
                       (constant ? " intrinsics constant" : "") + (held ? " held" : ""));
          const Eval a = Evaluate<R>(s, 4, huber, constant, false, held, false);
          const Eval b = Evaluate<R>(s, 4, huber, constant, false, held, true);
          ExpectSameRowsToTheBit(a, b);
          EXPECT_NEAR(b.cost, a.cost, 1e-13 * a.cost);
          EXPECT_NEAR(b.cost_only, a.cost, 1e-13 * a.cost);
          EXPECT_NEAR(a.cost_only, a.cost, 1e-13 * a.cost);
        }
      }
    }
  }

  // Two Levenberg-Marquardt iterations from a perturbed point (every block free, two threads):
  // the same steps with row groups as with whole blocks (the groups read the knots before their
  // first block from the blocks' memory at each point Ceres evaluates). Returns the parameters.
  template <class R>
  Eigen::VectorXd SolveTwice(const Samples<R>& s, bool groups) {
    ceres::Problem::Options po;
    po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    po.evaluation_callback = groups ? &point_in_memory_ : nullptr;
    ceres::Problem P(po);
    AddParameters(&P);
    AddSamples<R>(&P, s, 4, 0.0, false, true, groups);
    std::vector<double*> all;
    P.GetParameterBlocks(&all);
    std::vector<std::vector<double>> start;
    for (double* b : all)
      start.emplace_back(b, b + P.ParameterBlockSize(b));
    for (double* b : all) {
      std::vector<ceres::ResidualBlockId> users;
      P.GetResidualBlocksForParameterBlock(b, &users);
      if (users.empty())
        P.SetParameterBlockConstant(b);
    }
    // Move the knots' positions off the data's point (the rotations stay unit quaternions).
    for (int k = 0; k < spline_.NumKnots(); ++k)
      spline_.KnotData(k)[4] += 1e-3 * std::sin(0.7 * k);
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_QR;
    so.max_num_iterations = 2;
    so.num_threads = 2;
    so.function_tolerance = 0.0;
    so.gradient_tolerance = 0.0;
    so.parameter_tolerance = 0.0;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &P, &summary);
    EXPECT_EQ(summary.iterations.size(), 3u) << summary.FullReport();
    std::vector<double> values;
    for (std::size_t i = 0; i < all.size(); ++i) {
      const int size = P.ParameterBlockSize(all[i]);
      values.insert(values.end(), all[i], all[i] + size);
      std::copy(start[i].begin(), start[i].end(), all[i]);  // back to the fixture's point
    }
    return Eigen::Map<const Eigen::VectorXd>(values.data(),
                                             static_cast<Eigen::Index>(values.size()));
  }

  // Counts the evaluation passes: the row groups' evaluation point (inertial_row_groups.h).
  struct PointInMemory : ceres::EvaluationCallback {
    void PrepareForEvaluation(bool, bool) override { generation.fetch_add(1); }
    std::atomic<std::uint64_t> generation{0};
  } point_in_memory_;

  Samples<Base> BaseSamples() {
    return MakeSamples<Base>(0.0, Base::BlockSizes(imu_.layout()), [&] {
      ImuSampleSetup s;
      s.layout = imu_.layout();
      s.W = ImuWhitening::Of(noise_);
      return s;
    });
  }
  Samples<AuxImu> AuxImuSamples() {
    return MakeSamples<AuxImu>(offset_, AuxImu::BlockSizes(imu_.layout()), [&] {
      ImuSampleSetup s;
      s.layout = imu_.layout();
      s.W = ImuWhitening::Of(noise_);
      return s;
    });
  }
  Samples<AuxGyro> AuxGyroSamples() {
    return MakeSamples<AuxGyro>(offset_, AuxGyro::BlockSizes(gyro_.model()), [&] {
      GyroSampleSetup s;
      s.model = gyro_.model();
      s.inv_sigma = 1.0 / noise_.GyroSampleSigma();
      return s;
    });
  }

  Spline spline_;
  RdSpline<3, Nb> bg_;
  RdSpline<3, Nb> ba_;
  Eigen::Vector3d g_W_;
  Eigen::Quaterniond q_B_S_;
  Eigen::Vector3d t_B_S_;
  double offset_ = 0.0047;
  ImuIntrinsics imu_;
  GyroIntrinsics gyro_;
  InertialNoise noise_;
  So3RightManifold so3_;
  Se3RightManifold se3_;
  So3LeftManifold left_;
  ceres::SphereManifold<3> sphere_;
};

using Configs = ::testing::Types<testing::InertialConfig<4, Se3Representation::kSplit, 2>,
                                 testing::InertialConfig<5, Se3Representation::kJoint, 3>>;
TYPED_TEST_SUITE(InertialBlockTest, Configs);

TYPED_TEST(InertialBlockTest, CostGradientAndHessianEqualPerSample) {
  const auto base = this->BaseSamples();
  const auto aux = this->AuxImuSamples();
  const auto gyro = this->AuxGyroSamples();
  for (const int K : {1, 4}) {
    for (const double huber : {0.0, 3.0}) {
      for (const bool constant : {false, true}) {
        this->ExpectEqual(base, K, huber, constant, Name(Kind::kBaseImu));
        this->ExpectEqual(aux, K, huber, constant, Name(Kind::kAuxImu));
        this->ExpectEqual(gyro, K, huber, constant, Name(Kind::kAuxGyro));
      }
    }
  }
}

// The run length rule (InertialBlockSegments) on the base IMU of the default rig (imu2, full
// g-sensitivity: gravity 3 + biases 12 + intrinsics 25 ambient columns, rank 39), cubic spline,
// 0.029 s knots: compressed at 1 kHz (29 samples per segment), per-sample blocks at the demo's
// 250 Hz (7.25), where a compressed block would not halve Ceres' J^T J work.
TEST(InertialBlockSegmentsTest, CompressesOneKilohertzNotTheDemoRate) {
  const int at_1k = InertialBlockSegments(29.0, 6, 4, 40, 39);
  EXPECT_GE(at_1k, 4);
  EXPECT_LE(at_1k, 16);
  EXPECT_EQ(InertialBlockSegments(7.25, 6, 4, 40, 39), 0);
  EXPECT_EQ(InertialBlockSegments(5.8, 3, 4, 12, 11), 0);  // the 200 Hz gyro
}

// The stacked form hands Ceres the per-sample blocks' rows themselves: residuals and Jacobian
// equal to the last bit (same functions, same order), so the cost and the normal equations differ
// only by the summation order; runs of 1 and 3 segments (K > 1: knots a sample does not touch are
// zero columns), intrinsics free and constant.
TYPED_TEST(InertialBlockTest, StackedBlocksHoldThePerSampleRowsExactly) {
  this->ExpectStackedSame(this->BaseSamples(), Name(Kind::kBaseImu));
  this->ExpectStackedSame(this->AuxImuSamples(), Name(Kind::kAuxImu));
  this->ExpectStackedSame(this->AuxGyroSamples(), Name(Kind::kAuxGyro));
}

// A block over samples the calibrator holds (1 byte per sample instead of a functor) is the block
// over owned functors to the bit: each sample is placed on its segments by the same arithmetic.
TYPED_TEST(InertialBlockTest, HeldSamplesGiveTheOwnedBlockExactly) {
  this->ExpectHeldSame(this->BaseSamples(), Name(Kind::kBaseImu));
  this->ExpectHeldSame(this->AuxImuSamples(), Name(Kind::kAuxImu));
  this->ExpectHeldSame(this->AuxGyroSamples(), Name(Kind::kAuxGyro));
}

// Row groups hold the whole block's rows: the same residuals and Jacobian to the bit, the same
// cost; base IMU, auxiliary IMU, gyroscope.
TYPED_TEST(InertialBlockTest, RowGroupsHoldTheWholeBlocksRowsExactly) {
  this->ExpectRowGroupsSame(this->BaseSamples(), Name(Kind::kBaseImu));
  this->ExpectRowGroupsSame(this->AuxImuSamples(), Name(Kind::kAuxImu));
  this->ExpectRowGroupsSame(this->AuxGyroSamples(), Name(Kind::kAuxGyro));
}

// Two solver iterations (evaluations at new points, candidate steps residual-only): the row
// groups take the whole blocks' steps, to rounding of the summation order.
TYPED_TEST(InertialBlockTest, RowGroupsTakeTheWholeBlocksSteps) {
  const auto base = this->BaseSamples();
  const Eigen::VectorXd a = this->SolveTwice(base, false);
  const Eigen::VectorXd b = this->SolveTwice(base, true);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_LT((a - b).cwiseAbs().maxCoeff(), 1e-10);
}

// The groups of a 1 kHz run on a cubic split spline (K = 9: 12 rotation and 12 position knots,
// then the common blocks): four trajectory parts and the common rows with the remainder row.
TEST(InertialRowGroupsTest, CutsTheTrajectoryInFourAndKeepsTheCommonRows) {
  std::vector<int> tan_col;
  for (int b = 0; b < 24; ++b)
    tan_col.push_back(3 * b);
  // The common blocks' starts: 72, then after gravity (2), biases (4 x 3), Dw, Da, Tg, R_I_a.
  int col = 72;
  for (const int size : {2, 3, 3, 3, 3, 6, 6, 9, 3}) {
    tan_col.push_back(col);
    col += size;
  }
  const auto groups = InertialRowGroups(tan_col, 24, col + 1);
  ASSERT_EQ(groups.size(), 5u);
  const int first[] = {0, 6, 12, 18, 24};
  int row = 0;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    EXPECT_EQ(groups[g].first_block, first[g]);
    EXPECT_EQ(groups[g].row0, row);
    row += groups[g].rows;
  }
  EXPECT_EQ(row, col + 1);  // every row once, the remainder row in the last group
  EXPECT_EQ(groups.back().rows, col + 1 - 72);
}

TEST(InertialBlockStackedTest, RefusesARobustLoss) {
  using R = BaseImuResidual<4, Se3Representation::kSplit, 2>;
  ImuSampleSetup setup;
  std::vector<R::Functor> samples;
  samples.emplace_back(setup);
  const std::vector<int> sizes = R::BlockSizes(setup.layout);
  const std::vector<const ceres::Manifold*> manifolds(sizes.size() - R::kNumTrajBlocks, nullptr);
  EXPECT_THROW(InertialBlockResidual<R>(samples, {0}, 1, sizes, manifolds, 3.0, true),
               std::invalid_argument);
}

}  // namespace
}  // namespace ctcal
