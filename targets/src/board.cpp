#include "ctcal/targets/board.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <opencv2/aruco/charuco.hpp>

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
  } else if (config.type == TargetType::kCharuco) {
    const int dictionary_id = ArucoDictionaryId(config.dictionary);
    if (config.squares_x < 2 || config.squares_y < 2 || !(config.square_length_m > 0.0) ||
        !(config.marker_length_m > 0.0) || !(config.marker_length_m < config.square_length_m) ||
        dictionary_id < 0) {
      throw std::invalid_argument(
          "charuco: invalid squaresX/squaresY/squareLength/markerLength/dictionary");
    }
    // OpenCV builds the board: its corner ids and positions and its marker layout are what
    // cv::aruco detects and interpolates against, so they are taken from it, not re-derived.
    const cv::Ptr<cv::aruco::Dictionary> dictionary =
        cv::aruco::getPredefinedDictionary(dictionary_id);
    const int num_markers = config.squares_x * config.squares_y / 2;  // the white squares
    if (num_markers > dictionary->bytesList.rows) {
      throw std::invalid_argument("charuco: " + std::to_string(num_markers) + " markers, but " +
                                  config.dictionary + " has only " +
                                  std::to_string(dictionary->bytesList.rows));
    }
    const cv::Ptr<cv::aruco::CharucoBoard> charuco = cv::aruco::CharucoBoard::create(
        config.squares_x, config.squares_y, static_cast<float>(config.square_length_m),
        static_cast<float>(config.marker_length_m), dictionary);
    rows_ = config.squares_y - 1;
    cols_ = config.squares_x - 1;
    // OpenCV's board frame has y down the print (z into it); ours has y up and z towards the
    // viewer, as for every board: y_W = squaresY * squareLength - y_OpenCV, same ids.
    const double height = config.squares_y * config.square_length_m;
    for (const cv::Point3f& p : charuco->chessboardCorners)
      corners_W_.emplace_back(p.x, height - p.y, 0.0);
    marker_bits_ = dictionary->markerSize;
    marker_of_square_.assign(static_cast<size_t>(config.squares_x * config.squares_y), -1);
    for (size_t i = 0; i < charuco->ids.size(); ++i) {
      // objPoints[i][0] is the marker's top-left corner as printed.
      const cv::Point3f& top_left = charuco->objPoints[i][0];
      Marker marker;
      marker.id = charuco->ids[i];
      marker.top_left = Eigen::Vector2d(top_left.x, height - top_left.y);
      const double side = config.marker_length_m;
      const int col =
          static_cast<int>(std::floor((marker.top_left.x() + 0.5 * side) / config.square_length_m));
      const int row =
          static_cast<int>(std::floor((marker.top_left.y() - 0.5 * side) / config.square_length_m));
      if (col < 0 || row < 0 || col >= config.squares_x || row >= config.squares_y)
        throw std::logic_error("charuco: a marker outside the board (OpenCV's layout changed?)");
      marker_of_square_[static_cast<size_t>(row * config.squares_x + col)] =
          static_cast<int>(markers_.size());
      markers_.push_back(marker);
      const cv::Mat bits = cv::aruco::Dictionary::getBitsFromByteList(
          dictionary->bytesList.rowRange(marker.id, marker.id + 1), marker_bits_);
      marker_data_.emplace_back(bits.begin<uint8_t>(), bits.end<uint8_t>());
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
  if (type() == TargetType::kCharuco) {
    return Eigen::AlignedBox2d(Eigen::Vector2d::Zero(),
                               Eigen::Vector2d(config_.squares_x * config_.square_length_m,
                                               config_.squares_y * config_.square_length_m));
  }
  // Inner corners plus one square all round.
  return Eigen::AlignedBox2d(Eigen::Vector2d(-config_.row_spacing_m, -config_.col_spacing_m),
                             Eigen::Vector2d(config_.target_rows * config_.row_spacing_m,
                                             config_.target_cols * config_.col_spacing_m));
}

double Board::FeatureSize() const {
  if (type() == TargetType::kAprilGrid)
    return std::min(TagBitSize(), config_.tag_spacing * config_.tag_size);
  if (type() == TargetType::kCharuco)
    return config_.marker_length_m / MarkerCells();
  return std::min(config_.row_spacing_m, config_.col_spacing_m);
}

bool Board::IsBlack(double x, double y) const {
  switch (type()) {
    case TargetType::kAprilGrid:
      return AprilGridIsBlack(x, y);
    case TargetType::kCheckerboard:
      return CheckerboardIsBlack(x, y);
    case TargetType::kCharuco:
      return CharucoIsBlack(x, y);
  }
  return false;
}

bool Board::CharucoIsBlack(double x, double y) const {
  const double square = config_.square_length_m;
  const double fi = std::floor(x / square);
  const double fj = std::floor(y / square);
  if (fi < 0.0 || fj < 0.0 || fi >= config_.squares_x || fj >= config_.squares_y)
    return false;
  const int index = marker_of_square_[static_cast<size_t>(static_cast<int>(fj) * config_.squares_x +
                                                          static_cast<int>(fi))];
  if (index < 0)
    return true;  // the squares without a marker are the black ones
  const Marker& marker = markers_[static_cast<size_t>(index)];
  const int cells = MarkerCells();
  const double cell = config_.marker_length_m / cells;
  const double lx = (x - marker.top_left.x()) / cell;
  const double ly = (marker.top_left.y() - y) / cell;  // down the marker from its top
  if (lx < 0.0 || ly < 0.0 || lx >= cells || ly >= cells)
    return false;  // the white of the square around the marker
  const int cx = static_cast<int>(lx), cy = static_cast<int>(ly);
  if (cx == 0 || cy == 0 || cx == cells - 1 || cy == cells - 1)
    return true;  // the marker's black border
  return marker_data_[static_cast<size_t>(index)]
                     [static_cast<size_t>((cy - 1) * marker_bits_ + cx - 1)] == 0;
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
