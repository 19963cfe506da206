// The threads' shares of the normal equations' assembly (calibrator/src/solver/thread_shares.h) on
// a trajectory-shaped problem: residual blocks reading 4 consecutive knots (camera frames and
// inertial samples) and the samples also 2 of a coarser bias spline's knots. The shares must never
// let two threads write one nuisance block, and they must stay balanced however the problem lists
// its blocks: a camera that sees the board in alternate seconds lists the knots of the gaps last
// (the cross-validation subset of issue 20 ran its Jacobian passes on one thread that way).
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>
#include <set>
#include <vector>

#include "../../../calibrator/src/solver/thread_shares.h"

namespace ctcal {
namespace {

struct Problem {
  std::vector<std::vector<int>> nuisance_of;
  std::vector<double> work;
  int nuisance_blocks = 0;
};

// `knots` trajectory knots and one bias knot per 25 of them. Frames (work 4) first, only in the
// even blocks of 100 knots when `gaps`, then one sample (work 1) per knot. The nuisance blocks are
// numbered as ParameterBlocksInResidualOrder numbers them: by first reader.
Problem Trajectory(int knots, bool gaps) {
  const int bias_knots = knots / 25 + 2;
  std::vector<std::vector<int>> readers;  // in the problem's own numbering: knots, then biases
  std::vector<double> work;
  for (int k = 0; k + 4 <= knots; ++k) {
    if (gaps && (k / 100) % 2 == 1)
      continue;
    readers.push_back({k, k + 1, k + 2, k + 3});
    work.push_back(4.0);
  }
  for (int k = 0; k + 4 <= knots; ++k) {
    const int b = knots + k / 25;
    readers.push_back({k, k + 1, k + 2, k + 3, b, b + 1});
    work.push_back(1.0);
  }
  Problem p;
  p.work = work;
  std::vector<int> number(static_cast<std::size_t>(knots + bias_knots), -1);
  for (auto& of : readers) {
    for (int& b : of) {
      int& n = number[static_cast<std::size_t>(b)];
      if (n < 0)
        n = p.nuisance_blocks++;
      b = n;
    }
  }
  p.nuisance_of = readers;
  return p;
}

// The property the assembly needs: a nuisance block is written by one thread at most.
void ExpectNoBlockWrittenByTwoThreads(const Problem& p, const ThreadShares& s) {
  std::vector<int> writer(static_cast<std::size_t>(p.nuisance_blocks), -1);
  for (std::size_t t = 0; t < s.own.size(); ++t) {
    for (const std::size_t i : s.own[t]) {
      for (const int b : p.nuisance_of[i]) {
        int& w = writer[static_cast<std::size_t>(b)];
        EXPECT_TRUE(w < 0 || w == static_cast<int>(t)) << "nuisance block " << b;
        w = static_cast<int>(t);
      }
    }
  }
}

void ExpectEveryBlockOnce(const Problem& p, const ThreadShares& s) {
  std::vector<std::size_t> all(s.shared);
  for (const auto& own : s.own)
    all.insert(all.end(), own.begin(), own.end());
  std::sort(all.begin(), all.end());
  std::vector<std::size_t> expected(p.nuisance_of.size());
  std::iota(expected.begin(), expected.end(), 0);
  EXPECT_EQ(all, expected);
}

double Work(const Problem& p, const std::vector<std::size_t>& blocks) {
  double w = 0.0;
  for (const std::size_t i : blocks)
    w += p.work[i];
  return w;
}

TEST(ThreadShares, BandOrderFollowsTheKnotsWhateverTheirNumbering) {
  const Problem p = Trajectory(1000, true);
  const std::vector<int> rank = BandOrder(p.nuisance_of, p.nuisance_blocks);
  std::vector<int> sorted = rank;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t r = 0; r < sorted.size(); ++r)
    ASSERT_EQ(sorted[r], static_cast<int>(r));  // a permutation
  // The knots' ranks along the trajectory move one way (either end may come first), within the
  // reach of one bias knot's readers (breadth-first levels).
  const int a = rank[static_cast<std::size_t>(p.nuisance_of.front()[0])];
  const int z = rank[static_cast<std::size_t>(p.nuisance_of[p.nuisance_of.size() - 1][3])];
  EXPECT_GT(std::abs(z - a), 900);
}

class ThreadSharesOf : public ::testing::TestWithParam<bool> {};

TEST_P(ThreadSharesOf, TrajectoryAreBalancedAndDisjoint) {
  const Problem p = Trajectory(2000, GetParam());
  const double total = std::accumulate(p.work.begin(), p.work.end(), 0.0);
  for (const int threads : {1, 2, 3, 4}) {
    SCOPED_TRACE(threads);
    const ThreadShares s = ShareBlocks(p.nuisance_of, p.work, p.nuisance_blocks, threads);
    ASSERT_EQ(s.own.size(), static_cast<std::size_t>(threads));
    ExpectEveryBlockOnce(p, s);
    ExpectNoBlockWrittenByTwoThreads(p, s);
    // Straddlers: the blocks at a cut within a bias knot's reach, about 2 x 25 samples per cut;
    // each range loses those at its ends, so the shares differ by up to ~10 % at 4 threads here.
    EXPECT_LE(Work(p, s.shared), 0.02 * total * (threads - 1) + 1e-9);
    for (const auto& own : s.own)
      EXPECT_NEAR(Work(p, own), (total - Work(p, s.shared)) / threads, 0.15 * total / threads);
  }
}

INSTANTIATE_TEST_SUITE_P(, ThreadSharesOf, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& p) {
                           return p.param ? "WithGaps" : "Covered";
                         });

TEST(ThreadShares, BlocksWithoutNuisanceGoRoundRobinAndUnreadBlocksRankLast) {
  Problem p = Trajectory(200, false);
  p.nuisance_blocks += 1;  // one block nobody reads
  p.nuisance_of.push_back({});
  p.work.push_back(3.0);
  p.nuisance_of.push_back({});
  p.work.push_back(3.0);
  const ThreadShares s = ShareBlocks(p.nuisance_of, p.work, p.nuisance_blocks, 2);
  ExpectEveryBlockOnce(p, s);
  EXPECT_EQ(s.rank.back(), p.nuisance_blocks - 1);
  const std::size_t last = p.nuisance_of.size() - 1;
  const auto in0 = std::count(s.own[0].begin(), s.own[0].end(), last - 1) +
                   std::count(s.own[0].begin(), s.own[0].end(), last);
  EXPECT_EQ(in0, 1);  // one each
}

}  // namespace
}  // namespace ctcal
