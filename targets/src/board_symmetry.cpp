#include "ctcal/targets/board_symmetry.h"

#include <cmath>

namespace ctcal {

namespace {

constexpr double kPi = 3.14159265358979323846;

// The corner at `p`, or -1 (a turn that does not map the grid onto itself).
int CornerAt(const Board& board, const Eigen::Vector3d& p, double tolerance) {
  for (int id = 0; id < board.NumCorners(); ++id)
    if ((board.Corner(id) - p).norm() <= tolerance)
      return id;
  return -1;
}

}  // namespace

std::vector<BoardTurn> BoardSymmetries(const Board& board) {
  const Eigen::AlignedBox2d box = board.PatternBox();
  const Eigen::Vector2d centre = box.center();
  const double feature = board.FeatureSize();
  std::vector<BoardTurn> out;
  for (int q = 1; q <= 3; ++q) {
    BoardTurn turn;
    turn.quarter_turns = q;
    const Eigen::Matrix3d R = Eigen::AngleAxisd(q * 0.5 * kPi, Eigen::Vector3d::UnitZ()).matrix();
    const Eigen::Vector3d c(centre.x(), centre.y(), 0.0);
    turn.T_turn.linear() = R;
    turn.T_turn.translation() = c - R * c;
    // The corner grid onto itself.
    bool symmetric = true;
    for (int id = 0; id < board.NumCorners() && symmetric; ++id) {
      const int to = CornerAt(board, turn.T_turn * board.Corner(id), 1e-3 * feature);
      symmetric = to >= 0;
      turn.turned_id.push_back(to);
    }
    // The print onto itself, read at the centres of a quarter-feature grid (never on an edge of
    // the pattern, whose features are whole multiples of FeatureSize from the box's corner).
    const double step = 0.25 * feature;
    const int nx = static_cast<int>(std::round(box.sizes().x() / step));
    const int ny = static_cast<int>(std::round(box.sizes().y() / step));
    for (int i = 0; i < nx && symmetric; ++i) {
      for (int j = 0; j < ny && symmetric; ++j) {
        const Eigen::Vector3d p(box.min().x() + (i + 0.5) * step, box.min().y() + (j + 0.5) * step,
                                0.0);
        const Eigen::Vector3d t = turn.T_turn * p;
        symmetric = board.IsBlack(p.x(), p.y()) == board.IsBlack(t.x(), t.y());
      }
    }
    if (symmetric)
      out.push_back(std::move(turn));
  }
  return out;
}

}  // namespace ctcal
