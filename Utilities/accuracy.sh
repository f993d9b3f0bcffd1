#!/usr/bin/env bash
# Accuracy of approach B on X-rays that xpose's DRR model did not make (the clinical scenario of
# the physics simulator): the acceptance runs and the ablation table of Documentation/results.md.
# Usage: bash Utilities/accuracy.sh [acceptance|ablation|all] [TRIALS_PER_ABLATION_ROW]
# Needs build/bin/xpose and ../shared/data/ct/vhm-pelvis; writes under eval/ (ignored by git).
set -euo pipefail
cd "$(dirname "$0")/.."
what=${1:-all}
rowTrials=${2:-10}
xpose=build/bin/xpose
pelvis=../shared/data/ct/vhm-pelvis
geometry=Data/geometry/stereo-oblique-90.json
mkdir -p eval

# One evaluate run; prints its summary row: success, median and largest-ok mTRE, bias per axis, time.
run() { # NAME CT SIZE TRIALS MIN MAX SEED ARGS...
  local name=$1 ct=$2 size=$3 trials=$4 min=$5 max=$6 seed=$7
  shift 7
  local dir=eval/accuracy-$name
  rm -rf "$dir" # a fresh run: evaluate would resume from an earlier run's trials
  "$xpose" evaluate --ct "$ct" --geometry "$geometry" --size "$size" --scenario clinical --approaches B \
    --trials "$trials" --min-translation "$min" --max-translation "$max" --seed "$seed" "$@" --out-dir "$dir" > "$dir.log"
  local summary bias
  summary=$(grep '^| B: entropy masks' "$dir.log" | head -1)
  bias=$(grep '^| B |' "$dir.log" | head -1)
  awk -F'|' -v name="$name" -v s="$summary" -v b="$bias" 'BEGIN {
    split(s, a, "|"); split(b, c, "|");
    gsub(/^ +| +$/, "", a[4]); gsub(/^ +| +$/, "", a[5]);
    printf "| %s | %s | %s | %s | %s | %s | %s | %s |%s |\n", name, a[3], (a[4] == "-" ? a[5] : a[4]), a[6], c[3], c[4], c[6], c[7], a[10] }'
}

header() {
  echo "| run | trials | success | median mTRE (mm) | median signed error tx ty tz (mm) | pitch roll yaw (deg) | ok beyond 2 mm | largest ok mTRE (mm) | median time (s) |"
  echo "|---|---|---|---|---|---|---|---|---|"
}

if [ "$what" = acceptance ] || [ "$what" = all ]; then
  [ -d eval/phantom-ct-2mm ] || "$xpose" phantom --out eval/phantom-ct-2mm --spacing 2 > /dev/null
  header
  run pelvis-0-20mm "$pelvis" 512x384 50 1 20 1
  run pelvis-20-30mm "$pelvis" 512x384 30 20 30 2
  run phantom-0-20mm eval/phantom-ct-2mm 256x192 50 1 20 1
  run phantom-20-30mm eval/phantom-ct-2mm 256x192 30 20 30 2
fi

if [ "$what" = ablation ] || [ "$what" = all ]; then
  echo
  header
  run all-effects "$pelvis" 512x384 "$rowTrials" 1 20 3
  for effect in spectrum pixel-area table couch scatter blur quantum-noise electronic-noise heel log truncation; do
    run "without-$effect" "$pelvis" 512x384 "$rowTrials" 1 20 3 --without "$effect"
  done
  # Scatter's fall-off where the body ends at the CT's end slices: the two effects together.
  run "without-truncation,scatter" "$pelvis" 512x384 "$rowTrials" 1 20 3 --without truncation scatter
  run "registration-keep-table" "$pelvis" 512x384 "$rowTrials" 1 20 3 --keep-table
  for step in levels high-pass coverage levels,high-pass,coverage; do
    run "registration-without-$step" "$pelvis" 512x384 "$rowTrials" 1 20 3 --registration-off "$step"
  done
fi
