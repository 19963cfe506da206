// The calibration's heap re-execution (apps/huge_page_heap.h): the GLIBC_TUNABLES value it sets,
// and when it leaves the process alone (the tunable set already, by the user or by the
// re-execution itself, which must not loop; huge pages never given, or given to all already); and
// the re-executed `ctcal calibrate` keeps its process name.
#include "huge_page_heap.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "cli_test_util.h"

namespace ctcal::app {
namespace {

constexpr const char* kMadvise = "always [madvise] never";

TEST(HugePageHeap, TurnsTheTunableOnBesideTheUsersOwn) {
  EXPECT_EQ(HugePageTunables(nullptr, kMadvise), "glibc.malloc.hugetlb=1");
  EXPECT_EQ(HugePageTunables("", kMadvise), "glibc.malloc.hugetlb=1");
  EXPECT_EQ(HugePageTunables("glibc.malloc.arena_max=2", kMadvise),
            "glibc.malloc.arena_max=2:glibc.malloc.hugetlb=1");
}

TEST(HugePageHeap, LeavesTheProcessAloneWhenThereIsNothingToDo) {
  // Set already: by the re-execution (no second one) or by the user (theirs stands, also 0).
  EXPECT_EQ(HugePageTunables("glibc.malloc.hugetlb=1", kMadvise), std::nullopt);
  EXPECT_EQ(HugePageTunables("glibc.malloc.arena_max=2:glibc.malloc.hugetlb=0", kMadvise),
            std::nullopt);
  // The kernel's mode: never, always (every anonymous page already), unreadable.
  EXPECT_EQ(HugePageTunables(nullptr, "always madvise [never]"), std::nullopt);
  EXPECT_EQ(HugePageTunables(nullptr, "[always] madvise never"), std::nullopt);
  EXPECT_EQ(HugePageTunables(nullptr, ""), std::nullopt);
}

// A file of /proc/<pid>/ ('\0' separators kept), empty when unreadable.
std::string ProcFile(pid_t pid, const char* name) {
  return test::Slurp("/proc/" + std::to_string(pid) + "/" + name);
}

// `ctcal calibrate` re-executes itself with the tunable, and the process is still named ctcal
// (`ps`, `pgrep ctcal`, `killall ctcal`; through /proc/self/exe it was "exe"). The rig is a FIFO:
// the calibration blocks on reading it after the re-execution, which its environment shows, and
// the test reads its name there; closing the FIFO then ends it (an empty rig: exit 2).
TEST(HugePageHeap, ReexecutedCalibrationKeepsItsName) {
  std::string enabled;
  std::getline(std::ifstream("/sys/kernel/mm/transparent_hugepage/enabled"), enabled);
  if (!HugePageTunables(std::getenv("GLIBC_TUNABLES"), enabled))
    GTEST_SKIP() << "no re-execution here: transparent huge pages are '" << enabled
                 << "' (it needs [madvise]) or GLIBC_TUNABLES sets the tunable already";
  const std::filesystem::path dir =
      std::filesystem::path(::testing::TempDir()) / ("ctcal_reexec_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string fifo = (dir / "rig.yaml").string();
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const std::string out = (dir / "out").string(), data = (dir / "data").string();
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const int null = open("/dev/null", O_WRONLY);
    dup2(null, 1);
    dup2(null, 2);
    execl(CTCAL_BINARY, CTCAL_BINARY, "calibrate", "--rig", fifo.c_str(), "--data", data.c_str(),
          "--out", out.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  bool reexecuted = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!reexecuted && std::chrono::steady_clock::now() < deadline) {
    reexecuted = ProcFile(pid, "environ").find("glibc.malloc.hugetlb=1") != std::string::npos;
    if (!reexecuted)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  const std::string name = ProcFile(pid, "comm");
  // Opening the FIFO for writing releases the reader; closing it gives it an empty file. Without
  // blocking: a calibration that never came to read it (it failed first) must not hang the test.
  int status = 0;
  pid_t ended = 0;
  while ((ended = waitpid(pid, &status, WNOHANG)) == 0) {
    const int writer = open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
    if (writer >= 0)
      close(writer);
    if (std::chrono::steady_clock::now() > deadline + std::chrono::seconds(30)) {
      kill(pid, SIGKILL);
      ended = waitpid(pid, &status, 0);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_EQ(ended, pid);
  ASSERT_TRUE(reexecuted) << "the calibration did not re-execute itself within 30 s";
  EXPECT_EQ(name, "ctcal\n");
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 2) << "status " << status;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace ctcal::app
