#include "ctcal/sensors/json_format.h"

#include <cmath>
#include <cstdio>

#include "ctcal/sensors/number_format.h"

namespace ctcal {

std::string JsonNumber(double x) {
  return std::isfinite(x) ? FormatDouble(x) : "null";
}

std::string JsonNumber(const std::optional<double>& x) {
  return x ? JsonNumber(*x) : std::string("null");
}

std::string JsonString(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof(buf), "\\u%04x", c);
      out += buf;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

}  // namespace ctcal
