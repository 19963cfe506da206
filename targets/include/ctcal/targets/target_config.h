// The Kalibr target file of SPEC section 5, as plain data. Rig and result files embed it under
// `target:`; the detector, the renderer and the simulator build boards from it.
#pragma once

#include <string>

namespace YAML {
class Node;
class Emitter;
}  // namespace YAML

namespace ctcal {

enum class TargetType { kAprilGrid, kCheckerboard, kCharuco };

struct TargetConfig {
  TargetType type = TargetType::kAprilGrid;
  // aprilgrid
  int tag_cols = 6;
  int tag_rows = 6;
  double tag_size = 0.088;   // metres, edge of the whole black square
  double tag_spacing = 0.3;  // gap / tag_size
  int black_tag_border = 2;  // Kalibr prints 2; standard AprilTag 3 boards have 1
  // checkerboard (inner corners)
  int target_cols = 0;
  int target_rows = 0;
  double row_spacing_m = 0.0;
  double col_spacing_m = 0.0;
  // charuco (OpenCV's CharucoBoard; not in Kalibr, names as OpenCV's, docs/targets.md): squares
  // along x and y, their edge and the ArUco marker's edge (m), OpenCV's predefined dictionary.
  int squares_x = 0;
  int squares_y = 0;
  double square_length_m = 0.0;
  double marker_length_m = 0.0;
  std::string dictionary = "DICT_4X4_50";
};

// OpenCV's predefined ArUco dictionary for `name` (DICT_4X4_50 ... DICT_APRILTAG_36h11, as in
// cv::aruco::PREDEFINED_DICTIONARY_NAME); -1 if there is none of that name.
int ArucoDictionaryId(const std::string& name);

// Parses a target node; throws std::runtime_error naming `context` (file or rig key) and the
// offending key for unknown keys, missing required keys and out-of-range values.
TargetConfig ParseTargetConfig(const YAML::Node& node, const std::string& context);
TargetConfig LoadTargetConfig(const std::string& path);
// Writes the Kalibr keys as a map (block or flow style is the emitter's choice).
void EmitTargetConfig(const TargetConfig& target, YAML::Emitter& out);
void SaveTargetConfig(const TargetConfig& target, const std::string& path);

}  // namespace ctcal
