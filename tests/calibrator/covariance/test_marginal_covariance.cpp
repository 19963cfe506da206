// The marginal covariance must equal the calibration block of the full inverse on well-posed
// problems, and say "undetermined" exactly for the parameters of null directions.
#include <ceres/autodiff_cost_function.h>
#include <ceres/crs_matrix.h>
#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "ctcal/calibrator/marginal_covariance.h"
#include "ctcal/spline/so3.h"
#include "ctcal/spline/so3_manifold.h"

namespace ctcal {
namespace {

// r = A * [x0; x1; y] - b over blocks of sizes 3, 3, 2 (nuisance x0, x1; calibration y).
struct LinearResidual {
  LinearResidual(const Eigen::Matrix<double, 4, 8>& A, const Eigen::Vector4d& b) : A_(A), b_(b) {}
  template <typename T>
  bool operator()(const T* x0, const T* x1, const T* y, T* r) const {
    T stacked[8] = {x0[0], x0[1], x0[2], x1[0], x1[1], x1[2], y[0], y[1]};
    for (int i = 0; i < 4; ++i) {
      r[i] = T(-b_(i));
      for (int j = 0; j < 8; ++j)
        r[i] += T(A_(i, j)) * stacked[j];
    }
    return true;
  }
  Eigen::Matrix<double, 4, 8> A_;
  Eigen::Vector4d b_;
};

struct ScalarPrior {
  ScalarPrior(int index, double sigma) : index_(index), sigma_(sigma) {}
  template <typename T>
  bool operator()(const T* y, T* r) const {
    r[0] = y[index_] / T(sigma_);
    return true;
  }
  int index_;
  double sigma_;
};

struct SumResidual {
  template <typename T>
  bool operator()(const T* xs, const T* ys, const T* zs, T* r) const {
    r[0] = xs[0] + ys[0] + ys[1];
    r[1] = xs[1] - xs[0];
    r[2] = xs[2] + T(2) * zs[0];
    r[3] = xs[0] + xs[1] + xs[2];
    r[4] = zs[0];
    r[5] = xs[1] + T(3) * xs[2];
    return true;
  }
};

struct Diff {
  template <typename T>
  bool operator()(const T* xs, const T* ys, T* r) const {
    r[0] = xs[0] - ys[0];
    r[1] = xs[0] + ys[1];
    return true;
  }
};

struct RotationMeasurement {
  RotationMeasurement(const Eigen::Quaterniond& q, double sigma) : q_meas(q), sigma(sigma) {}
  template <typename T>
  bool operator()(const T* q_data, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(q_data);
    const Vec3T<T> e = LogSO3<T>(q * q_meas.cast<T>().conjugate());
    for (int i = 0; i < 3; ++i)
      r[i] = e(i) / T(sigma);
    return true;
  }
  Eigen::Quaterniond q_meas;
  double sigma;
};

struct Three {
  template <typename T>
  bool operator()(const T* a, const T* b, const T* c, T* r) const {
    r[0] = a[0] + b[0];
    r[1] = a[0] - c[0];
    r[2] = b[0];
    return true;
  }
};

TEST(MarginalCovariance, EqualsBlockOfFullInverse) {
  std::mt19937 rng(7);
  std::normal_distribution<double> gauss;
  double x0[3] = {0, 0, 0}, x1[3] = {0, 0, 0}, y[2] = {0, 0};
  ceres::Problem problem;
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(8, 8);
  for (int k = 0; k < 6; ++k) {
    Eigen::Matrix<double, 4, 8> A;
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 8; ++j)
        A(i, j) = gauss(rng);
    }
    H += A.transpose() * A;
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<LinearResidual, 4, 3, 3, 2>(
                                 new LinearResidual(A, Eigen::Vector4d::Zero())),
                             nullptr, x0, x1, y);
  }
  const MarginalInformation info =
      ComputeMarginalInformation(problem, {{y, {"y[0]", "y[1]"}, {1.0, 1.0}}});
  EXPECT_EQ(info.nuisance_dimension, 6);
  EXPECT_EQ(info.nuisance_damping, 0.0);
  const Eigen::Matrix2d expected = H.inverse().bottomRightCorner<2, 2>();
  const CalibrationCovariance cov = InvertInformation(info);
  EXPECT_LT((cov.covariance - expected).norm(), 1e-9 * expected.norm());
  EXPECT_NEAR(cov.sigma(0), std::sqrt(expected(0, 0)), 1e-9);
  EXPECT_TRUE(cov.null_directions.empty());
}

// A nuisance block no residual touches (a knot beyond the kept samples) has no information and
// couples to nothing: the marginal information must be exactly that of the problem without it,
// with no damping of the others.
TEST(MarginalCovariance, UntouchedNuisanceBlockIsLeftOutExactly) {
  std::mt19937 rng(9);
  std::normal_distribution<double> gauss;
  double x0[3] = {0, 0, 0}, x1[3] = {0, 0, 0}, y[2] = {0, 0}, unused[6] = {0, 0, 0, 0, 0, 0};
  ceres::Problem with, without;
  with.AddParameterBlock(unused, 6);
  for (int k = 0; k < 3; ++k) {
    Eigen::Matrix<double, 4, 8> A;
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 8; ++j)
        A(i, j) = gauss(rng);
    }
    for (ceres::Problem* p : {&with, &without}) {
      p->AddResidualBlock(new ceres::AutoDiffCostFunction<LinearResidual, 4, 3, 3, 2>(
                              new LinearResidual(A, Eigen::Vector4d::Zero())),
                          nullptr, x0, x1, y);
    }
  }
  const std::vector<CalibrationBlock> calib = {{y, {"y[0]", "y[1]"}, {1.0, 1.0}}};
  const MarginalInformation a = ComputeMarginalInformation(with, calib);
  const MarginalInformation b = ComputeMarginalInformation(without, calib);
  EXPECT_EQ(a.nuisance_damping, 0.0);
  EXPECT_LT((a.information - b.information).norm(), 1e-12 * b.information.norm());
}

TEST(MarginalCovariance, NullDirectionMarksOnlyItsParameters) {
  // y[0] and y[1] are only seen as their sum; z is observed directly.
  double x[3] = {0, 0, 0}, y[2] = {0, 0}, z[1] = {0};
  ceres::Problem problem;
  problem.AddResidualBlock(
      new ceres::AutoDiffCostFunction<SumResidual, 6, 3, 2, 1>(new SumResidual), nullptr, x, y, z);
  const MarginalInformation info =
      ComputeMarginalInformation(problem, {{y, {"y[0]", "y[1]"}, {1.0, 1.0}}, {z, {"z"}, {1.0}}});
  const CalibrationCovariance cov = InvertInformation(info);
  // x is fixed by r1, r3, r5 and z by r2, r4; the data see y[0] + y[1] only.
  ASSERT_EQ(cov.null_directions.size(), 1u);
  EXPECT_TRUE(cov.undetermined[0]);
  EXPECT_TRUE(cov.undetermined[1]);
  EXPECT_TRUE(std::isinf(cov.sigma(0)));
  EXPECT_FALSE(cov.undetermined[2]);
  EXPECT_TRUE(std::isfinite(cov.sigma(2)));
}

// A null direction through a lens' projection parameter carries the camera's other intrinsics
// along, even below the loading threshold: here the data see b and c - L a only, so along
// (1, 0, L) a moves freely and c with it by L a (omni-radtan's k2 on the xi-k1-focal direction
// loads 0.06-0.07, docs/initialisation.md). With L = 0.05 an estimate whose a is off by 1 has c
// off by 0.05, 5 of c's pseudo-inverse sigmas: c must be undetermined when a is an omni camera's
// xi and c its k2, b (no loading) not. A null direction with a tiny eigenvalue (1e-14 of the
// largest, below the null rule) gives the same answers; L = 1e-6 leaves c determined (a drift of
// 200 moves it by 0.02 sigma), and so does a motion gauge (a leads, not an intrinsic) with L =
// 0.05: the loading rule alone.
TEST(MarginalCovariance, LensNullDirectionCarriesTheOtherIntrinsics) {
  // cam0 is an omni camera: intrinsics [xi, fu, fv, pu, pv], xi its projection parameter.
  const std::vector<std::string> lens = {"cam0.intrinsics[0]", "cam0.intrinsics[4]",
                                         "cam0.distortion_coeffs[1]"};
  const std::vector<std::string> gauge = {"imu0.R_B_S[2]", "cam0.t_B_S[0]", "cam0.intrinsics[3]"};
  for (const double loading : {0.05, 1e-6}) {
    for (const double weak : {0.0, 1e-5}) {
      for (const auto* names : {&lens, &gauge}) {
        // Rows of J: 100 b, 100 (c - loading a) and weak (a + loading c).
        Eigen::Matrix3d J;
        J << 0.0, 100.0, 0.0, -100.0 * loading, 0.0, 100.0, weak, 0.0, loading * weak;
        MarginalInformation info;
        info.information = J.transpose() * J;
        info.names = *names;
        info.unit = Eigen::Vector3d::Ones();
        const CalibrationCovariance cov = InvertInformation(info);
        const std::string what =
            (*names)[2] + ", loading " + std::to_string(loading) + ", weak " + std::to_string(weak);
        ASSERT_EQ(cov.null_directions.size(), 1u) << what;
        const Eigen::VectorXd v = cov.scaled_eigenvectors.col(cov.null_directions[0]);
        EXPECT_NEAR(std::abs(v(2)), loading / std::sqrt(1.0 + loading * loading), 1e-9) << what;
        EXPECT_TRUE(cov.undetermined[0]) << what;
        EXPECT_FALSE(cov.undetermined[1]) << what;
        EXPECT_NEAR(cov.sigma(1), 0.01, 1e-12) << what;
        const bool carried = names == &lens && loading > 1e-3;
        EXPECT_EQ(cov.undetermined[2], carried) << what;
        EXPECT_EQ(std::isinf(cov.sigma(2)), carried) << what;
      }
    }
  }
}

TEST(MarginalCovariance, PriorsDetermineANullDirectionUnlessExcluded) {
  double x[1] = {0}, y[2] = {0, 0};
  ceres::Problem problem;
  const auto data = problem.AddResidualBlock(
      new ceres::AutoDiffCostFunction<Diff, 2, 1, 2>(new Diff), nullptr, x, y);
  problem.AddResidualBlock(
      new ceres::AutoDiffCostFunction<ScalarPrior, 1, 2>(new ScalarPrior(0, 0.5)), nullptr, y);
  const std::vector<CalibrationBlock> calib = {{y, {"y[0]", "y[1]"}, {1.0, 1.0}}};

  const CalibrationCovariance with_prior =
      InvertInformation(ComputeMarginalInformation(problem, calib));
  EXPECT_TRUE(with_prior.null_directions.empty());
  // With x marginalised the data give y[0] + y[1] with variance 2; the prior pins y[0] with
  // sigma 0.5, so var(y[1]) = 0.25 + 2.
  EXPECT_NEAR(with_prior.sigma(0), 0.5, 1e-9);
  EXPECT_NEAR(with_prior.sigma(1), 1.5, 1e-9);

  const CalibrationCovariance data_only =
      InvertInformation(ComputeMarginalInformation(problem, calib, {data}));
  EXPECT_EQ(data_only.null_directions.size(), 1u);
  EXPECT_TRUE(data_only.undetermined[0]);
  EXPECT_TRUE(data_only.undetermined[1]);
}

// The data's Schur complement plus the priors' information (AddCalibrationInformation) equals the
// Schur complement of data and priors together: the pipeline factors H_nn once.
TEST(MarginalCovariance, PriorInformationAddsToTheDataSchurComplement) {
  std::mt19937 rng(3);
  std::normal_distribution<double> gauss;
  double x0[3] = {0, 0, 0}, x1[3] = {0, 0, 0}, y[2] = {0.1, -0.2};
  ceres::Problem problem;
  std::vector<ceres::ResidualBlockId> data, priors;
  for (int k = 0; k < 3; ++k) {
    Eigen::Matrix<double, 4, 8> A;
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 8; ++j)
        A(i, j) = gauss(rng);
    }
    data.push_back(
        problem.AddResidualBlock(new ceres::AutoDiffCostFunction<LinearResidual, 4, 3, 3, 2>(
                                     new LinearResidual(A, Eigen::Vector4d::Zero())),
                                 nullptr, x0, x1, y));
  }
  priors.push_back(problem.AddResidualBlock(
      new ceres::AutoDiffCostFunction<ScalarPrior, 1, 2>(new ScalarPrior(0, 0.5)), nullptr, y));
  priors.push_back(problem.AddResidualBlock(
      new ceres::AutoDiffCostFunction<ScalarPrior, 1, 2>(new ScalarPrior(1, 0.2)), nullptr, y));
  const std::vector<CalibrationBlock> calib = {{y, {"y[0]", "y[1]"}, {1.0, 1.0}}};
  const MarginalInformation all = ComputeMarginalInformation(problem, calib);
  MarginalInformation sum = ComputeMarginalInformation(problem, calib, data);
  const Eigen::MatrixXd data_only = sum.information;
  AddCalibrationInformation(problem, calib, priors, &sum);
  EXPECT_LT((sum.information - all.information).norm(), 1e-12 * all.information.norm());
  EXPECT_NEAR((sum.information - data_only)(0, 0), 4.0, 1e-12);   // 1 / 0.5^2
  EXPECT_NEAR((sum.information - data_only)(1, 1), 25.0, 1e-12);  // 1 / 0.2^2
  // A "prior" on a nuisance block is refused.
  EXPECT_THROW(AddCalibrationInformation(problem, calib, data, &sum), std::logic_error);
}

// More residual blocks than one chunk of the accumulation (4096): the chunked J^T J equals the
// dense one, and summing chunks on a second thread (threads = 2) gives the same bits.
TEST(MarginalCovariance, ChunksOnTwoThreadsGiveTheSameInformation) {
  std::mt19937 rng(11);
  std::normal_distribution<double> gauss;
  // A chain of 420 nuisance blocks (3 each) with a shared 2-vector, 10 residuals per link.
  constexpr int kBlocks = 420;
  std::vector<std::array<double, 3>> x(kBlocks, {0.0, 0.0, 0.0});
  double y[2] = {0.0, 0.0};
  ceres::Problem problem;
  const int dim = 3 * kBlocks + 2;
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(dim, dim);
  for (int k = 0; k + 1 < kBlocks; ++k) {
    for (int m = 0; m < 10; ++m) {
      Eigen::Matrix<double, 4, 8> A;
      for (int i = 0; i < 4; ++i) {
        for (int j = 0; j < 8; ++j)
          A(i, j) = gauss(rng);
      }
      const Eigen::Matrix<double, 8, 8> AtA = A.transpose() * A;
      int col[8] = {3 * k, 3 * k + 1, 3 * k + 2, 3 * k + 3, 3 * k + 4, 3 * k + 5, dim - 2, dim - 1};
      for (int i = 0; i < 8; ++i) {
        for (int j = 0; j < 8; ++j)
          H(col[i], col[j]) += AtA(i, j);
      }
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<LinearResidual, 4, 3, 3, 2>(
                                   new LinearResidual(A, Eigen::Vector4d::Zero())),
                               nullptr, x[static_cast<std::size_t>(k)].data(),
                               x[static_cast<std::size_t>(k + 1)].data(), y);
    }
  }
  ASSERT_GT(problem.NumResidualBlocks(), 4096);
  const std::vector<CalibrationBlock> calib = {{y, {"y[0]", "y[1]"}, {1.0, 1.0}}};
  const MarginalInformation serial = ComputeMarginalInformation(problem, calib, {}, 1);
  const MarginalInformation parallel = ComputeMarginalInformation(problem, calib, {}, 2);
  EXPECT_EQ(serial.information, parallel.information);
  const Eigen::Matrix2d expected =
      H.ldlt().solve(Eigen::MatrixXd::Identity(dim, dim)).bottomRightCorner<2, 2>().inverse();
  EXPECT_LT((serial.information - expected).norm(), 1e-8 * expected.norm());
}

// A rotation measured directly with isotropic noise sigma (in the full-angle left perturbation)
// must come back with exactly that sigma: checks the manifold's tangent convention end to end.
TEST(MarginalCovariance, RotationSigmaUsesFullAngleLeftPerturbation) {
  const Eigen::Quaterniond q_true =
      Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  Eigen::Quaterniond q = q_true;
  ceres::Problem problem;
  problem.AddParameterBlock(q.coeffs().data(), 4, new So3LeftManifold);
  problem.AddResidualBlock(new ceres::AutoDiffCostFunction<RotationMeasurement, 3, 4>(
                               new RotationMeasurement(q_true, 0.01)),
                           nullptr, q.coeffs().data());
  const double deg = M_PI / 180.0;
  const CalibrationCovariance cov = InvertInformation(ComputeMarginalInformation(
      problem, {{q.coeffs().data(), {"R[0]", "R[1]", "R[2]"}, {deg, deg, deg}}}));
  for (int i = 0; i < 3; ++i)
    EXPECT_NEAR(cov.sigma(i), 0.01, 1e-9);
}

// r = sum_b A_b x_b over any parameter blocks (ambient coordinates), for random sparsity patterns.
class LinearBlocks : public ceres::CostFunction {
 public:
  LinearBlocks(std::vector<Eigen::MatrixXd> A) : A_(std::move(A)) {
    set_num_residuals(static_cast<int>(A_.front().rows()));
    for (const Eigen::MatrixXd& a : A_)
      mutable_parameter_block_sizes()->push_back(static_cast<int>(a.cols()));
  }
  bool Evaluate(double const* const* x, double* r, double** jacobians) const override {
    Eigen::Map<Eigen::VectorXd> e(r, num_residuals());
    e.setZero();
    for (std::size_t b = 0; b < A_.size(); ++b) {
      e += A_[b] * Eigen::Map<const Eigen::VectorXd>(x[b], A_[b].cols());
      if (jacobians != nullptr && jacobians[b] != nullptr)
        Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
            jacobians[b], A_[b].rows(), A_[b].cols()) = A_[b];
    }
    return true;
  }

 private:
  std::vector<Eigen::MatrixXd> A_;
};

// The in-place accumulation of H (its nuisance part as a fixed lower-triangular pattern) must give
// the Schur complement of the dense J^T J, whatever order the residual blocks list their
// parameter blocks in, with manifolds (tangent < ambient), constant blocks of both kinds, an
// untouched nuisance block, and residual blocks that touch calibration blocks only.
TEST(MarginalCovariance, InPlaceAccumulationEqualsTheDenseSchurComplement) {
  std::mt19937 rng(23);
  std::normal_distribution<double> gauss;
  // Nuisance: 30 blocks of sizes 1..3 and 5 unit quaternions; calibration: a 2-vector, a
  // quaternion, a constant 3-vector; plus a constant and an untouched nuisance block.
  std::vector<std::vector<double>> values;
  for (int k = 0; k < 30; ++k)
    values.emplace_back(static_cast<std::size_t>(1 + k % 3), 0.1 * k);
  for (int k = 0; k < 5; ++k)
    values.push_back({0.1 * k, 0.2, -0.3, 1.0});
  values.push_back({0.5, -0.5});           // 35: calibration 2-vector
  values.push_back({0.1, 0.2, 0.3, 1.0});  // 36: calibration quaternion
  values.push_back({1.0, 2.0, 3.0});       // 37: constant calibration
  values.push_back({4.0, 5.0});            // 38: constant nuisance
  values.push_back({6.0});                 // 39: untouched nuisance
  for (std::vector<double>& q : values) {
    if (q.size() == 4)
      Eigen::Map<Eigen::Vector4d>(q.data()).normalize();
  }
  ceres::EigenQuaternionManifold quaternion;
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  for (std::vector<double>& v : values) {
    if (v.size() == 4)
      problem.AddParameterBlock(v.data(), 4, &quaternion);
    else
      problem.AddParameterBlock(v.data(), static_cast<int>(v.size()));
  }
  problem.SetParameterBlockConstant(values[37].data());
  problem.SetParameterBlockConstant(values[38].data());
  // Residual blocks over a window of nearby nuisance blocks (a chain, as knots are), in shuffled
  // order, with a random subset of the calibration and constant blocks.
  for (int r = 0; r < 300; ++r) {
    std::vector<int> blocks;
    const int first = r % 33;
    for (int k = first; k < first + 3; ++k)
      blocks.push_back(k);
    if (r % 10 == 0)
      blocks = {35, 36};  // calibration only
    for (const int extra : {35, 36, 37, 38}) {
      if (std::find(blocks.begin(), blocks.end(), extra) == blocks.end() && rng() % 2 == 0)
        blocks.push_back(extra);
    }
    std::shuffle(blocks.begin(), blocks.end(), rng);
    const int rows = 2 + static_cast<int>(rng() % 6);
    std::vector<Eigen::MatrixXd> A;
    std::vector<double*> pointers;
    for (const int b : blocks) {
      Eigen::MatrixXd a(rows, static_cast<int>(values[static_cast<std::size_t>(b)].size()));
      for (int i = 0; i < a.size(); ++i)
        a.data()[i] = gauss(rng);
      A.push_back(a);
      pointers.push_back(values[static_cast<std::size_t>(b)].data());
    }
    problem.AddResidualBlock(new LinearBlocks(A), nullptr, pointers);
  }
  const std::vector<CalibrationBlock> calib = {
      {values[35].data(), {"a0", "a1"}, {1.0, 1.0}},
      {values[36].data(), {"q0", "q1", "q2"}, {1.0, 1.0, 1.0}},
      {values[37].data(), {"c0", "c1", "c2"}, {1.0, 1.0, 1.0}}};
  const MarginalInformation info = ComputeMarginalInformation(problem, calib, {}, 2);
  ASSERT_EQ(info.names.size(), 5u);
  EXPECT_EQ(info.nuisance_damping, 0.0);

  // Reference: the dense J^T J over (touched nuisance, calibration), tangent coordinates.
  ceres::Problem::EvaluateOptions eval;
  for (std::size_t b = 0; b < 35; ++b)
    eval.parameter_blocks.push_back(values[b].data());
  eval.parameter_blocks.push_back(values[35].data());
  eval.parameter_blocks.push_back(values[36].data());
  ceres::CRSMatrix crs;
  ASSERT_TRUE(problem.Evaluate(eval, nullptr, nullptr, nullptr, &crs));
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int i = 0; i < crs.num_rows; ++i) {
    for (int e = crs.rows[static_cast<std::size_t>(i)];
         e < crs.rows[static_cast<std::size_t>(i) + 1]; ++e)
      J(i, crs.cols[static_cast<std::size_t>(e)]) = crs.values[static_cast<std::size_t>(e)];
  }
  const Eigen::MatrixXd H = J.transpose() * J;
  const int n = crs.num_cols - 5;
  ASSERT_EQ(info.nuisance_dimension, n + 1);  // the untouched block counts, and is left out
  const Eigen::MatrixXd H_nc = H.topRightCorner(n, 5);
  const Eigen::MatrixXd expected =
      H.bottomRightCorner(5, 5) - H_nc.transpose() * H.topLeftCorner(n, n).ldlt().solve(H_nc);
  EXPECT_LT((info.information - expected).norm(), 1e-10 * expected.norm());
}

TEST(MarginalCovariance, ConstantCalibrationBlocksAreSkipped) {
  double x[1] = {0}, y[1] = {0}, z[1] = {0};
  ceres::Problem problem;
  problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Three, 3, 1, 1, 1>(new Three), nullptr,
                           x, y, z);
  problem.SetParameterBlockConstant(z);
  const MarginalInformation info =
      ComputeMarginalInformation(problem, {{y, {"y"}, {1.0}}, {z, {"z"}, {1.0}}});
  ASSERT_EQ(info.names.size(), 1u);
  EXPECT_EQ(info.names[0], "y");
  // H = [[2,1],[1,2]] over (x, y): Schur = 2 - 1/2 = 1.5.
  EXPECT_NEAR(info.information(0, 0), 1.5, 1e-12);
}

}  // namespace
}  // namespace ctcal
