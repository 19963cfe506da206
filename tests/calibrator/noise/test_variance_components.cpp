// Variance component estimation's parts: the hat-matrix traces (exact and by Hutchinson's
// probes) on random sparse least-squares problems, the traces summing to the number of
// parameters, the iterated estimate recovering known noise levels of two groups stated 0.3x and
// 3x, and the shrunk per-part variance.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>
#include <vector>

#include "ctcal/calibrator/noise/variance_components.h"

namespace ctcal {
namespace {

// A banded random design: row i reads `width` consecutive parameters near i * cols / rows (a
// trajectory-like band), group = i % groups.
struct Design {
  Eigen::MatrixXd J;
  std::vector<int> group;
};

Design RandomDesign(int rows, int cols, int groups, int width, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss;
  Design d;
  d.J = Eigen::MatrixXd::Zero(rows, cols);
  for (int i = 0; i < rows; ++i) {
    const int first = std::min(cols - width, static_cast<int>(static_cast<long>(i) * cols / rows));
    for (int j = first; j < first + width; ++j)
      d.J(i, j) = gauss(rng);
    d.group.push_back(i % groups);
  }
  return d;
}

ceres::CRSMatrix ToCrs(const Eigen::MatrixXd& J) {
  ceres::CRSMatrix crs;
  crs.num_rows = static_cast<int>(J.rows());
  crs.num_cols = static_cast<int>(J.cols());
  crs.rows.push_back(0);
  for (int i = 0; i < J.rows(); ++i) {
    for (int j = 0; j < J.cols(); ++j) {
      if (J(i, j) != 0.0) {
        crs.cols.push_back(j);
        crs.values.push_back(J(i, j));
      }
    }
    crs.rows.push_back(static_cast<int>(crs.cols.size()));
  }
  return crs;
}

// tr(N^-1 N_k) by dense algebra: the reference.
std::vector<double> DenseTraces(const Design& d, int groups) {
  const Eigen::MatrixXd N = d.J.transpose() * d.J;
  const Eigen::MatrixXd inverse = N.ldlt().solve(Eigen::MatrixXd::Identity(N.rows(), N.cols()));
  std::vector<double> t(static_cast<std::size_t>(groups), 0.0);
  for (int k = 0; k < groups; ++k) {
    std::vector<int> rows;
    for (std::size_t i = 0; i < d.group.size(); ++i) {
      if (d.group[i] == k)
        rows.push_back(static_cast<int>(i));
    }
    Eigen::MatrixXd Jk(static_cast<Eigen::Index>(rows.size()), d.J.cols());
    for (std::size_t r = 0; r < rows.size(); ++r)
      Jk.row(static_cast<Eigen::Index>(r)) = d.J.row(rows[r]);
    t[static_cast<std::size_t>(k)] = inverse.cwiseProduct(Jk.transpose() * Jk).sum();
  }
  return t;
}

std::vector<double> Traces(const Design& d, int groups, const RedundancyOptions& options,
                           int chunk_rows) {
  HatTraces traces(static_cast<int>(d.J.cols()), groups, options);
  for (int first = 0; first < d.J.rows(); first += chunk_rows) {
    const int rows = std::min(chunk_rows, static_cast<int>(d.J.rows()) - first);
    traces.Add(ToCrs(d.J.middleRows(first, rows)),
               std::vector<int>(d.group.begin() + first, d.group.begin() + first + rows));
  }
  return traces.Compute();
}

TEST(HatTraces, ExactTracesMatchDenseAlgebraAndSumToTheParameters) {
  const Design d = RandomDesign(600, 80, 3, 6, 1);
  const std::vector<double> reference = DenseTraces(d, 3);
  const std::vector<double> t = Traces(d, 3, RedundancyOptions{}, 97);  // 80 <= exact limit
  double sum = 0.0;
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(t[static_cast<std::size_t>(k)], reference[static_cast<std::size_t>(k)], 1e-6);
    sum += t[static_cast<std::size_t>(k)];
  }
  EXPECT_NEAR(sum, 80.0, 1e-6);  // every row in a group: tr(H) = u
}

TEST(HatTraces, HutchinsonProbesAgreeWithTheExactTraces) {
  // 1000 parameters, groups of very different leverage: group 0 holds most of the rows.
  Design d = RandomDesign(5000, 1000, 4, 8, 2);
  for (std::size_t i = 0; i < d.group.size(); ++i)
    d.group[i] = i % 10 < 7 ? 0 : static_cast<int>(i % 10) - 6;  // 0: 70 %, 1..3: 10 % each
  const std::vector<double> reference = DenseTraces(d, 4);
  RedundancyOptions options;
  options.exact_max_columns = 0;  // force the probes
  options.probes = 8;
  const std::vector<double> t = Traces(d, 4, options, 1000);
  for (int k = 0; k < 4; ++k) {
    const double ref = reference[static_cast<std::size_t>(k)];
    // The estimator's standard deviation is <= sqrt(2 t / probes): 5 of them at most.
    EXPECT_NEAR(t[static_cast<std::size_t>(k)], ref, 5.0 * std::sqrt(2.0 * ref / options.probes))
        << "group " << k;
  }
}

TEST(HatTraces, ColumnsNoRowReadsDoNotChangeTheTraces) {
  Design d = RandomDesign(400, 60, 2, 5, 3);
  d.J.conservativeResize(Eigen::NoChange, 64);
  d.J.rightCols(4).setZero();  // knots past the data
  Design dense = d;
  dense.J = d.J.leftCols(60);
  const std::vector<double> reference = DenseTraces(dense, 2);
  const std::vector<double> t = Traces(d, 2, RedundancyOptions{}, 400);
  EXPECT_NEAR(t[0], reference[0], 1e-6);
  EXPECT_NEAR(t[1], reference[1], 1e-6);
}

// A linear model y = J x + e with two groups of known sigma, weighted at first by stated sigmas
// 0.3x and 3x the truth: iterating solve -> sigma_k^2 *= e_k^T W_k e_k / r_k -> re-solve recovers
// both within 5 % (their sampling error here: ~1.5 %).
TEST(VarianceComponents, IterationRecoversTwoNoiseLevelsStatedWrong) {
  const Design d = RandomDesign(4000, 300, 2, 10, 4);
  const double truth[2] = {0.5, 2.0};
  const double stated[2] = {0.3 * truth[0], 3.0 * truth[1]};
  std::mt19937 rng(5);
  std::normal_distribution<double> gauss;
  Eigen::VectorXd x_true(d.J.cols());
  for (int j = 0; j < x_true.size(); ++j)
    x_true(j) = gauss(rng);
  Eigen::VectorXd y = d.J * x_true;
  for (int i = 0; i < y.size(); ++i)
    y(i) += truth[d.group[static_cast<std::size_t>(i)]] * gauss(rng);

  double sigma[2] = {stated[0], stated[1]};
  for (int round = 0; round < 8; ++round) {
    Eigen::MatrixXd Jw = d.J;
    Eigen::VectorXd yw = y;
    for (int i = 0; i < y.size(); ++i) {
      const double w = 1.0 / sigma[d.group[static_cast<std::size_t>(i)]];
      Jw.row(i) *= w;
      yw(i) *= w;
    }
    const Eigen::VectorXd x = (Jw.transpose() * Jw).ldlt().solve(Jw.transpose() * yw);
    const Eigen::VectorXd e = yw - Jw * x;
    Design whitened{Jw, d.group};
    const std::vector<double> t = Traces(whitened, 2, RedundancyOptions{}, 4000);
    for (int k = 0; k < 2; ++k) {
      VarianceComponent v;
      for (int i = 0; i < e.size(); ++i) {
        if (d.group[static_cast<std::size_t>(i)] == k) {
          v.weighted += e(i) * e(i);
          v.count += 1.0;
        }
      }
      v.trace = t[static_cast<std::size_t>(k)];
      sigma[k] *= std::sqrt(v.VarianceFactor());
    }
  }
  EXPECT_NEAR(sigma[0] / truth[0], 1.0, 0.05);
  EXPECT_NEAR(sigma[1] / truth[1], 1.0, 0.05);
}

TEST(VarianceComponents, ShrunkVarianceWeighsThePartAgainstTheSensor) {
  // No data of its own: the sensor's; much data: its own; in between: the weighted mean.
  EXPECT_DOUBLE_EQ(ShrunkVariance(0.0, 0.0, 2.0, 10.0), 2.0);
  EXPECT_NEAR(ShrunkVariance(4.0e6, 1.0e6, 2.0, 10.0), 4.0, 1e-4);
  EXPECT_DOUBLE_EQ(ShrunkVariance(40.0, 10.0, 2.0, 10.0), (40.0 + 20.0) / 20.0);
}

}  // namespace
}  // namespace ctcal
