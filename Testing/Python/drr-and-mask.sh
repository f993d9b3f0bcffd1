#!/usr/bin/env bash
# Usage: drr-and-mask.sh XPOSE PYTHON SOURCE_DIR WORK_DIR
# Examples/Python/drr_and_mask.py on the phantom: both PNGs written, the DRR of the panel's size,
# a mask that keeps part of the image (neither nothing nor everything).
set -euo pipefail
xpose=$1 python=$2 source=$3 work=$4
rm -rf "$work" && mkdir -p "$work"
"$xpose" phantom --out "$work/ct" --spacing 3 >/dev/null
line=$("$python" "$source/Examples/Python/drr_and_mask.py" --ct "$work/ct" \
  --geometry "$source/Data/geometry/stereo-oblique-90.json" --view 1 --pose 2,0,0,0,0,1 --out-dir "$work/out")
echo "$line"
test -s "$work/out/drr.png" && test -s "$work/out/mask.png"
"$python" - "$line" <<'PY'
import re, sys
m = re.match(r"DRR (\d+)x(\d+), H\(X\) ([\d.]+), valid fraction ([\d.]+)", sys.argv[1])
ok = m and m.group(1, 2) == ("1024", "768") and 0.0 < float(m.group(3)) and 0.05 < float(m.group(4)) < 0.95
sys.exit(0 if ok else 1)
PY
