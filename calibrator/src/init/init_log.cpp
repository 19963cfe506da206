#include "ctcal/calibrator/init/init_log.h"

#include <iostream>

namespace ctcal {

InitError::InitError(const std::string& stage, const std::string& sensor, const std::string& reason)
    : std::runtime_error("initialisation stage '" + stage + "', sensor '" + sensor +
                         "': " + reason),
      stage_(stage),
      sensor_(sensor) {}

void LogInitToStderr(const std::string& line) {
  std::cerr << "[init] " << line << '\n';
}

}  // namespace ctcal
