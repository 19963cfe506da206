// The small JSON writers the subcommands' `--json` outputs share (compare, crossval): a quoted,
// escaped string and a number that is `null` when not finite (JSON has no inf / nan).
#pragma once

#include <optional>
#include <string>

namespace ctcal {

std::string JsonString(const std::string& s);
std::string JsonNumber(double x);
std::string JsonNumber(const std::optional<double>& x);

}  // namespace ctcal
