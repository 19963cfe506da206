#include "ctcal/sensors/inertial_noise.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace ctcal {

namespace {

void CheckPositive(double value, const char* key) {
  if (!std::isfinite(value) || !(value > 0.0)) {
    std::ostringstream s;
    s << "noise." << key << ": must be a positive finite number, got " << value;
    throw std::invalid_argument(s.str());
  }
}

}  // namespace

void InertialNoise::Validate(bool has_accelerometer) const {
  CheckPositive(gyroscope_noise_density, "gyroscope_noise_density");
  CheckPositive(gyroscope_random_walk, "gyroscope_random_walk");
  if (has_accelerometer) {
    CheckPositive(accelerometer_noise_density, "accelerometer_noise_density");
    CheckPositive(accelerometer_random_walk, "accelerometer_random_walk");
  }
  CheckPositive(update_rate, "update_rate");
}

}  // namespace ctcal
