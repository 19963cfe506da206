// Shared plumbing of the `ctcal` subcommands (SPEC section 8): Boost.Program_options parsing,
// `--help`, and the exit-code / one-line-error convention of apps/commands.h:
//   0  success (and `--help`),
//   1  a run that failed (solver diverged, I/O error while writing results, ...),
//   2  bad usage or bad input, with exactly ONE line on stderr: `ctcal <cmd>: error: <what>`.
//
// A subcommand looks like:
//   int RunFoo(int argc, char** argv) {
//     namespace po = boost::program_options;
//     CommandLine cli("foo", "--in FILE [--n N]", "what foo does, one sentence");
//     std::string in;
//     cli.options().add_options()
//         ("in", po::value(&in)->required(), "input file")
//         ("n", po::value<int>()->default_value(3), "how many");
//     if (const auto exit_code = cli.Parse(argc, argv)) return *exit_code;
//     try { ... } catch (const std::exception& e) { return cli.InputError(e.what()); }
//   }
#pragma once

#include <boost/program_options.hpp>
#include <cstdio>
#include <optional>
#include <sstream>
#include <string>
#include <utility>

namespace ctcal::app {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailed = 1;
inline constexpr int kExitBadInput = 2;

class CommandLine {
 public:
  // `command` is the subcommand's name, `synopsis` its arguments as SPEC section 8 writes them,
  // `summary` one sentence for the help text.
  CommandLine(std::string command, std::string synopsis, std::string summary)
      : command_(std::move(command)),
        synopsis_(std::move(synopsis)),
        summary_(std::move(summary)),
        options_("options") {
    options_.add_options()("help,h", "print this help and exit");
  }

  boost::program_options::options_description& options() { return options_; }
  boost::program_options::positional_options_description& positional() { return positional_; }
  const boost::program_options::variables_map& vm() const { return vm_; }
  const std::string& command() const { return command_; }

  // Parses argv (argv[0] is the subcommand name). Returns an exit code when the command must stop
  // now: 0 after printing --help, 2 after printing one line for bad usage. std::nullopt: go on.
  // Positional arguments are rejected unless the command declared them in positional() (SPEC
  // section 8 names every argument but crossval's two result files).
  std::optional<int> Parse(int argc, char** argv) {
    namespace po = boost::program_options;
    try {
      po::store(po::command_line_parser(argc, argv)  // skips argv[0], the name
                    .options(options_)
                    .positional(positional_)
                    .style(po::command_line_style::default_style &
                           ~po::command_line_style::allow_guessing)
                    .run(),
                vm_);
      // --help wins over missing required options, so it is checked before notify().
      if (vm_.count("help")) {
        PrintHelp(stdout);
        return kExitOk;
      }
      po::notify(vm_);
    } catch (const po::error& e) {
      return UsageError(std::string(e.what()) + " (ctcal " + command_ + " --help)");
    }
    return std::nullopt;
  }

  void PrintHelp(std::FILE* out) const {
    std::fprintf(out, "usage: ctcal %s %s\n\n%s\n\n", command_.c_str(), synopsis_.c_str(),
                 summary_.c_str());
    std::ostringstream text;
    text << options_;
    std::fprintf(out, "%s", text.str().c_str());
  }

  // Bad usage (an option missing or malformed). Prints one line, returns 2.
  int UsageError(const std::string& what) const { return Error(what, kExitBadInput); }
  // Bad input (a file that does not follow SPEC, an unknown name). Prints one line, returns 2.
  int InputError(const std::string& what) const { return Error(what, kExitBadInput); }
  // A run that could not complete on valid input. Prints one line, returns 1.
  int RunFailed(const std::string& what) const { return Error(what, kExitFailed); }

 private:
  int Error(const std::string& what, int code) const {
    // One line: a message spanning lines (e.g. a nested exception) is flattened.
    std::string line = what;
    for (char& c : line) {
      if (c == '\n' || c == '\r')
        c = ' ';
    }
    std::fprintf(stderr, "ctcal %s: error: %s\n", command_.c_str(), line.c_str());
    return code;
  }

  std::string command_;
  std::string synopsis_;
  std::string summary_;
  boost::program_options::options_description options_;
  boost::program_options::positional_options_description positional_;
  boost::program_options::variables_map vm_;
};

}  // namespace ctcal::app
