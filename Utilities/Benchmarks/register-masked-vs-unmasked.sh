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
  python3 - "$work/$mode/result.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
m = r["misalignment"]
print("status:", r["status"], [f["code"] for f in r["failures"]])
print("misalignment: t", ["%.3f" % t for t in m["translation_mm"]], "mm, pitch/roll/yaw",
      ["%.3f" % m["rotation_deg"][a] for a in ("pitch", "roll", "yaw")], "degrees")
print("mask valid fraction:", {v: round(r["mask_valid_fraction"][v], 3) for v in r["views"]})
print("DRRs:", r["drr_count"], "evaluations:", r["evaluations"])
print("timing (s):", {k: round(v, 2) for k, v in r["timing_s"].items()})
print("stages:", [(s["name"], s["first_evaluation"], round(s["seconds"], 2)) for s in r["convergence"]["stages"]])
PY
done
echo "== truth: misalignment $pose (mm, degrees)"
timing() { python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["timing_s"][sys.argv[2]])' "$work/$1/result.json" "$2"; }
echo "fine-alignment time unmasked / masked: $(echo "$(timing unmasked fine) / $(timing masked fine)" | bc -l | cut -c1-5)"
echo "whole registration time unmasked / masked: $(echo "$(timing unmasked total) / $(timing masked total)" | bc -l | cut -c1-5)"
