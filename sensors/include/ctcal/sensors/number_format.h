// How ctcal writes a double into its text files (YAML, CSV): the shortest decimal that reads back
// to the identical double, always with a '.' so that YAML 1.1 readers (PyYAML, hence Kalibr's
// tools) see a float and not an int or a string: 9.81 -> "9.81", 1 -> "1.0", 2e-05 -> "2.0e-05".
// Non-finite values are written as YAML writes them: .inf, -.inf, .nan.
#pragma once

#include <string>
#include <string_view>

namespace ctcal {

std::string FormatDouble(double x);
// FormatDouble written into [first, last), which holds at least kFormatDoubleChars; returns the
// end of what was written (the writers of large tables format without a string per number).
inline constexpr int kFormatDoubleChars = 32;
char* FormatDoubleTo(char* first, char* last, double x);

// Parses a whole string as a double: decimal or scientific notation, YAML's .inf / -.inf / .nan
// (any case), and inf / nan. Returns false (leaving *x untouched) for anything else, including
// trailing characters and an empty string.
bool ParseDouble(std::string_view s, double* x);

}  // namespace ctcal
