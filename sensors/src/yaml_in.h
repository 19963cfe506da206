// Private to sensors/: strict reading of YAML values with one error style for every file of SPEC
// section 7 and Kalibr's files: "<file>:<line>: <where>: <what>", thrown as std::runtime_error.
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <functional>
#include <set>
#include <string>
#include <vector>

namespace ctcal::internal {

class YamlIn {
 public:
  explicit YamlIn(std::string file) : file_(std::move(file)) {}
  const std::string& file() const { return file_; }
  // Receives the notes of values taken with a correction (a rotation re-orthonormalised); without
  // one they are dropped.
  void SetWarn(std::function<void(const std::string&)> warn) { warn_ = std::move(warn); }

  // Loads a file; a missing file or malformed YAML throws naming the file (and line).
  static YAML::Node LoadFile(const std::string& path);

  [[noreturn]] void Fail(const YAML::Node& at, const std::string& where,
                         const std::string& what) const;

  // Every key of `map` must be in `allowed`; a key given twice is an error too (yaml-cpp keeps
  // one of them silently). `kind` names what the map is ("sensor of type imu") in the message.
  void CheckKeys(const YAML::Node& map, const std::string& where,
                 const std::set<std::string>& allowed, const std::string& kind) const;
  void RequireMap(const YAML::Node& node, const std::string& where) const;

  double Double(const YAML::Node& node, const std::string& where) const;
  // Finite value required (NaN and infinities are errors).
  double FiniteDouble(const YAML::Node& node, const std::string& where) const;
  int Int(const YAML::Node& node, const std::string& where) const;
  std::int64_t Int64(const YAML::Node& node, const std::string& where) const;
  std::string String(const YAML::Node& node, const std::string& where) const;
  std::vector<std::string> StringList(const YAML::Node& node, const std::string& where) const;
  // A flat list of numbers; `size` < 0: any size. Non-finite numbers are errors unless allowed.
  std::vector<double> Vector(const YAML::Node& node, const std::string& where, int size,
                             bool allow_non_finite = false) const;
  Eigen::Vector3d Vector3(const YAML::Node& node, const std::string& where) const;
  // A row-major list of `rows` lists of `cols` finite numbers.
  Eigen::MatrixXd Matrix(const YAML::Node& node, const std::string& where, int rows,
                         int cols) const;
  // A rotation matrix with det +1: kept as written when orthonormal within 1e-6 (8 digits,
  // Kalibr's files; exact round trips), replaced by the nearest rotation with a note when within
  // 1e-3 (a drawing's rotation rounded to 4-6 decimals), an error beyond.
  Eigen::Matrix3d Rotation(const YAML::Node& node, const std::string& where) const;
  // A rigid transform: rotation block as above, last row [0 0 0 1].
  Eigen::Matrix4d Rigid(const YAML::Node& node, const std::string& where) const;

 private:
  // R checked as above; `what` starts the error message.
  Eigen::Matrix3d CheckedRotation(const Eigen::Matrix3d& R, const YAML::Node& node,
                                  const std::string& where, const std::string& what) const;

  std::string file_;
  std::function<void(const std::string&)> warn_;
};

}  // namespace ctcal::internal
