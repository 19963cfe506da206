#!/usr/bin/env bash
# Formats every C++ source of the project in place with the repository's .clang-format.
set -euo pipefail
cd "$(dirname "$0")/.."
git ls-files --cached --others --exclude-standard -- '*.h' '*.hpp' '*.cpp' '*.cc' |
  xargs -r clang-format -i --style=file
