#include "ctcal/sensors/compare.h"

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "ctcal/sensors/json_format.h"
#include "ctcal/sensors/number_format.h"
#include "ctcal/sensors/parameter_names.h"
#include "ctcal/spline/so3.h"

namespace ctcal {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

std::string Cell(double x) {
  if (std::isinf(x))
    return x > 0 ? "inf" : "-inf";
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.9g", x);
  return buf;
}

// The truth re-expressed with `base` (one of its sensors) as frame B and reference clock, so that
// a result with another base (a camera-only calibration of a visual-inertial rig) is compared
// in its own frames: T_base_S = T_B_base^-1 T_B_S, and with t_B = t_S + time_offset_S,
// t_base = t_B - time_offset_base, so time_offset'_S = time_offset_S - time_offset_base.
RigConfig Rebased(const RigConfig& truth, const std::string& base) {
  if (truth.base_imu == base)
    return truth;
  const SensorConfig* new_base = truth.Find(base);
  if (!new_base) {
    throw std::runtime_error("the result's base '" + base +
                             "' is not a sensor of the truth (base '" + truth.base_imu +
                             "'): their T_B_S are in different frames");
  }
  const Eigen::Matrix4d T_base_B = new_base->T_B_S.inverse();
  const double base_offset = new_base->time_offset;
  RigConfig out = truth;
  out.base_imu = base;
  for (SensorConfig& s : out.sensors) {
    s.T_B_S = s.name == base ? Eigen::Matrix4d::Identity() : Eigen::Matrix4d(T_base_B * s.T_B_S);
    s.time_offset = s.name == base ? 0.0 : s.time_offset - base_offset;
  }
  return out;
}

}  // namespace

Comparison CompareRigs(const RigConfig& truth_in, const RigConfig& result) {
  RigConfig truth = Rebased(truth_in, result.base_imu);
  Comparison c;
  const bool compare_gravity = truth.gravity_W.has_value() && result.gravity_W.has_value();
  // Gravity's magnitude is an input (gravity_magnitude, SPEC section 1), only its direction is
  // estimated, and its sigma is the direction's (a 2-dof sphere tangent). A result that assumed
  // another magnitude than the truth's (9.81 against standard gravity's 9.80665, 0.0034 m/s^2)
  // differs from it along g by that difference, which no sigma covers: 4.9 sigma in the component
  // along g of a Kalibr user's import. So the truth's direction is compared at the result's
  // magnitude; with equal magnitudes the truth is taken as it is.
  if (compare_gravity && truth.gravity_magnitude != result.gravity_magnitude &&
      truth.gravity_W->norm() > 0.0)
    truth.gravity_W = Eigen::Vector3d(truth.gravity_W->normalized() * result.gravity_W->norm());
  Eigen::Vector3d dtheta = Eigen::Vector3d::Zero();
  for (const ScalarParameter& p : ScalarParameters(result, true)) {
    if (p.sensor.empty() && !compare_gravity)
      continue;
    if (!p.sensor.empty()) {
      const SensorConfig* t = truth.Find(p.sensor);
      if (!t)
        throw std::runtime_error("the truth has no sensor '" + p.sensor + "' (needed for " +
                                 p.name + ")");
      if (t->type != result.Find(p.sensor)->type) {
        throw std::runtime_error("sensor '" + p.sensor + "' is a " +
                                 ToString(result.Find(p.sensor)->type) + " in the result but a " +
                                 ToString(t->type) + " in the truth");
      }
    }
    ComparisonRow row;
    row.name = p.name;
    row.rotation = p.rotation;
    if (p.rotation) {
      if (p.index == 0) {
        // The truth's model must have the same rotation (imu1's R_I_w is not imu2's R_I_a).
        if (!FindParameter(truth, p.name)) {
          throw std::runtime_error("the truth has no rotation " + p.sensor + "." + p.key +
                                   " (its model differs from the result's)");
        }
        const Eigen::Matrix3d R_true = ParameterRotation(truth, p);
        const Eigen::Matrix3d R_est = ParameterRotation(result, p);
        // Identical matrices give exactly 0, whatever the rounding of the quaternion product.
        dtheta.setZero();
        if (R_est != R_true) {
          dtheta = RotationError<double>(Eigen::Quaterniond(R_est).normalized(),
                                         Eigen::Quaterniond(R_true).normalized());
        }
        c.rotations.push_back({p.sensor + "." + p.key, dtheta.norm() * kRadToDeg});
      }
      row.truth = 0.0;
      row.estimate = dtheta(p.index);
      row.error = dtheta(p.index);
    } else {
      // The result's own parameter list decides the rows; the truth must have each of them.
      const std::optional<ScalarParameter> in_truth = FindParameter(truth, p.name);
      if (!in_truth) {
        throw std::runtime_error("the truth has no parameter " + p.name +
                                 " (its model differs from the result's)");
      }
      row.truth = ParameterValue(truth, *in_truth);
      row.estimate = ParameterValue(result, p);
      row.error = row.estimate - row.truth;
    }
    row.sigma = ParameterSigma(result, p);
    if (row.sigma && std::isfinite(*row.sigma) && *row.sigma > 0.0)
      row.error_over_sigma = row.error / *row.sigma;
    c.rows.push_back(row);
  }

  ComparisonSummary& s = c.summary;
  s.count = static_cast<int>(c.rows.size());
  for (const ComparisonRow& row : c.rows) {
    if (!row.error_over_sigma) {
      if (row.sigma && std::isinf(*row.sigma))
        ++s.undetermined;
      else
        ++s.no_sigma;
      continue;
    }
    ++s.with_sigma;
    const double z = std::abs(*row.error_over_sigma);
    if (z <= 3.0)
      ++s.within_3_sigma;
    if (!s.worst_error_over_sigma || z > std::abs(*s.worst_error_over_sigma)) {
      s.worst_error_over_sigma = *row.error_over_sigma;
      s.worst_name = row.name;
    }
  }
  if (s.with_sigma > 0)
    s.fraction_within_3_sigma = static_cast<double>(s.within_3_sigma) / s.with_sigma;
  return c;
}

std::string FormatComparison(const Comparison& c) {
  std::ostringstream out;
  char line[256];
  std::snprintf(line, sizeof(line), "%-28s %17s %17s %17s %13s %12s\n", "parameter", "truth",
                "estimate", "error", "sigma", "error/sigma");
  out << line;
  for (const ComparisonRow& r : c.rows) {
    std::string sigma = "-";
    std::string z = "-";
    if (r.sigma) {
      sigma = std::isinf(*r.sigma) ? "undetermined" : Cell(*r.sigma);
      if (r.error_over_sigma) {
        char buf[32];
        std::snprintf(buf, sizeof(buf), "%.3f", *r.error_over_sigma);
        z = buf;
      } else if (std::isinf(*r.sigma)) {
        z = "undetermined";
      }
    }
    std::snprintf(line, sizeof(line), "%-28s %17s %17s %17s %13s %12s\n", r.name.c_str(),
                  Cell(r.truth).c_str(), Cell(r.estimate).c_str(), Cell(r.error).c_str(),
                  sigma.c_str(), z.c_str());
    out << line;
  }
  for (const RotationComparison& r : c.rotations) {
    std::snprintf(line, sizeof(line), "%-28s angle of Log(R_est * R_true^T): %.6g deg\n",
                  r.name.c_str(), r.angle_deg);
    out << line;
  }
  const ComparisonSummary& s = c.summary;
  out << "summary: " << s.count << " estimated scalars, " << s.with_sigma << " with a sigma, "
      << s.undetermined << " undetermined (sigma .inf), " << s.no_sigma << " without a sigma";
  if (s.fraction_within_3_sigma) {
    std::snprintf(line, sizeof(line), "; %d (%.1f%%) within 3 sigma; worst %s at %.3f sigma",
                  s.within_3_sigma, 100.0 * *s.fraction_within_3_sigma, s.worst_name->c_str(),
                  *s.worst_error_over_sigma);
    out << line;
  }
  out << "\n";
  return out.str();
}

std::string ComparisonJson(const Comparison& c) {
  std::ostringstream out;
  out << "{\n  \"parameters\": [";
  for (std::size_t i = 0; i < c.rows.size(); ++i) {
    const ComparisonRow& r = c.rows[i];
    out << (i ? ",\n" : "\n") << "    {\"name\": " << JsonString(r.name)
        << ", \"truth\": " << JsonNumber(r.truth) << ", \"estimate\": " << JsonNumber(r.estimate)
        << ", \"error\": " << JsonNumber(r.error) << ", \"sigma\": " << JsonNumber(r.sigma)
        << ", \"error_over_sigma\": " << JsonNumber(r.error_over_sigma)
        << ", \"undetermined\": " << (r.sigma && std::isinf(*r.sigma) ? "true" : "false") << "}";
  }
  out << (c.rows.empty() ? "],\n" : "\n  ],\n") << "  \"rotations\": [";
  for (std::size_t i = 0; i < c.rotations.size(); ++i) {
    out << (i ? ", " : "") << "{\"name\": " << JsonString(c.rotations[i].name)
        << ", \"angle_deg\": " << JsonNumber(c.rotations[i].angle_deg) << "}";
  }
  const ComparisonSummary& s = c.summary;
  out << "],\n  \"summary\": {\"count\": " << s.count << ", \"with_sigma\": " << s.with_sigma
      << ", \"undetermined\": " << s.undetermined << ", \"no_sigma\": " << s.no_sigma
      << ", \"within_3_sigma\": " << s.within_3_sigma
      << ", \"fraction_within_3_sigma\": " << JsonNumber(s.fraction_within_3_sigma)
      << ", \"worst\": ";
  if (s.worst_name) {
    out << "{\"name\": " << JsonString(*s.worst_name)
        << ", \"error_over_sigma\": " << JsonNumber(s.worst_error_over_sigma) << "}";
  } else {
    out << "null";
  }
  out << "}\n}\n";
  return out.str();
}

}  // namespace ctcal
