#include "ctcal/calibrator/memory_usage.h"

#include <sys/resource.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace ctcal {

MemoryUsage CurrentMemoryUsage() {
  MemoryUsage m;
  // statm: total program size, then resident pages.
  if (std::FILE* f = std::fopen("/proc/self/statm", "r")) {
    long size = 0, resident = 0;
    if (std::fscanf(f, "%ld %ld", &size, &resident) == 2)
      m.rss_mb = static_cast<double>(resident) * static_cast<double>(sysconf(_SC_PAGESIZE)) / 1e6;
    std::fclose(f);
  }
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) == 0)
    m.peak_mb = static_cast<double>(usage.ru_maxrss) * 1024.0 / 1e6;  // ru_maxrss is in KiB
  return m;
}

bool MemoryLogEnabled() {
  static const bool enabled = [] {
    const char* env = std::getenv("CTCAL_LOG_MEMORY");
    return env != nullptr && std::strcmp(env, "0") != 0;
  }();
  return enabled;
}

std::string MemoryNote(const std::string& where) {
  if (!MemoryLogEnabled())
    return {};
  const MemoryUsage m = CurrentMemoryUsage();
  char line[200];
  std::snprintf(line, sizeof line, "memory: RSS %.0f MB, peak %.0f MB (%s)", m.rss_mb, m.peak_mb,
                where.c_str());
  return line;
}

void ReleaseFreedMemory() {
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

void LogMemory(const std::function<void(const std::string&)>& log, const std::string& where) {
  if (MemoryLogEnabled())
    log("    " + MemoryNote(where));
}

}  // namespace ctcal
