#!/usr/bin/env bash
# The robustness sweep of the coarse-guess initialisation (docs/initialisation.md): for each seed,
# simulate the `full` scenario with `--perturb coarse`, calibrate from that guess, calibrate the
# same data from the truth with `--init off`, and print one markdown row: the largest R_B_S error
# (deg), t_B_S error (mm), time-offset error (ms), focal error (px), the scalars within 3 sigma,
# the worst |error| / sigma, the largest difference between the two starts in sigmas (the
# initialisation succeeded when both starts reach the same minimum) and the CPU time (user + sys)
# of the coarse calibration.
#
#   scripts/init_sweep.sh BUILD OUT DURATION_S "SEEDS" [RIG.yaml]
#   scripts/init_sweep.sh build /tmp/sweep 12 "101 102 103"
#   scripts/init_sweep.sh build /tmp/sweep_hand 12 "201 202" configs/init_sweep_rig.yaml
set -euo pipefail
ctcal="$1/bin/ctcal"
out=$2
duration=$3
seeds=$4
rig_args=()
if [[ $# -ge 5 ]]; then
  rig_args=(--rig "$5")
fi
mkdir -p "$out"

# Reads `ctcal compare` output on stdin; prints "rot_deg trans_mm offset_ms focal_px within/n worst".
summarise() {
  awk '
    /angle of Log/ && $1 ~ /R_B_S/ { if ($(NF - 1) > rot) rot = $(NF - 1) }
    $1 ~ /\.t_B_S\[/ { s = $1; sub(/\[.*/, "", s); t[s] += $4 * $4 }
    $1 ~ /time_offset/ { e = $4 < 0 ? -$4 : $4; if (e > off) off = e }
    $1 ~ /intrinsics\[[01]\]/ { e = $4 < 0 ? -$4 : $4; if (e > foc) foc = e }
    NF == 6 && $6 ~ /^-?[0-9.]+$/ {
      n++; z = $6 < 0 ? -$6 : $6; if (z < 3) w++; if (z > worst) { worst = z; wn = $1 } }
    END {
      for (s in t) if (sqrt(t[s]) > tr) tr = sqrt(t[s])
      printf "%.3f %.2f %.3f %.2f %d/%d %.2f(%s)\n", rot, tr * 1e3, off * 1e3, foc, w, n, worst, wn
    }'
}

echo "| seed | R_B_S deg | t_B_S mm | offset ms | focal px | within 3 sigma | worst sigma | coarse vs truth start, sigma | CPU s |"
echo "|---|---|---|---|---|---|---|---|---|"
for seed in $seeds; do
  d="$out/data_$seed"
  [[ -f "$d/truth.yaml" ]] ||
    "$ctcal" simulate --scenario full --seed "$seed" --duration "$duration" --perturb coarse \
      "${rig_args[@]}" --out "$d" > "$out/simulate_$seed.log" 2>&1
  if ! /usr/bin/time -f "%U %S" -o "$out/time_$seed.txt" "$ctcal" calibrate --rig "$d/rig.yaml" \
    --data "$d" --out "$out/coarse_$seed" --threads 1 > "$out/coarse_$seed.log" 2>&1; then
    echo "| $seed | failed: $(tail -1 "$out/coarse_$seed.log") |"
    continue
  fi
  "$ctcal" calibrate --rig "$d/truth.yaml" --data "$d" --out "$out/truth_$seed" --init off \
    --threads 1 > "$out/truth_$seed.log" 2>&1
  read -r rot tr off foc within worst < <("$ctcal" compare --truth "$d/truth.yaml" \
    --result "$out/coarse_$seed/result.yaml" | summarise)
  read -r _ _ _ _ _ same < <("$ctcal" compare --truth "$out/truth_$seed/result.yaml" \
    --result "$out/coarse_$seed/result.yaml" | summarise)
  cpu=$(awk '{ printf "%.1f", $1 + $2 }' "$out/time_$seed.txt")
  echo "| $seed | $rot | $tr | $off | $foc | $within | $worst | $same | $cpu |"
done
