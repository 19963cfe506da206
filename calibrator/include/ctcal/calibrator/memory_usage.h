// The process' memory at a point of the run: where a long recording's peak comes from
// (docs/performance.md, step 7). The peak of a whole command is what `/usr/bin/time -v` reports;
// these probes split it by stage.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

namespace ctcal {

struct MemoryUsage {
  double rss_mb = 0.0;   // resident now (/proc/self/statm; 0 where not available)
  double peak_mb = 0.0;  // the largest resident size so far (getrusage ru_maxrss)
};

MemoryUsage CurrentMemoryUsage();

// Whether the environment variable CTCAL_LOG_MEMORY is set (to anything but "0"): the
// calibrators then log a memory line at every stage boundary and LM iteration.
bool MemoryLogEnabled();

// "memory: RSS 512 MB, peak 1024 MB (<where>)", or empty when !MemoryLogEnabled().
std::string MemoryNote(const std::string& where);

// The bytes the heap holds free (freed, still resident or reusable; glibc's mallinfo2 over every
// arena), or -1 where that is not known.
std::int64_t FreeHeapBytes();

// Returns the heap's freed pages to the system (glibc's malloc_trim; a no-op elsewhere), so that
// memory a finished stage freed is not still resident while the next stage peaks, when the heap
// holds at least kTrimAboveBytes free (where FreeHeapBytes is not known: always). Less is kept for
// the next stage to reuse: returned, its pages are faulted in again (memory_usage.cpp). Returns
// whether it trimmed.
inline constexpr std::int64_t kTrimAboveBytes = std::int64_t{64} << 20;
bool ReleaseFreedMemory();

// Passes MemoryNote(where), indented, to `log` when MemoryLogEnabled().
void LogMemory(const std::function<void(const std::string&)>& log, const std::string& where);

}  // namespace ctcal
