#!/usr/bin/env bash
# Usage: drr-and-mask.sh XPOSE PYTHON SOURCE_DIR WORK_DIR
# Examples/Python/drr_and_mask.py on the phantom: the three PNGs written, the DRR of the panel's
# size, a mask that keeps part of the image (neither nothing nor everything), and the metric over
# the mask's pixels: a positive MI and a correlation short of 1 between DRRs 2 mm and 1 degree
# apart, and less MI than the DRR shares with itself (--pose 0,0,0,0,0,0).
set -euo pipefail
xpose=$1 python=$2 source=$3 work=$4
rm -rf "$work" && mkdir -p "$work"
"$xpose" phantom --out "$work/ct" --spacing 3 >/dev/null
line=$("$python" "$source/Examples/Python/drr_and_mask.py" --ct "$work/ct" \
  --geometry "$source/Data/geometry/stereo-oblique-90.json" --view 1 --pose 2,0,0,0,0,1 --out-dir "$work/out")
echo "$line"
test -s "$work/out/drr.png" && test -s "$work/out/mask.png" && test -s "$work/out/overlay.png"
same=$("$python" "$source/Examples/Python/drr_and_mask.py" --ct "$work/ct" \
  --geometry "$source/Data/geometry/stereo-oblique-90.json" --view 1 --pose 0,0,0,0,0,0 --out-dir "$work/same")
echo "$same"
"$python" - "$line" "$same" <<'PY'
import re, sys
pattern = (r"DRR (\d+)x(\d+), H\(X\) ([\d.]+), valid fraction ([\d.]+), MI with the planned pose's DRR ([\d.]+) "
           r"\(NCC ([-\d.]+)\) over (\d+) pixels")
m, same = (re.match(pattern, line) for line in sys.argv[1:3])
ok = (m and same and m.group(1, 2) == ("1024", "768") and 0.0 < float(m.group(3)) and 0.05 < float(m.group(4)) < 0.95
      and 0.0 < float(m.group(5)) < float(same.group(5)) and float(m.group(6)) < 0.999 and float(same.group(6)) > 0.999
      and int(m.group(7)) > 0)
sys.exit(0 if ok else 1)
PY
