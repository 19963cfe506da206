// Wall and CPU time of the stages of a command (the `ctcal calibrate` log's `time:` lines,
// docs/performance.md step 7d). On a machine shared with other processes the wall time says
// little; the process CPU (all threads) and a thread's own CPU say where the work is.
#pragma once

#include <chrono>
#include <string>
#include <vector>

namespace ctcal::report {

// CPU seconds of the whole process (every thread) and of the calling thread.
double ProcessCpuSeconds();
double ThreadCpuSeconds();

struct StageTime {
  std::string name;
  double wall_s = 0.0;
  double cpu_s = 0.0;  // process CPU over the stage (all threads)
};

// Laps of consecutive stages: each Lap() closes the stage that began at the previous Lap() (or
// at construction).
class StageClock {
 public:
  StageClock();
  StageTime Lap(const std::string& name);

 private:
  std::chrono::steady_clock::time_point wall_;
  double cpu_ = 0.0;
};

// "name 0.12 s (CPU 0.20 s)".
std::string FormatStageTime(const StageTime& t);
// "time: read 0.01 s (CPU 0.01 s), html 0.05 s (CPU 0.05 s), ..." (one line).
std::string FormatStageTimes(const std::vector<StageTime>& stages);

}  // namespace ctcal::report
