// The turns of a board in its own plane that leave its printed pattern unchanged: a detector that
// reads only the print cannot tell a view of the board from a view of the board so turned, so the
// corner order of every detection is known only up to these turns (docs/targets.md, "Symmetric
// boards"). A checkerboard of rows x cols inner corners looks the same after a half turn exactly
// when rows + cols is even (the half turn maps square (i, j) of the (rows+1) x (cols+1) squares
// onto (rows - i, cols - j), whose colour parity differs by rows + cols), and a square one
// (rows == cols, equal spacings) after a quarter turn when rows is even. AprilGrids and ChArUco
// boards carry codes and have none. The calibrator resolves each view's turn by consistency
// (calibrator/init/board_order.h).
#pragma once

#include <Eigen/Geometry>
#include <vector>

#include "ctcal/targets/board.h"

namespace ctcal {

// One turn of the board about its pattern's centre by quarter_turns * 90 deg (counter-clockwise
// seen from +z, the printed side).
struct BoardTurn {
  int quarter_turns = 0;  // 1, 2 or 3
  // p_W after the turn: T_turn * p_W (a rotation about z through the pattern's centre).
  Eigen::Isometry3d T_turn = Eigen::Isometry3d::Identity();
  // Corner `id` lands where corner turned_id[id] was: Corner(turned_id[id]) = T_turn * Corner(id).
  std::vector<int> turned_id;
};

// The turns that map the printed pattern and the corner grid onto themselves (empty: every
// detection's order is the board's). Checked on the print itself (Board::IsBlack on a grid of a
// quarter feature over the pattern box), so the rule above is derived, not assumed.
std::vector<BoardTurn> BoardSymmetries(const Board& board);

}  // namespace ctcal
