#!/usr/bin/env bash
# Usage: register-matches-command.sh XPOSE PYTHON SOURCE_DIR WORK_DIR
# Simulated phantom X-rays registered by `xpose register` and by Examples/Python/register.py:
# both must report the same misalignment and correction to 1e-6, and the same status.
set -euo pipefail
xpose=$1 python=$2 source=$3 work=$4
geometry=$source/Data/geometry/stereo-oblique-90.json
rm -rf "$work" && mkdir -p "$work"
"$xpose" phantom --out "$work/ct" --spacing 2 >/dev/null
"$xpose" simulate --ct "$work/ct" --geometry "$geometry" --pose 3,-2,1,1,-1,1.5 --noise 20 --kv-contrast \
  --out-dir "$work/xray" >/dev/null
"$xpose" register --ct "$work/ct" --geometry "$geometry" --xray "$work/xray/xray_A.png" --xray "$work/xray/xray_B.png" \
  --size 256x192 --out-dir "$work/command" >/dev/null
"$python" "$source/Examples/Python/register.py" --ct "$work/ct" --geometry "$geometry" \
  --xray "$work/xray/xray_A.png" --xray "$work/xray/xray_B.png" --size 256x192 >"$work/python.json"
"$python" - "$work/command/result.json" "$work/python.json" <<'PY'
import json, sys
command, python = (json.load(open(path)) for path in sys.argv[1:3])
def numbers(pose):
    return pose["translation_mm"] + [pose["rotation_deg"][a] for a in ("pitch", "roll", "yaw")]
worst = max(abs(a - b) for key in ("misalignment", "correction")
            for a, b in zip(numbers(command[key]), numbers(python[key])))
print("status", command["status"], python["status"], "largest difference", worst)
print("misalignment", numbers(python["misalignment"]))
sys.exit(0 if command["status"] == python["status"] == "ok" and worst <= 1e-6 else 1)
PY
