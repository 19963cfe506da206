#include "ctcal/report/stage_time.h"

#include <time.h>

#include <cstdio>

namespace ctcal::report {
namespace {

double ClockSeconds(clockid_t id) {
  timespec ts{};
  if (clock_gettime(id, &ts) != 0)
    return 0.0;
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

}  // namespace

double ProcessCpuSeconds() {
  return ClockSeconds(CLOCK_PROCESS_CPUTIME_ID);
}
double ThreadCpuSeconds() {
  return ClockSeconds(CLOCK_THREAD_CPUTIME_ID);
}

StageClock::StageClock() : wall_(std::chrono::steady_clock::now()), cpu_(ProcessCpuSeconds()) {}

StageTime StageClock::Lap(const std::string& name) {
  const auto wall = std::chrono::steady_clock::now();
  const double cpu = ProcessCpuSeconds();
  StageTime t{name, std::chrono::duration<double>(wall - wall_).count(), cpu - cpu_};
  wall_ = wall;
  cpu_ = cpu;
  return t;
}

std::string FormatStageTime(const StageTime& t) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "%s %.2f s (CPU %.2f s)", t.name.c_str(), t.wall_s, t.cpu_s);
  return buf;
}

std::string FormatStageTimes(const std::vector<StageTime>& stages) {
  std::string line = "time:";
  for (size_t i = 0; i < stages.size(); ++i)
    line += (i ? ", " : " ") + FormatStageTime(stages[i]);
  return line;
}

}  // namespace ctcal::report
