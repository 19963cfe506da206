#include "ctcal/targets/board.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "tag_family.h"

namespace ctcal {

Board::Board(const TargetConfig& config) : config_(config) {
  if (config.type == TargetType::kAprilGrid) {
    if (config.tag_rows < 1 || config.tag_cols < 1 || !(config.tag_size > 0.0) ||
        !(config.tag_spacing > 0.0) ||
        (config.black_tag_border != 1 && config.black_tag_border != 2)) {
      throw std::invalid_argument("aprilgrid: invalid tagRows/tagCols/tagSize/tagSpacing/border");
    }
    const auto& codes = internal::Tag36h11RowMajorCodes();
    const int num_tags = config.tag_rows * config.tag_cols;
    if (num_tags > static_cast<int>(codes.size())) {
      throw std::invalid_argument("aprilgrid: " + std::to_string(num_tags) +
                                  " tags, but tag36h11 has only " + std::to_string(codes.size()));
    }
    tag_codes_.assign(codes.begin(), codes.begin() + num_tags);
    rows_ = 2 * config.tag_rows;
    cols_ = 2 * config.tag_cols;
    // SPEC section 5: x = floor(c/2) * (1+tagSpacing) * tagSize + (c mod 2) * tagSize.
    const double period = (1.0 + config.tag_spacing) * config.tag_size;
    corners_W_.reserve(static_cast<size_t>(rows_ * cols_));
    for (int r = 0; r < rows_; ++r) {
      for (int c = 0; c < cols_; ++c) {
        corners_W_.emplace_back((c / 2) * period + (c % 2) * config.tag_size,
                                (r / 2) * period + (r % 2) * config.tag_size, 0.0);
      }
    }
  } else {
    if (config.target_rows < 2 || config.target_cols < 2 || !(config.row_spacing_m > 0.0) ||
        !(config.col_spacing_m > 0.0)) {
      throw std::invalid_argument("checkerboard: invalid targetRows/targetCols/spacing");
    }
    rows_ = config.target_rows;
    cols_ = config.target_cols;
    // Kalibr's ordering: x grows with the row index.
    corners_W_.reserve(static_cast<size_t>(rows_ * cols_));
    for (int r = 0; r < rows_; ++r) {
      for (int c = 0; c < cols_; ++c)
        corners_W_.emplace_back(r * config.row_spacing_m, c * config.col_spacing_m, 0.0);
    }
  }
}

std::array<int, 4> Board::TagCornerIds(int tag_id) const {
  const int tag_row = tag_id / config_.tag_cols;
  const int tag_col = tag_id % config_.tag_cols;
  const int b = 2 * tag_row * cols_ + 2 * tag_col;
  return {b, b + 1, b + cols_ + 1, b + cols_};
}

uint64_t Board::TagCode(int tag_id) const {
  return tag_codes_[static_cast<size_t>(tag_id)];
}

double Board::TagBitSize() const {
  return config_.tag_size / (kTagDataBits + 2 * config_.black_tag_border);
}

Eigen::AlignedBox2d Board::PatternBox() const {
  if (type() == TargetType::kAprilGrid) {
    // Kalibr draws a black square of tagSpacing * tagSize at every tag corner, outer ones too.
    const double gap = config_.tag_spacing * config_.tag_size;
    const double period = config_.tag_size + gap;
    return Eigen::AlignedBox2d(
        Eigen::Vector2d(-gap, -gap),
        Eigen::Vector2d((config_.tag_cols - 1) * period + config_.tag_size + gap,
                        (config_.tag_rows - 1) * period + config_.tag_size + gap));
  }
  // Inner corners plus one square all round.
  return Eigen::AlignedBox2d(Eigen::Vector2d(-config_.row_spacing_m, -config_.col_spacing_m),
                             Eigen::Vector2d(config_.target_rows * config_.row_spacing_m,
                                             config_.target_cols * config_.col_spacing_m));
}

double Board::FeatureSize() const {
  if (type() == TargetType::kAprilGrid)
    return std::min(TagBitSize(), config_.tag_spacing * config_.tag_size);
  return std::min(config_.row_spacing_m, config_.col_spacing_m);
}

bool Board::IsBlack(double x, double y) const {
  return type() == TargetType::kAprilGrid ? AprilGridIsBlack(x, y) : CheckerboardIsBlack(x, y);
}

bool Board::AprilGridIsBlack(double x, double y) const {
  const double size = config_.tag_size;
  const double period = (1.0 + config_.tag_spacing) * size;
  // Tag (column i, row j) covers [i*period, i*period + size) on x; the gap [size, period) after it
  // carries the corner squares where a gap column crosses a gap row.
  const double fi = std::floor(x / period);
  const double fj = std::floor(y / period);
  if (fi < -1.0 || fj < -1.0 || fi >= config_.tag_cols || fj >= config_.tag_rows)
    return false;
  const int i = static_cast<int>(fi);
  const int j = static_cast<int>(fj);
  const double lx = x - fi * period;
  const double ly = y - fj * period;
  const bool in_gap_x = lx >= size;
  const bool in_gap_y = ly >= size;
  if (in_gap_x && in_gap_y)
    return true;  // a corner square
  if (in_gap_x || in_gap_y || i < 0 || j < 0)
    return false;  // white gap between tags, or left of / below the first tag
  const int border = config_.black_tag_border;
  const int cells = kTagDataBits + 2 * border;
  const double bit = size / cells;
  const int cx = std::min(cells - 1, static_cast<int>(lx / bit));
  const int cy = std::min(cells - 1, static_cast<int>(ly / bit));  // from the tag's bottom
  if (cx < border || cy < border || cx >= cells - border || cy >= cells - border)
    return true;
  const int data_col = cx - border;
  const int data_row = cells - 1 - cy - border;  // from the tag's top
  const int index = data_row * kTagDataBits + data_col;
  const uint64_t word = tag_codes_[static_cast<size_t>(j * config_.tag_cols + i)];
  const int nbits = kTagDataBits * kTagDataBits;
  return ((word >> (nbits - 1 - index)) & 1u) == 0;
}

bool Board::CheckerboardIsBlack(double x, double y) const {
  // Square (i, j) spans [(i-1) * rowSpacing, i * rowSpacing) on x; the square below-left of
  // corner 0 is black, as in Kalibr's generator.
  const double fi = std::floor(x / config_.row_spacing_m) + 1.0;
  const double fj = std::floor(y / config_.col_spacing_m) + 1.0;
  if (fi < 0.0 || fj < 0.0 || fi > config_.target_rows || fj > config_.target_cols)
    return false;
  return (static_cast<int>(fi) + static_cast<int>(fj)) % 2 == 0;
}

}  // namespace ctcal
