#include "ctcal/sim/random.h"

#include <cmath>

namespace ctcal::sim {
namespace {

// SplitMix64 finaliser: decorrelates seeds that differ in a few bits (seed, seed + 1, ...).
std::uint64_t Mix(std::uint64_t z) {
  z += 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

}  // namespace

Random Random::Fork(std::uint64_t stream) const {
  return Random(Mix(Mix(seed_) ^ Mix(stream + 0x632be59bd9b4e019ULL)));
}

double Random::Uniform() {
  // The top 53 bits of one 64-bit draw, scaled exactly into [0, 1).
  return static_cast<double>(engine_() >> 11) * 0x1.0p-53;
}

double Random::Gaussian() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  // Box-Muller: u1 in (0, 1] so that log(u1) is finite.
  const double u1 = 1.0 - Uniform();
  const double u2 = Uniform();
  const double r = std::sqrt(-2.0 * std::log(u1));
  const double angle = 2.0 * M_PI * u2;
  spare_ = r * std::sin(angle);
  has_spare_ = true;
  return r * std::cos(angle);
}

Eigen::Vector3d Random::Gaussian3(double sigma) {
  // Evaluated in a fixed order (function arguments would not be).
  const double x = Gaussian(sigma);
  const double y = Gaussian(sigma);
  const double z = Gaussian(sigma);
  return Eigen::Vector3d(x, y, z);
}

}  // namespace ctcal::sim
