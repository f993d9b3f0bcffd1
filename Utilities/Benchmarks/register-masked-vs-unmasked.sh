#!/usr/bin/env bash
# Simulates stereo X-rays of a known misalignment (noise, kV contrast, X-ray-only objects) and
# registers them with and without the entropy masks; prints errors, time per stage and the ratio.
# Usage: register-masked-vs-unmasked.sh [CT] [POSE] [SIZE]
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
ct=${1:-$root/../shared/data/ct/vhm-pelvis}
pose=${2:-8,-6,4,2,-2,3}
size=${3:-512x384}
xpose=${XPOSE:-$root/build/bin/xpose}
geometry=$root/Data/geometry/stereo-oblique-90.json
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

"$xpose" simulate --ct "$ct" --geometry "$geometry" --pose "$pose" --noise 30 --kv-contrast --add-objects \
  --out-dir "$work/xray" >/dev/null
for mode in masked unmasked; do
  flag=""; [ "$mode" = unmasked ] && flag="--no-entropy-mask"
  status=0
  "$xpose" register --ct "$ct" --geometry "$geometry" --xray "$work/xray/xray_A.png" --xray "$work/xray/xray_B.png" \
    --size "$size" $flag --out-dir "$work/$mode" >"$work/$mode.log" || status=$?
  echo "== $mode (exit $status)"
  grep -E '"status"|"misalignment"|"mask_valid_fraction"|"drr_count"|"evaluations"|"timing_s"' "$work/$mode/result.json"
  grep -o '"stages": \[[^]]*\]' "$work/$mode/result.json"
done
echo "== truth: misalignment $pose (mm, degrees)"
fine() { sed -n 's/.*"fine": \([0-9.]*\).*/\1/p' "$work/$1/result.json"; }
total() { sed -n 's/.*"total": \([0-9.]*\).*/\1/p' "$work/$1/result.json"; }
echo "fine-alignment time unmasked / masked: $(echo "$(fine unmasked) / $(fine masked)" | bc -l | cut -c1-5)"
echo "whole registration time unmasked / masked: $(echo "$(total unmasked) / $(total masked)" | bc -l | cut -c1-5)"
