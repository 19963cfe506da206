// The calibration's heap on transparent huge pages: glibc's malloc asked to advise the kernel to
// back its heap with 2 MiB pages (docs/performance.md, issue 23 session 16).
#pragma once

#include <optional>
#include <string>

namespace ctcal::app {

// The GLIBC_TUNABLES value that turns glibc.malloc.hugetlb on, given the current value (null:
// unset) and the first line of /sys/kernel/mm/transparent_hugepage/enabled; nullopt when there is
// nothing to do: the tunable is set already (by the user, or by the re-execution below), or the
// kernel gives huge pages to no one ("[never]") or to everyone already ("[always]").
std::optional<std::string> HugePageTunables(const char* current, const std::string& thp_enabled);

// Re-executes this program with HugePageTunables' value when there is one (its file, as
// /proc/self/exe names it, so that the process keeps its name; the same arguments); returns when
// there is none or the re-execution fails (the run then goes on as before). glibc reads its
// tunables once, at start-up: setting one needs a new process image.
void ReexecWithHugePageHeap(char** argv);

// Whether this process runs with glibc.malloc.hugetlb=1 (the log says so: a re-execution is not
// otherwise visible).
bool HeapOnHugePages();

}  // namespace ctcal::app
