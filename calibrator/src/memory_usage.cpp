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

std::int64_t FreeHeapBytes() {
#if defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 33))
  return static_cast<std::int64_t>(mallinfo2().fordblks);
#else
  return -1;
#endif
}

bool ReleaseFreedMemory() {
#if defined(__GLIBC__)
  // A trim returns every free page, and the stage after it touches them again, a page fault each
  // (zeroed, on a virtual machine a trap to the host): EuRoC's 36 s held 13-58 MB free at each of
  // its 12 calls (the full calibration's and the subset's), and returning them cost ~0.27 s of
  // system time and 16 % of the command's wall time, for no lower peak. Held free below
  // kTrimAboveBytes, the next stage reuses them instead. The 10 min 1 kHz recording holds 80-300
  // MB free at 4 of its 6 calls (its loaded data, a solve's Jacobian, the prepared data) and
  // peaks where it did (868 MB; 887 MB with no trim at all).
  const std::int64_t free_bytes = FreeHeapBytes();
  if (free_bytes >= 0 && free_bytes < kTrimAboveBytes)
    return false;
  malloc_trim(0);
  return true;
#else
  return false;
#endif
}

void LogMemory(const std::function<void(const std::string&)>& log, const std::string& where) {
  if (MemoryLogEnabled())
    log("    " + MemoryNote(where));
}

}  // namespace ctcal
