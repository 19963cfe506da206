#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/, one per reader) with Debian's clang-14 under AddressSanitizer
# and UndefinedBehaviorSanitizer in build-fuzz/, and runs each for SECONDS (default 600) from its
# seed corpus (fuzz/corpus/<target>/; what it finds goes to build-fuzz/corpus/<target>/, crashes
# to build-fuzz/findings/<target>/). Exit 1 when a target crashed, leaked or hung (> 10 s on one
# input). docs/fuzzing.md has the targets, the hours run and the findings.
#
#   scripts/fuzz.sh [SECONDS] [TARGET ...]     TARGET: csv rig_yaml kalibr ros1_bag ros2_bag image
#
# Needs clang-14, libclang-rt-14-dev (the sanitizers) and libfuzzer-14-dev (the -fsanitize=fuzzer
# runtime); the default build needs none of them.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
SECONDS_EACH=${1:-600}
shift || true
TARGETS=("$@")
[ ${#TARGETS[@]} -eq 0 ] && TARGETS=(csv rig_yaml kalibr ros1_bag ros2_bag image)
BUILD=${CTCAL_FUZZ_BUILD:-$ROOT/build-fuzz}

cmake -S "$ROOT" -B "$BUILD" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 \
  -DCTCAL_BUILD_FUZZ=ON -DCTCAL_BUILD_TESTS=OFF -DCTCAL_BUILD_BENCH=OFF -DCTCAL_WERROR=OFF \
  -DCTCAL_SANITIZE=address,undefined ${CTCAL_FUZZ_CMAKE_ARGS:-} >/dev/null
cmake --build "$BUILD" -j"${CTCAL_FUZZ_JOBS:-2}" --target "${TARGETS[@]/#/fuzz_}"

status=0
for t in "${TARGETS[@]}"; do
  corpus=$BUILD/corpus/$t
  findings=$BUILD/findings/$t
  mkdir -p "$corpus" "$findings"
  echo "[fuzz] $t: ${SECONDS_EACH} s"
  # -rss_limit_mb: a reader must not need more than 2 GB for an input of a few KB.
  if ! (cd "$findings" && "$BUILD/bin/fuzz_$t" -max_total_time="$SECONDS_EACH" -timeout=10 \
          -rss_limit_mb=2048 -max_len=65536 -print_final_stats=1 \
          "$corpus" "$ROOT/fuzz/corpus/$t" >"$BUILD/fuzz_$t.log" 2>&1); then
    echo "[fuzz] $t: FAILED (see $BUILD/fuzz_$t.log and $findings)"
    status=1
  fi
  grep -E "^stat::number_of_executed_units|^Done" "$BUILD/fuzz_$t.log" || true
done
exit $status
