#!/usr/bin/env bash
# The cost of calibrate's cross-validation on `make demo`'s rig (issue 20: at most 2x the plain
# run): the demo's data simulated once, then calibrated N times with and N times without
# cross-validation, alternating; prints each run's wall and CPU seconds and the medians' ratios.
# Usage: scripts/crossval_cost.sh [BUILD_DIR] [N]
set -euo pipefail
build=${1:-build}
n=${2:-3}
ctcal="$build/bin/ctcal"
work=${CTCAL_COST_DIR:-$(mktemp -d /tmp/ctcal_xval_cost.XXXXXX)}
[ -f "$work/data/truth.yaml" ] ||
  "$ctcal" simulate --scenario full --seed 2024 --duration 60 --perturb table4 --out "$work/data" >/dev/null
: >"$work/times.txt"
for _ in $(seq 1 "$n"); do
  for mode in on off; do
    extra=(--no-cross-validate)
    [ "$mode" = on ] && extra=(--cross-validate)
    code=0
    /usr/bin/time -f "$mode %e %U %S" -a -o "$work/times.txt" "$ctcal" calibrate \
      --rig "$work/data/rig.yaml" --data "$work/data" --out "$work/out_$mode" "${extra[@]}" \
      >/dev/null 2>&1 || code=$?
    [ "$code" -le 0 ] || [ "$code" -eq 3 ] || { echo "calibrate ($mode) exited $code" >&2; exit 1; }
  done
done
python3 - "$work/times.txt" <<'PY'
import statistics, sys
rows = [l.split() for l in open(sys.argv[1]) if l.strip()]
med = {}
for mode in ("on", "off"):
    wall = [float(r[1]) for r in rows if r[0] == mode]
    cpu = [float(r[2]) + float(r[3]) for r in rows if r[0] == mode]
    med[mode] = (statistics.median(wall), statistics.median(cpu))
    print(f"{mode:3s} wall {wall} cpu {[round(c, 2) for c in cpu]}")
print(f"median ratio (cross-validated / plain): wall {med['on'][0] / med['off'][0]:.2f}, "
      f"cpu {med['on'][1] / med['off'][1]:.2f}")
PY
echo "files in $work"
