// Independent work items on a few threads, for the calibrator's embarrassingly parallel loops
// (PnP per frame, correlation per lag). Each item writes its own output slot, so the result does
// not depend on the thread count or the schedule: a loop is parallelised without changing a bit
// of what it computes.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace ctcal {

// Calls body(i) once for every i in [0, n), on up to `threads` threads (the caller's among them;
// <= 1: serially, in order). Items are handed out one at a time, so uneven items balance. The
// first exception a body throws is rethrown after every thread has finished.
template <typename Body>
void ParallelFor(int threads, std::size_t n, const Body& body) {
  const std::size_t workers =
      std::min<std::size_t>(n, static_cast<std::size_t>(std::max(threads, 1)));
  if (workers <= 1) {
    for (std::size_t i = 0; i < n; ++i)
      body(i);
    return;
  }
  std::atomic<std::size_t> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  const auto work = [&] {
    for (std::size_t i = next++; i < n; i = next++) {
      try {
        body(i);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(error_mutex);
        if (!error)
          error = std::current_exception();
        next = n;  // stop handing out items
      }
    }
  };
  std::vector<std::thread> pool;
  for (std::size_t t = 1; t < workers; ++t)
    pool.emplace_back(work);
  work();
  for (std::thread& t : pool)
    t.join();
  if (error)
    std::rethrow_exception(error);
}

}  // namespace ctcal
