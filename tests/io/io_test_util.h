// Shared by the file round-trip tests: values that exercise every bit of a double.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>

namespace ctcal::test {

// Any finite double, drawn from its bit pattern so that every exponent range is exercised.
inline double RandomDouble(std::mt19937_64& rng) {
  while (true) {
    const std::uint64_t bits = rng();
    double x;
    std::memcpy(&x, &bits, sizeof(x));
    if (std::isfinite(x))
      return x;
  }
}

}  // namespace ctcal::test
