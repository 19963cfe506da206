// Board geometry against SPEC section 5's formulas, the tag36h11 bit order, and the printed
// texture (what the renderer and the PDF writer draw).
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "checkerboard_config.h"
#include "ctcal/targets/board.h"

namespace ctcal {
namespace {

TargetConfig AprilGrid(int rows, int cols, double size, double spacing, int border = 2) {
  TargetConfig t;
  t.type = TargetType::kAprilGrid;
  t.tag_rows = rows;
  t.tag_cols = cols;
  t.tag_size = size;
  t.tag_spacing = spacing;
  t.black_tag_border = border;
  return t;
}

using test::Checkerboard;

TEST(Board, AprilGridIdsAndPositionsFollowSpec) {
  for (const auto& [rows, cols] : std::vector<std::pair<int, int>>{{6, 6}, {3, 5}, {7, 2}}) {
    const double size = 0.088, spacing = 0.3;
    const Board board(AprilGrid(rows, cols, size, spacing));
    ASSERT_EQ(board.rows(), 2 * rows);
    ASSERT_EQ(board.cols(), 2 * cols);
    ASSERT_EQ(board.NumCorners(), 4 * rows * cols);
    ASSERT_EQ(board.NumTags(), rows * cols);
    for (int r = 0; r < 2 * rows; ++r) {
      for (int c = 0; c < 2 * cols; ++c) {
        const int id = r * 2 * cols + c;
        const double x = std::floor(c / 2.0) * (1 + spacing) * size + (c % 2) * size;
        const double y = std::floor(r / 2.0) * (1 + spacing) * size + (r % 2) * size;
        EXPECT_DOUBLE_EQ(board.Corner(id).x(), x) << id;
        EXPECT_DOUBLE_EQ(board.Corner(id).y(), y) << id;
        EXPECT_EQ(board.Corner(id).z(), 0.0);
      }
    }
  }
}

TEST(Board, TagCornersAreBottomLeftBottomRightTopRightTopLeft) {
  const double size = 0.05, spacing = 0.25;
  const Board board(AprilGrid(4, 3, size, spacing));
  for (int k = 0; k < board.NumTags(); ++k) {
    const std::array<int, 4> ids = board.TagCornerIds(k);
    const int b = 2 * (k / 3) * 2 * 3 + 2 * (k % 3);  // SPEC section 5
    EXPECT_EQ(ids, (std::array<int, 4>{b, b + 1, b + 2 * 3 + 1, b + 2 * 3}));
    const Eigen::Vector3d origin((k % 3) * (1 + spacing) * size, (k / 3) * (1 + spacing) * size, 0);
    EXPECT_TRUE(board.Corner(ids[0]).isApprox(origin) || origin.isZero());
    EXPECT_TRUE((board.Corner(ids[1]) - origin).isApprox(Eigen::Vector3d(size, 0, 0)));
    EXPECT_TRUE((board.Corner(ids[2]) - origin).isApprox(Eigen::Vector3d(size, size, 0)));
    EXPECT_TRUE((board.Corner(ids[3]) - origin).isApprox(Eigen::Vector3d(0, size, 0)));
  }
}

TEST(Board, CheckerboardIdsAndPositionsFollowSpec) {
  const Board board(Checkerboard(6, 9, 0.03, 0.025));
  ASSERT_EQ(board.NumCorners(), 54);
  EXPECT_EQ(board.NumTags(), 0);
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 9; ++c) {
      // Kalibr's ordering: x grows with the row index.
      EXPECT_TRUE(board.Corner(r * 9 + c).isApprox(Eigen::Vector3d(r * 0.03, c * 0.025, 0.0)) ||
                  (r == 0 && c == 0));
    }
  }
  EXPECT_TRUE(board.Corner(0).isZero());
}

// AprilTag 3 stores tag36h11 words in the order of its bit_x/bit_y tables; re-ordered row-major
// they must be Kalibr's (and AprilTag 2's) words, which Kalibr's generator prints.
TEST(Board, Tag36h11RowMajorWordsAreKalibrs) {
  const Board board(AprilGrid(1, 6, 0.1, 0.3));
  const uint64_t kalibr[6] = {0xd5d628584, 0xd97f18b49, 0xdd280910e,
                              0xe479e9c98, 0xebcbca822, 0xf31dab3ac};
  for (int id = 0; id < 6; ++id)
    EXPECT_EQ(board.TagCode(id), kalibr[id]) << "id " << id;
}

TEST(Board, AprilGridTextureMatchesCodesBordersAndCornerSquares) {
  for (int border : {1, 2}) {
    const double size = 0.1, spacing = 0.3;
    const Board board(AprilGrid(2, 3, size, spacing, border));
    const int cells = 6 + 2 * border;
    const double bit = size / cells;
    EXPECT_DOUBLE_EQ(board.TagBitSize(), bit);
    for (int k = 0; k < board.NumTags(); ++k) {
      const double x0 = (k % 3) * (1 + spacing) * size;
      const double y0 = (k / 3) * (1 + spacing) * size;
      for (int cy = 0; cy < cells; ++cy) {
        for (int cx = 0; cx < cells; ++cx) {
          const bool is_border =
              cx < border || cy < border || cx >= cells - border || cy >= cells - border;
          bool black = true;
          if (!is_border) {
            // Cell (cx, cy) counts up from the bottom-left; the word is row-major from the top.
            const int index = (cells - 1 - cy - border) * 6 + (cx - border);
            black = ((board.TagCode(k) >> (35 - index)) & 1u) == 0;
          }
          EXPECT_EQ(board.IsBlack(x0 + (cx + 0.5) * bit, y0 + (cy + 0.5) * bit), black)
              << "tag " << k << " cell " << cx << "," << cy;
        }
      }
    }
    const double gap = spacing * size;
    // Corner squares at every tag corner, the outer ones too; white gaps between them.
    for (int j = 0; j <= 2; ++j) {
      for (int i = 0; i <= 3; ++i) {
        const double cx = i * (size + gap) - 0.5 * gap;
        const double cy = j * (size + gap) - 0.5 * gap;
        EXPECT_TRUE(board.IsBlack(cx, cy)) << i << "," << j;
        if (i < 3) {
          EXPECT_FALSE(board.IsBlack(cx + 0.5 * (size + gap), cy)) << i << "," << j;
        }
      }
    }
    EXPECT_FALSE(board.IsBlack(-2 * gap, 0.5 * size));  // paper outside the pattern
    const Eigen::AlignedBox2d box = board.PatternBox();
    EXPECT_NEAR(box.min().x(), -gap, 1e-12);
    EXPECT_NEAR(box.max().x(), 3 * size + 3 * gap, 1e-12);
    EXPECT_NEAR(box.max().y(), 2 * size + 2 * gap, 1e-12);
  }
}

TEST(Board, CheckerboardTextureAlternatesAroundEveryCorner) {
  const Board board(Checkerboard(4, 5, 0.04, 0.03));
  EXPECT_TRUE(board.IsBlack(-0.02, -0.015));  // the square before corner 0
  for (int id = 0; id < board.NumCorners(); ++id) {
    const Eigen::Vector3d& p = board.Corner(id);
    const double e = 0.005;
    const bool a = board.IsBlack(p.x() - e, p.y() - e);
    EXPECT_EQ(board.IsBlack(p.x() + e, p.y() + e), a) << id;
    EXPECT_NE(board.IsBlack(p.x() + e, p.y() - e), a) << id;
    EXPECT_NE(board.IsBlack(p.x() - e, p.y() + e), a) << id;
  }
  EXPECT_FALSE(board.IsBlack(-0.05, 0.0));
}

TEST(Board, RejectsConfigurationsWithoutABoard) {
  EXPECT_THROW(Board(AprilGrid(0, 6, 0.1, 0.3)), std::invalid_argument);
  EXPECT_THROW(Board(AprilGrid(6, 6, -0.1, 0.3)), std::invalid_argument);
  EXPECT_THROW(Board(AprilGrid(6, 6, 0.1, 0.3, 3)), std::invalid_argument);
  EXPECT_THROW(Board(AprilGrid(30, 30, 0.1, 0.3)), std::invalid_argument);  // > 587 tags
  EXPECT_THROW(Board(Checkerboard(1, 5, 0.1, 0.1)), std::invalid_argument);
  EXPECT_THROW(Board(Checkerboard(4, 5, 0.0, 0.1)), std::invalid_argument);
}

}  // namespace
}  // namespace ctcal
