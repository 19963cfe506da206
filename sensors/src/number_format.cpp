#include "ctcal/sensors/number_format.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>
#include <string_view>

namespace ctcal {

char* FormatDoubleTo(char* first, char* last, double x) {
  const auto put = [&](std::string_view text) {
    const std::size_t n = std::min(text.size(), static_cast<std::size_t>(last - first));
    std::copy_n(text.data(), n, first);
    return first + n;
  };
  if (std::isnan(x))
    return put(".nan");
  if (std::isinf(x))
    return put(x > 0 ? ".inf" : "-.inf");
  // Shortest round-trip representation (C++17 <charconv>): exact, and readable for 9.81.
  char* end = std::to_chars(first, last, x).ptr;
  if (std::find(first, end, '.') != end || end + 2 > last)
    return end;
  // No '.': "1" -> "1.0", "2e-05" -> "2.0e-05".
  char* e = std::find(first, end, 'e');
  std::copy_backward(e, end, end + 2);
  e[0] = '.';
  e[1] = '0';
  return end + 2;
}

std::string FormatDouble(double x) {
  char buf[kFormatDoubleChars];
  return std::string(buf, FormatDoubleTo(buf, buf + sizeof buf, x));
}

bool ParseDouble(std::string_view s, double* x) {
  // Plain numbers first (a dataset holds millions): what from_chars takes whole, after an
  // optional '+', is the answer; YAML's names and their spellings only when it does not.
  const char* begin = s.data() + (!s.empty() && s[0] == '+' ? 1 : 0);
  const char* end = s.data() + s.size();
  double value = 0.0;
  // from_chars takes a '-' of its own: "+-1" is no number (it read as -1).
  if (!s.empty() && !(begin != s.data() && begin != end && *begin == '-')) {
    const auto res = std::from_chars(begin, end, value);
    if (res.ec == std::errc() && res.ptr == end) {
      *x = value;
      return true;
    }
  }
  if (s.size() > 5)
    return false;  // longer than every name below
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
  return false;
}

}  // namespace ctcal
