#!/usr/bin/env bash
# Builds ctcal with AddressSanitizer + UndefinedBehaviorSanitizer in its own folder and runs the
# GoogleTest executables under it, one process per executable (docs/sanitizers.md).
#
#   scripts/sanitize_tests.sh [build-dir] [executable-regex] [gtest-filter]
#
# build-dir defaults to build-asan; the regex picks executables by name (default: all of them,
# e.g. '^(spline|sensors)_' for a part); the filter is passed as --gtest_filter (default: all).
# Warnings are not errors here: GCC warns differently with the sanitizers (the normal build
# checks them). Assertions stay on (no NDEBUG): Eigen checks its indices. -O1 -g1 instead of
# RelWithDebInfo's -O2 -g: the Ceres autodiff files compile about 3x faster
# under AddressSanitizer and the reports still name file and line. Each executable's output goes
# to <build-dir>/sanitize-logs/<exe>.log; the summary lists the ones that failed.
set -uo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build-asan}
pick=${2:-.}
filter=${3:-*}
jobs=${CTCAL_SANITIZE_JOBS:-2}
limit=${CTCAL_SANITIZE_TIMEOUT:-3600}  # seconds per executable (exit code 124 when exceeded)

cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1" \
  -DCTCAL_SANITIZE=address,undefined -DCTCAL_BUILD_BENCH=OFF -DCTCAL_WERROR=OFF >/dev/null || exit 2

# Every test executable whose name matches, plus ctcal (the end-to-end tests run it).
targets=$(find "$root/tests" -mindepth 2 -maxdepth 2 -name 'test_*.cpp' | sort |
  sed -E 's|.*/tests/([a-z]+)/test_([a-z0-9_]+)\.cpp|\1_\2|' | grep -E -- "$pick")
[ -n "$targets" ] || { echo "no test executable matches '$pick'" >&2; exit 2; }
# shellcheck disable=SC2086
nice -n 10 cmake --build "$build" --target ctcal $targets -j"$jobs" || exit 2

# halt_on_error + UBSan's -fno-sanitize-recover=all: the first finding aborts its executable.
# detect_leaks: LeakSanitizer runs at exit; fontconfig's process-lifetime cache is suppressed.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:halt_on_error=1:detect_stack_use_after_return=1:strict_string_checks=1:check_initialization_order=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$root/scripts/lsan.supp}

logs="$build/sanitize-logs"
mkdir -p "$logs"
failed=()
for t in $targets; do
  start=$(date +%s)
  nice -n 10 timeout "$limit" "$build/tests/$t" --gtest_filter="$filter" >"$logs/$t.log" 2>&1
  rc=$?
  secs=$(($(date +%s) - start))
  summary=$(grep -E '^\[  (PASSED|FAILED|SKIPPED) ' "$logs/$t.log" | tr '\n' ' ')
  findings=$(grep -cE '^(==[0-9]+==ERROR|SUMMARY: (Address|UndefinedBehavior|Leak)Sanitizer)|runtime error:' \
    "$logs/$t.log")
  printf '%-45s rc=%-3s %4ss findings=%s %s\n' "$t" "$rc" "$secs" "$findings" "$summary"
  [ "$rc" -eq 0 ] && [ "$findings" -eq 0 ] || failed+=("$t")
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "failed or with findings (logs in $logs): ${failed[*]}"
  exit 1
fi
echo "all $(echo "$targets" | wc -w) executables passed with no sanitizer finding"
