// Shared helpers of the end-to-end tests of the `ctcal` command line: run the built executable
// with its output captured, and read back what it wrote.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace ctcal::test {

struct CliRun {
  int code = -1;  // the exit code, -1 when the process did not exit normally
  std::string out;
  std::string err;
};

// The whole file ("" when it cannot be read).
inline std::string Slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// Runs `ctcal <args>` through the shell; stdout and stderr go to stdout.txt and stderr.txt in
// `dir` (created), which should be unique per test: ctest runs tests in parallel. With
// `timeout_s` > 0 the run is killed after that many seconds (coreutils' timeout): the code is then
// 124, and 128 + N when ctcal died of signal N.
inline CliRun RunCtcal(const std::string& args, const std::string& dir, int timeout_s = 0) {
  std::filesystem::create_directories(dir);
  const std::string out = dir + "/stdout.txt", err = dir + "/stderr.txt";
  const std::string cmd =
      (timeout_s > 0 ? "timeout -k 5 " + std::to_string(timeout_s) + " " : std::string()) +
      std::string(CTCAL_BINARY) + " " + args + " >" + out + " 2>" + err;
  const int status = std::system(cmd.c_str());
  CliRun r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = Slurp(out);
  r.err = Slurp(err);
  return r;
}

// The number of lines of a text: an error of the command line is exactly one.
inline int Lines(const std::string& s) {
  int n = 0;
  for (char c : s)
    n += c == '\n';
  return n;
}

}  // namespace ctcal::test
