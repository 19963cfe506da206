#!/usr/bin/env bash
# The main job of `make demo`. Until the calibrator lands, the demo shows what exists: a spline
# fitted to an analytic trajectory with its derivatives checked against the analytic ones.
set -euo pipefail
build=${1:-build}
"$build/bin/spline_demo"
