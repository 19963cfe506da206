#!/usr/bin/env bash
# `make demo`: simulate the default rig (full scenario, 60 s, fixed seed, table4 guesses),
# calibrate it with the continuous-time calibrator and compare the result with the truth.
set -euo pipefail
build=${1:-build}
ctcal="$build/bin/ctcal"
work=${CTCAL_DEMO_DIR:-$(mktemp -d /tmp/ctcal_demo.XXXXXX)}
"$ctcal" simulate --scenario full --seed 2024 --duration 60 --perturb table4 --out "$work/data"
"$ctcal" calibrate --rig "$work/data/rig.yaml" --data "$work/data" --out "$work/out"
"$ctcal" compare --truth "$work/data/truth.yaml" --result "$work/out/result.yaml"
echo "demo files in $work"
