#include "ctcal/targets/target_config.h"

#include <yaml-cpp/yaml.h>

#include <charconv>
#include <fstream>
#include <set>
#include <stdexcept>

namespace ctcal {
namespace {

// The shortest decimal that reads back as the same double: 0.088, not 0.087999999999999995 (which
// yaml-cpp's fixed 17-digit precision would write).
std::string Shortest(double v) {
  char buf[32];
  const auto result = std::to_chars(buf, buf + sizeof(buf), v);
  std::string s(buf, result.ptr);
  if (s.find_first_of(".eE") == std::string::npos)
    s += ".0";  // stays a float for readers
  return s;
}

[[noreturn]] void Fail(const std::string& context, const std::string& what) {
  throw std::runtime_error(context + ": target: " + what);
}

template <typename T>
T Required(const YAML::Node& node, const std::string& key, const std::string& context) {
  if (!node[key])
    Fail(context, "missing required key '" + key + "'");
  try {
    return node[key].as<T>();
  } catch (const YAML::Exception&) {
    Fail(context, "key '" + key + "' has a value of the wrong type");
  }
}

}  // namespace

int ArucoDictionaryId(const std::string& name) {
  // cv::aruco::PREDEFINED_DICTIONARY_NAME, in its order (OpenCV 4.6).
  static const char* const kNames[] = {
      "DICT_4X4_50",         "DICT_4X4_100",       "DICT_4X4_250",       "DICT_4X4_1000",
      "DICT_5X5_50",         "DICT_5X5_100",       "DICT_5X5_250",       "DICT_5X5_1000",
      "DICT_6X6_50",         "DICT_6X6_100",       "DICT_6X6_250",       "DICT_6X6_1000",
      "DICT_7X7_50",         "DICT_7X7_100",       "DICT_7X7_250",       "DICT_7X7_1000",
      "DICT_ARUCO_ORIGINAL", "DICT_APRILTAG_16h5", "DICT_APRILTAG_25h9", "DICT_APRILTAG_36h10",
      "DICT_APRILTAG_36h11"};
  for (int i = 0; i < static_cast<int>(sizeof(kNames) / sizeof(kNames[0])); ++i) {
    if (name == kNames[i])
      return i;
  }
  return -1;
}

TargetConfig ParseTargetConfig(const YAML::Node& node, const std::string& context) {
  if (!node || !node.IsMap())
    Fail(context, "expected a map with target_type and its keys");
  const std::string type = Required<std::string>(node, "target_type", context);
  TargetConfig t;
  std::set<std::string> allowed = {"target_type"};
  if (type == "aprilgrid") {
    t.type = TargetType::kAprilGrid;
    allowed.insert({"tagCols", "tagRows", "tagSize", "tagSpacing", "blackTagBorder", "codeOffset"});
    t.tag_cols = Required<int>(node, "tagCols", context);
    t.tag_rows = Required<int>(node, "tagRows", context);
    t.tag_size = Required<double>(node, "tagSize", context);
    t.tag_spacing = Required<double>(node, "tagSpacing", context);
    if (node["blackTagBorder"])
      t.black_tag_border = Required<int>(node, "blackTagBorder", context);
    if (node["codeOffset"] && Required<int>(node, "codeOffset", context) != 0) {
      Fail(context, "codeOffset other than 0 is not supported");
    }
    if (t.tag_cols < 1 || t.tag_rows < 1)
      Fail(context, "tagCols and tagRows must be >= 1");
    if (!(t.tag_size > 0.0))
      Fail(context, "tagSize must be > 0 (metres)");
    if (!(t.tag_spacing > 0.0))
      Fail(context, "tagSpacing must be > 0 (ratio gap / tagSize)");
    if (t.black_tag_border != 1 && t.black_tag_border != 2) {
      Fail(context, "blackTagBorder must be 1 or 2");
    }
  } else if (type == "checkerboard") {
    t.type = TargetType::kCheckerboard;
    allowed.insert({"targetCols", "targetRows", "rowSpacingMeters", "colSpacingMeters"});
    t.target_cols = Required<int>(node, "targetCols", context);
    t.target_rows = Required<int>(node, "targetRows", context);
    t.row_spacing_m = Required<double>(node, "rowSpacingMeters", context);
    t.col_spacing_m = Required<double>(node, "colSpacingMeters", context);
    if (t.target_cols < 2 || t.target_rows < 2) {
      Fail(context, "targetCols and targetRows (inner corners) must be >= 2");
    }
    if (!(t.row_spacing_m > 0.0) || !(t.col_spacing_m > 0.0)) {
      Fail(context, "rowSpacingMeters and colSpacingMeters must be > 0");
    }
  } else if (type == "charuco") {
    t.type = TargetType::kCharuco;
    allowed.insert({"squaresX", "squaresY", "squareLength", "markerLength", "dictionary"});
    t.squares_x = Required<int>(node, "squaresX", context);
    t.squares_y = Required<int>(node, "squaresY", context);
    t.square_length_m = Required<double>(node, "squareLength", context);
    t.marker_length_m = Required<double>(node, "markerLength", context);
    if (node["dictionary"])
      t.dictionary = Required<std::string>(node, "dictionary", context);
    if (t.squares_x < 2 || t.squares_y < 2)
      Fail(context, "squaresX and squaresY must be >= 2");
    if (!(t.square_length_m > 0.0))
      Fail(context, "squareLength must be > 0 (metres)");
    if (!(t.marker_length_m > 0.0) || !(t.marker_length_m < t.square_length_m))
      Fail(context, "markerLength must be > 0 and < squareLength (metres)");
    if (ArucoDictionaryId(t.dictionary) < 0)
      Fail(context, "unknown dictionary '" + t.dictionary + "' (OpenCV's names, e.g. DICT_4X4_50)");
  } else {
    Fail(context,
         "unknown target_type '" + type + "' (expected aprilgrid, checkerboard or charuco)");
  }
  for (const auto& kv : node) {
    const std::string key = kv.first.as<std::string>();
    if (!allowed.count(key))
      Fail(context, "unknown key '" + key + "' for " + type);
  }
  return t;
}

TargetConfig LoadTargetConfig(const std::string& path) {
  YAML::Node node;
  try {
    node = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw std::runtime_error(path + ": cannot open target file");
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(path + ": line " + std::to_string(e.mark.line + 1) +
                             ": malformed YAML: " + e.msg);
  }
  return ParseTargetConfig(node, path);
}

void EmitTargetConfig(const TargetConfig& t, YAML::Emitter& out) {
  out << YAML::BeginMap;
  if (t.type == TargetType::kAprilGrid) {
    out << YAML::Key << "target_type" << YAML::Value << "aprilgrid";
    out << YAML::Key << "tagCols" << YAML::Value << t.tag_cols;
    out << YAML::Key << "tagRows" << YAML::Value << t.tag_rows;
    out << YAML::Key << "tagSize" << YAML::Value << Shortest(t.tag_size);
    out << YAML::Key << "tagSpacing" << YAML::Value << Shortest(t.tag_spacing);
    out << YAML::Key << "blackTagBorder" << YAML::Value << t.black_tag_border;
  } else if (t.type == TargetType::kCharuco) {
    out << YAML::Key << "target_type" << YAML::Value << "charuco";
    out << YAML::Key << "squaresX" << YAML::Value << t.squares_x;
    out << YAML::Key << "squaresY" << YAML::Value << t.squares_y;
    out << YAML::Key << "squareLength" << YAML::Value << Shortest(t.square_length_m);
    out << YAML::Key << "markerLength" << YAML::Value << Shortest(t.marker_length_m);
    out << YAML::Key << "dictionary" << YAML::Value << t.dictionary;
  } else {
    out << YAML::Key << "target_type" << YAML::Value << "checkerboard";
    out << YAML::Key << "targetCols" << YAML::Value << t.target_cols;
    out << YAML::Key << "targetRows" << YAML::Value << t.target_rows;
    out << YAML::Key << "rowSpacingMeters" << YAML::Value << Shortest(t.row_spacing_m);
    out << YAML::Key << "colSpacingMeters" << YAML::Value << Shortest(t.col_spacing_m);
  }
  out << YAML::EndMap;
}

void SaveTargetConfig(const TargetConfig& target, const std::string& path) {
  YAML::Emitter out;
  out.SetDoublePrecision(17);
  EmitTargetConfig(target, out);
  std::ofstream f(path);
  if (!f)
    throw std::runtime_error(path + ": cannot write target file");
  f << out.c_str() << "\n";
}

}  // namespace ctcal
