#!/usr/bin/env bash
# Fails (listing the files) when any C++ source differs from its clang-format output.
set -uo pipefail
root=${1:-$(dirname "$0")/..}
cd "$root" || exit 2
files=$(find spline sensors targets calibrator report apps sim bench tests \
  \( -name '*.h' -o -name '*.hpp' -o -name '*.cpp' -o -name '*.cc' \) -not -path '*/data/*' 2>/dev/null | sort)
bad=0
for f in $files; do
  if ! clang-format --style=file --dry-run --Werror "$f" >/dev/null 2>&1; then
    echo "not clang-formatted: $f (run: make format)"
    bad=1
  fi
done
[ $bad -eq 0 ] && echo "all $(echo "$files" | wc -w) C++ files are clang-formatted"
exit $bad
