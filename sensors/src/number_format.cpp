#include "ctcal/sensors/number_format.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>

namespace ctcal {

std::string FormatDouble(double x) {
  if (std::isnan(x))
    return ".nan";
  if (std::isinf(x))
    return x > 0 ? ".inf" : "-.inf";
  char buf[64];
  // Shortest round-trip representation (C++17 <charconv>): exact, and readable for 9.81.
  const auto res = std::to_chars(buf, buf + sizeof(buf), x);
  std::string s(buf, res.ptr);
  if (s.find('.') == std::string::npos) {
    const std::size_t e = s.find('e');
    if (e == std::string::npos)
      s += ".0";
    else
      s.insert(e, ".0");
  }
  return s;
}

bool ParseDouble(const std::string& s, double* x) {
  std::string lower(s);
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  constexpr double kInf = std::numeric_limits<double>::infinity();
  if (lower == ".inf" || lower == "+.inf" || lower == "inf" || lower == "+inf") {
    *x = kInf;
    return true;
  }
  if (lower == "-.inf" || lower == "-inf") {
    *x = -kInf;
    return true;
  }
  if (lower == ".nan" || lower == "nan") {
    *x = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  if (s.empty())
    return false;
  const char* begin = s.data();
  if (*begin == '+')
    ++begin;
  double value = 0.0;
  const auto res = std::from_chars(begin, s.data() + s.size(), value);
  if (res.ec != std::errc() || res.ptr != s.data() + s.size())
    return false;
  *x = value;
  return true;
}

}  // namespace ctcal
