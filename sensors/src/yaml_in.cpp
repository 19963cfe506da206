#include "yaml_in.h"

#include <Eigen/Dense>
#include <cmath>
#include <stdexcept>

#include "ctcal/sensors/number_format.h"

namespace ctcal::internal {

YAML::Node YamlIn::LoadFile(const std::string& path) {
  try {
    return YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw std::runtime_error(path + ": cannot open file");
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(path + ":" + std::to_string(e.mark.line + 1) +
                             ": malformed YAML: " + e.msg);
  }
}

void YamlIn::Fail(const YAML::Node& at, const std::string& where, const std::string& what) const {
  std::string msg = file_;
  if (at.IsDefined() && at.Mark().line >= 0)
    msg += ":" + std::to_string(at.Mark().line + 1);
  msg += ": ";
  if (!where.empty())
    msg += where + ": ";
  throw std::runtime_error(msg + what);
}

void YamlIn::RequireMap(const YAML::Node& node, const std::string& where) const {
  if (!node.IsMap())
    Fail(node, where, "expected a map of keys");
}

void YamlIn::CheckKeys(const YAML::Node& map, const std::string& where,
                       const std::set<std::string>& allowed, const std::string& kind) const {
  RequireMap(map, where);
  std::set<std::string> seen;
  for (const auto& kv : map) {
    if (!kv.first.IsScalar())
      Fail(kv.first, where, "a key must be a plain word");
    const std::string key = kv.first.Scalar();
    if (!allowed.count(key)) {
      std::string list;
      for (const std::string& a : allowed)
        list += (list.empty() ? "" : ", ") + a;
      Fail(kv.first, where, "unknown key '" + key + "' for " + kind + " (allowed: " + list + ")");
    }
    if (!seen.insert(key).second)
      Fail(kv.first, where, "key '" + key + "' is given twice");
  }
}

double YamlIn::Double(const YAML::Node& node, const std::string& where) const {
  double x = 0.0;
  if (!node.IsScalar() || !ParseDouble(node.Scalar(), &x))
    Fail(node, where,
         "expected a number" + (node.IsScalar() ? ", got '" + node.Scalar() + "'" : ""));
  return x;
}

double YamlIn::FiniteDouble(const YAML::Node& node, const std::string& where) const {
  const double x = Double(node, where);
  if (!std::isfinite(x))
    Fail(node, where, "expected a finite number, got '" + node.Scalar() + "'");
  return x;
}

std::int64_t YamlIn::Int64(const YAML::Node& node, const std::string& where) const {
  if (!node.IsScalar())
    Fail(node, where, "expected an integer");
  const std::string& s = node.Scalar();
  std::size_t used = 0;
  long long v = 0;
  try {
    v = std::stoll(s, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != s.size())
    Fail(node, where, "expected an integer, got '" + s + "'");
  return v;
}

int YamlIn::Int(const YAML::Node& node, const std::string& where) const {
  const std::int64_t v = Int64(node, where);
  if (v < -2147483647 || v > 2147483647)
    Fail(node, where, "integer out of range: " + node.Scalar());
  return static_cast<int>(v);
}

std::string YamlIn::String(const YAML::Node& node, const std::string& where) const {
  if (!node.IsScalar())
    Fail(node, where, "expected a word");
  return node.Scalar();
}

std::vector<std::string> YamlIn::StringList(const YAML::Node& node,
                                            const std::string& where) const {
  std::vector<std::string> out;
  if (node.IsNull())
    return out;
  if (!node.IsSequence())
    Fail(node, where, "expected a list");
  for (const auto& item : node)
    out.push_back(String(item, where));
  return out;
}

std::vector<double> YamlIn::Vector(const YAML::Node& node, const std::string& where, int size,
                                   bool allow_non_finite) const {
  if (!node.IsSequence())
    Fail(node, where, "expected a list of numbers");
  if (size >= 0 && static_cast<int>(node.size()) != size) {
    Fail(node, where,
         "expected " + std::to_string(size) + " numbers, got " + std::to_string(node.size()));
  }
  std::vector<double> out;
  for (const auto& item : node)
    out.push_back(allow_non_finite ? Double(item, where) : FiniteDouble(item, where));
  return out;
}

Eigen::Vector3d YamlIn::Vector3(const YAML::Node& node, const std::string& where) const {
  const std::vector<double> v = Vector(node, where, 3);
  return Eigen::Vector3d(v[0], v[1], v[2]);
}

Eigen::MatrixXd YamlIn::Matrix(const YAML::Node& node, const std::string& where, int rows,
                               int cols) const {
  const std::string shape = std::to_string(rows) + "x" + std::to_string(cols);
  if (!node.IsSequence() || static_cast<int>(node.size()) != rows)
    Fail(node, where,
         "expected a " + shape + " matrix as a list of " + std::to_string(rows) + " rows");
  Eigen::MatrixXd m(rows, cols);
  for (int r = 0; r < rows; ++r) {
    const YAML::Node row = node[r];
    if (!row.IsSequence() || static_cast<int>(row.size()) != cols)
      Fail(row, where,
           "expected a " + shape + " matrix: row " + std::to_string(r) + " must have " +
               std::to_string(cols) + " numbers");
    for (int c = 0; c < cols; ++c)
      m(r, c) = FiniteDouble(row[c], where);
  }
  return m;
}

Eigen::Matrix3d YamlIn::CheckedRotation(const Eigen::Matrix3d& R, const YAML::Node& node,
                                        const std::string& where, const std::string& what) const {
  const double orth = (R.transpose() * R - Eigen::Matrix3d::Identity()).norm();
  if (orth > 1e-3 || R.determinant() < 0.0) {
    Fail(node, where,
         what + " (|R^T R - I| = " + FormatDouble(orth) +
             ", det = " + FormatDouble(R.determinant()) + ")");
  }
  if (orth <= 1e-6)
    return R;
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d nearest = svd.matrixU() * svd.matrixV().transpose();
  if (warn_) {
    const int line = node.Mark().line >= 0 ? node.Mark().line + 1 : 0;
    warn_(file_ + ":" + std::to_string(line) + ": warning: " + where +
          ": rotation not orthonormal within 1e-6 (|R^T R - I| = " + FormatDouble(orth) +
          "), taken as the nearest rotation");
  }
  return nearest;
}

Eigen::Matrix3d YamlIn::Rotation(const YAML::Node& node, const std::string& where) const {
  return CheckedRotation(Matrix(node, where, 3, 3), node, where, "not a rotation matrix");
}

Eigen::Matrix4d YamlIn::Rigid(const YAML::Node& node, const std::string& where) const {
  Eigen::Matrix4d T = Matrix(node, where, 4, 4);
  T.topLeftCorner<3, 3>() = CheckedRotation(T.topLeftCorner<3, 3>(), node, where,
                                            "not a rigid transform: rotation block");
  if (T(3, 0) != 0.0 || T(3, 1) != 0.0 || T(3, 2) != 0.0 || T(3, 3) != 1.0)
    Fail(node, where, "not a rigid transform: last row must be [0, 0, 0, 1]");
  return T;
}

}  // namespace ctcal::internal
