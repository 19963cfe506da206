// The report's text and number formats and its image axes, shared by its pages
// (report_*.cpp). Private to the report library.
#pragma once

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "ctcal/report/plot.h"
#include "ctcal/report/report.h"
#include "ctcal/sensors/parameter_names.h"
#include "ctcal/sensors/rig.h"

namespace ctcal::report::detail {

constexpr double kPageW = 842.0, kPageH = 595.0;  // A4 landscape, pt
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// `s` with HTML's special characters escaped.
std::string Escape(const std::string& s);
Color StatusColor(Status s);
std::string CssColor(const Color& c);
double Rms(const std::vector<double>& v);

// Units of a parameter key (SPEC section 7).
std::string Units(const ScalarParameter& p, const RigConfig& rig);

// "v +- s" with the sigma to 2 significant digits and the value to the same decimals, a common
// power of ten factored out for very small or large numbers: "458.652 +- 0.021",
// "(1.23 +- 0.45)e-04". Without a sigma: the value to 6 digits; sigma .inf: "+- inf".
std::string ValueSigma(double v, const std::optional<double>& sigma);

// The image plane of a W x H camera as axes: pixel centres at integers (SPEC section 2), so the
// image spans [-0.5, W - 0.5] x [-0.5, H - 0.5]; v grows downwards and pixels are square.
void ImageAxes(double W, double H, XYPlot* p);
void ImageAxes(double W, double H, HeatMap* hm);

}  // namespace ctcal::report::detail
