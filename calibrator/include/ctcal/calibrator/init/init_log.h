// What every coarse-guess initialisation stage shares: the error that names the stage and the
// sensor, and the sink for the one-line findings each stage logs.
#pragma once

#include <cstdint>
#include <cstdio>
#include <functional>
#include <stdexcept>
#include <string>

namespace ctcal {

// Thrown by a stage that cannot produce its quantity from the data (too few views, no rotation,
// an ambiguous correlation peak, ...). what() is "initialisation stage '<stage>', sensor
// '<sensor>': <reason>", so the user knows which sensor to fix and how.
class InitError : public std::runtime_error {
 public:
  InitError(const std::string& stage, const std::string& sensor, const std::string& reason);
  const std::string& stage() const { return stage_; }
  const std::string& sensor() const { return sensor_; }

 private:
  std::string stage_;
  std::string sensor_;
};

// Receives one line per finding (no trailing newline). An empty function logs nothing.
using InitLog = std::function<void(const std::string&)>;

// Writes "[init] <line>" to stderr: the default sink of every stage.
void LogInitToStderr(const std::string& line);

// A finding or a reason, printf-style (up to 511 characters: one log line).
template <typename... Args>
std::string FormatInitLine(const char* fmt, Args... args) {
  char buffer[512];
  std::snprintf(buffer, sizeof(buffer), fmt, args...);
  return buffer;
}

// A stamp in seconds, the unit the stages compute and print times in.
inline double InitSeconds(std::int64_t t_ns) {
  return static_cast<double>(t_ns) * 1e-9;
}

}  // namespace ctcal
