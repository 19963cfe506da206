#include "huge_page_heap.h"

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <system_error>

namespace ctcal::app {

std::optional<std::string> HugePageTunables(const char* current, const std::string& thp_enabled) {
  const std::string now = current != nullptr ? current : "";
  if (now.find("glibc.malloc.hugetlb") != std::string::npos ||
      thp_enabled.find("[madvise]") == std::string::npos)
    return std::nullopt;
  return now.empty() ? "glibc.malloc.hugetlb=1" : now + ":glibc.malloc.hugetlb=1";
}

void ReexecWithHugePageHeap(char** argv) {
#if defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 35))
  // Why: the calibration touches ~400 MB of fresh heap pages over a run (its normal equations,
  // factors and Jacobian scratch, allocated per solve), one page fault per 4 KiB page: ~10 % of
  // its CPU samples in the kernel's fault path on a virtual machine (EuRoC's 36 s: 96 k faults,
  // 0.80 s of system time). With the heap advised for 2 MiB pages: 41 k faults, 0.56 s, the whole
  // command 0.93x, the re-execution included (docs/performance.md, issue 23 session 16).
  std::string enabled;
  std::ifstream thp("/sys/kernel/mm/transparent_hugepage/enabled");
  std::getline(thp, enabled);
  const char* current = std::getenv("GLIBC_TUNABLES");
  const std::optional<std::string> tunables = HugePageTunables(current, enabled);
  if (!tunables)
    return;
  const std::string saved = current != nullptr ? current : "";
  if (setenv("GLIBC_TUNABLES", tunables->c_str(), 1) != 0)
    return;
  // The program's own file by its name: the kernel names a process after the file it executes,
  // and /proc/self/exe made that "exe" (`ps`, `top`, `pgrep ctcal` and `killall ctcal` no longer
  // found the calibration). The link itself when its target cannot be executed (the file replaced
  // or removed since the start: "... (deleted)").
  std::error_code error;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error)
    execv(self.c_str(), argv);
  execv("/proc/self/exe", argv);
  // Still here: the re-execution failed (no /proc, say). Go on in this process, as it was.
  if (current != nullptr)
    setenv("GLIBC_TUNABLES", saved.c_str(), 1);
  else
    unsetenv("GLIBC_TUNABLES");
#else
  (void)argv;
#endif
}

bool HeapOnHugePages() {
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  return tunables != nullptr &&
         std::string(tunables).find("glibc.malloc.hugetlb=1") != std::string::npos;
}

}  // namespace ctcal::app
