// The report's text and number formats and its image axes (report_format.h).
#include "report_format.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace ctcal::report::detail {

std::string Escape(const std::string& s) {
  std::string o;
  for (const char c : s) {
    switch (c) {
      case '&':
        o += "&amp;";
        break;
      case '<':
        o += "&lt;";
        break;
      case '>':
        o += "&gt;";
        break;
      case '"':
        o += "&quot;";
        break;
      default:
        o += c;
    }
  }
  return o;
}

Color StatusColor(Status s) {
  switch (s) {
    case Status::kPass:
      return kPass;
    case Status::kWarn:
      return kWarn;
    case Status::kFail:
      return kFail;
    default:
      return Color{0.55, 0.55, 0.55};
  }
}

std::string CssColor(const Color& c) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "#%02x%02x%02x", static_cast<int>(c.r * 255),
                static_cast<int>(c.g * 255), static_cast<int>(c.b * 255));
  return buf;
}

double Rms(const std::vector<double>& v) {
  double s = 0;
  int n = 0;
  for (const double x : v) {
    if (std::isfinite(x)) {
      s += x * x;
      ++n;
    }
  }
  return n ? std::sqrt(s / n) : kNaN;
}

// Units of a parameter key (SPEC section 7).
std::string Units(const ScalarParameter& p, const RigConfig& rig) {
  if (p.sensor.empty())
    return "m/s^2";
  if (p.rotation)
    return "rad";
  if (p.key == "t_B_S")
    return "m";
  if (p.key == "time_offset")
    return "s";
  if (p.key == "line_delay")
    return "s/row";
  if (p.key == "Tg")
    return "(rad/s)/(m/s^2)";
  if (p.key == "intrinsics") {
    const SensorConfig* s = rig.Find(p.sensor);
    if (s && s->camera_model == "pinhole")
      return "px";
    return "px or -";
  }
  return "-";
}

// "v +- s" with the sigma to 2 significant digits and the value to the same decimals, a common
// power of ten factored out for very small or large numbers: "458.652 +- 0.021",
// "(1.23 +- 0.45)e-04". Without a sigma: the value to 6 digits; sigma .inf: "+- inf".
std::string ValueSigma(double v, const std::optional<double>& sigma) {
  if (!std::isfinite(v))
    return FormatNumber(v);
  if (!sigma || !(*sigma > 0.0))
    return FormatNumber(v, 6);
  if (!std::isfinite(*sigma))
    return FormatNumber(v, 6) + " +- inf";
  const double mag = std::max(std::abs(v), *sigma);
  int e = 0;
  if (mag < 1e-3 || mag >= 1e5)
    e = static_cast<int>(std::floor(std::log10(mag)));
  const double scale = std::pow(10.0, -e);
  const int decimals =
      std::clamp(1 - static_cast<int>(std::floor(std::log10(*sigma * scale))), 0, 9);
  char buf[96];
  if (e == 0)
    std::snprintf(buf, sizeof buf, "%.*f +- %.*f", decimals, v, decimals, *sigma);
  else
    std::snprintf(buf, sizeof buf, "(%.*f +- %.*f)e%+03d", decimals, v * scale, decimals,
                  *sigma * scale, e);
  return buf;
}

void ImageAxes(double W, double H, XYPlot* p) {
  p->x_label = "u [px]";
  p->y_label = "v [px]";
  p->equal_aspect = true;
  p->y_down = true;
  p->x_min = -0.5;
  p->x_max = W - 0.5;
  p->y_min = -0.5;
  p->y_max = H - 0.5;
}

void ImageAxes(double W, double H, HeatMap* hm) {
  hm->x_lo = -0.5;
  hm->x_hi = W - 0.5;
  hm->y_lo = -0.5;
  hm->y_hi = H - 0.5;
  hm->x_label = "u [px]";
  hm->y_label = "v [px]";
}

}  // namespace ctcal::report::detail
