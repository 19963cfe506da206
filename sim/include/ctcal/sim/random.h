// The simulator's only source of randomness. Same seed -> same numbers on every platform: the
// engine (std::mt19937_64) is fully specified by the C++ standard, but the standard distributions
// are not (std::normal_distribution and even std::uniform_real_distribution differ between
// libstdc++, libc++ and MSVC), so the distributions here are written out explicitly.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <random>

namespace ctcal::sim {

class Random {
 public:
  explicit Random(std::uint64_t seed) : seed_(seed), engine_(seed) {}

  // An independent stream for one consumer (a sensor, the perturbation, ...), derived from this
  // generator's seed and `stream` only, never from how many numbers were drawn so far: adding a
  // sensor or a draw somewhere does not change the numbers every other consumer sees.
  Random Fork(std::uint64_t stream) const;

  // Uniform in [0, 1) with 53 random bits.
  double Uniform();
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  // Standard normal (Box-Muller; the second value of each pair is kept for the next call).
  double Gaussian();
  double Gaussian(double sigma) { return sigma * Gaussian(); }
  Eigen::Vector3d Gaussian3(double sigma);
  // 64 raw random bits (e.g. a seed for another generator).
  std::uint64_t Bits() { return engine_(); }
  // True with probability p.
  bool Bernoulli(double p) { return Uniform() < p; }

 private:
  std::uint64_t seed_;
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

}  // namespace ctcal::sim
