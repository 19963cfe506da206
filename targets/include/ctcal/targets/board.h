// A calibration board built from its Kalibr target file: corner ids and 3-D positions in the board
// frame W (SPEC section 5), the tags of an AprilGrid, and the printed pattern as a black/white
// texture of the board plane (what the renderer samples and the PDF writer draws).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <cstdint>
#include <vector>

#include "ctcal/targets/target_config.h"

namespace ctcal {

class Board {
 public:
  // Data bits per tag side of tag36h11.
  static constexpr int kTagDataBits = 6;

  // Throws std::invalid_argument for a configuration that describes no board.
  explicit Board(const TargetConfig& config);

  const TargetConfig& config() const { return config_; }
  TargetType type() const { return config_.type; }

  // The point grid: 2*tagRows x 2*tagCols for an AprilGrid, targetRows x targetCols inner corners
  // for a checkerboard, (squaresY - 1) x (squaresX - 1) inner corners for a ChArUco board
  // (OpenCV's ids; positions with y flipped, docs/targets.md). Point (r, c) has id r * cols() + c.
  int rows() const { return rows_; }
  int cols() const { return cols_; }
  int NumCorners() const { return rows_ * cols_; }
  // p_W of corner `id` (z = 0); ids in [0, NumCorners()).
  const Eigen::Vector3d& Corner(int id) const { return corners_W_[static_cast<size_t>(id)]; }
  const std::vector<Eigen::Vector3d>& Corners() const { return corners_W_; }

  // AprilGrid only (0 tags for a checkerboard). Tag k's corners in the tag's own order
  // bottom-left, bottom-right, top-right, top-left (board frame: x right, y up).
  int NumTags() const { return type() == TargetType::kAprilGrid ? tag_rows() * tag_cols() : 0; }
  int tag_rows() const { return config_.tag_rows; }
  int tag_cols() const { return config_.tag_cols; }
  std::array<int, 4> TagCornerIds(int tag_id) const;
  // The 36 data bits of tag `tag_id` as printed, row-major from the tag's top-left data cell, most
  // significant bit first, 1 = white: Kalibr's code word of tag36h11 for that id.
  uint64_t TagCode(int tag_id) const;
  // Edge of one bit cell of a tag (m): tagSize / (6 + 2 * blackTagBorder).
  double TagBitSize() const;

  // ChArUco only: the ArUco markers in the white squares, as OpenCV's CharucoBoard places them.
  struct Marker {
    int id = -1;                                         // in the board's dictionary
    Eigen::Vector2d top_left = Eigen::Vector2d::Zero();  // m, board frame (y up): largest y
  };
  const std::vector<Marker>& Markers() const { return markers_; }
  // Cells per marker side, its 1-cell black border included (markerSize + 2).
  int MarkerCells() const { return marker_bits_ + 2; }

  // The printed pattern's bounding box in the board plane (m), corner squares included.
  Eigen::AlignedBox2d PatternBox() const;
  // The smallest printed feature (m): a tag bit or a checkerboard square; sets sampling rates.
  double FeatureSize() const;
  // The ink at board-plane point (x, y) (m): true = black. White outside the pattern.
  bool IsBlack(double x, double y) const;

 private:
  bool AprilGridIsBlack(double x, double y) const;
  bool CheckerboardIsBlack(double x, double y) const;
  bool CharucoIsBlack(double x, double y) const;

  TargetConfig config_;
  int rows_ = 0;
  int cols_ = 0;
  std::vector<Eigen::Vector3d> corners_W_;
  std::vector<uint64_t> tag_codes_;
  // ChArUco: markers, the marker in each square (squaresX * row + col; -1: a black square) and
  // each marker's data bits (row-major from its top-left, 1 = white).
  std::vector<Marker> markers_;
  std::vector<int> marker_of_square_;
  int marker_bits_ = 0;
  std::vector<std::vector<uint8_t>> marker_data_;
};

}  // namespace ctcal
