// The turns a board's print is unchanged by (targets/board_symmetry.h), found on the print itself,
// against the rule derived from the squares' colour parity: a checkerboard of rows x cols inner
// corners looks the same after a half turn exactly when rows + cols is even, a square one after a
// quarter turn when rows is even; AprilGrids and ChArUco boards never.
#include "ctcal/targets/board_symmetry.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "checkerboard_config.h"

namespace ctcal {
namespace {

TargetConfig Checkerboard(int rows, int cols, double row_spacing = 0.03,
                          double col_spacing = 0.03) {
  return test::Checkerboard(rows, cols, row_spacing, col_spacing);
}

std::vector<int> QuarterTurns(const std::vector<BoardTurn>& turns) {
  std::vector<int> q;
  for (const BoardTurn& t : turns)
    q.push_back(t.quarter_turns);
  return q;
}

TEST(BoardSymmetry, CheckerboardsFollowTheColourParityRule) {
  for (int rows = 2; rows <= 9; ++rows) {
    for (int cols = 2; cols <= 9; ++cols) {
      const Board board(Checkerboard(rows, cols));
      std::vector<int> expected;
      const bool quarter = rows == cols && rows % 2 == 0;
      if (quarter)
        expected.push_back(1);
      if ((rows + cols) % 2 == 0)
        expected.push_back(2);
      if (quarter)
        expected.push_back(3);
      EXPECT_EQ(QuarterTurns(BoardSymmetries(board)), expected) << rows << " x " << cols;
    }
  }
  // Square in corners but not in metres: no quarter turn.
  EXPECT_EQ(QuarterTurns(BoardSymmetries(Board(Checkerboard(4, 4, 0.03, 0.04)))),
            std::vector<int>{2});
}

TEST(BoardSymmetry, TurnMapsEveryCornerOntoItsTurnedId) {
  const Board board(Checkerboard(4, 6));  // 5x7 squares: issue 21's board
  const std::vector<BoardTurn> turns = BoardSymmetries(board);
  ASSERT_EQ(turns.size(), 1u);
  const int n = board.NumCorners();
  for (int id = 0; id < n; ++id) {
    // The half turn of the row-major grid reverses the ids.
    EXPECT_EQ(turns[0].turned_id[static_cast<std::size_t>(id)], n - 1 - id);
    EXPECT_LT((board.Corner(turns[0].turned_id[static_cast<std::size_t>(id)]) -
               turns[0].T_turn * board.Corner(id))
                  .norm(),
              1e-12);
  }
  const Board square(Checkerboard(6, 6));
  for (const BoardTurn& t : BoardSymmetries(square)) {
    std::vector<bool> hit(static_cast<std::size_t>(square.NumCorners()), false);
    for (int to : t.turned_id)
      hit[static_cast<std::size_t>(to)] = true;
    EXPECT_EQ(std::count(hit.begin(), hit.end(), true), square.NumCorners()) << "a permutation";
  }
}

TEST(BoardSymmetry, CodedBoardsHaveNone) {
  EXPECT_TRUE(BoardSymmetries(Board(TargetConfig{})).empty());  // 6x6 AprilGrid
  TargetConfig grid;
  grid.tag_rows = grid.tag_cols = 4;
  EXPECT_TRUE(BoardSymmetries(Board(grid)).empty());
  TargetConfig charuco;
  charuco.type = TargetType::kCharuco;
  charuco.squares_x = 5;
  charuco.squares_y = 7;
  charuco.square_length_m = 0.04;
  charuco.marker_length_m = 0.03;
  EXPECT_TRUE(BoardSymmetries(Board(charuco)).empty());
}

}  // namespace
}  // namespace ctcal
