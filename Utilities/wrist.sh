#!/usr/bin/env bash
# The real biplane wrist set (../shared/data/real-biplane-wrist): for each bone and frame, the
# pose found from nothing (global search), then registrations from STARTS seeded starts within
# 5 mm and 5 degrees of it (each parameter uniform in +-5), and per bone and frame: how many end
# ok, the spread (max - min) per axis of the ok ends, and, over all ends whatever their status,
# how many lie within 0.5 mm of the ends' median translation, and how many within 0.5 mm and
# 0.5 degrees of the median pose (how consistent the optimum is, before the gate's word).
# Usage: bash Utilities/wrist.sh [STARTS] [BONES] [FRAMES]   (defaults: 20, "mc3 rad uln", "0002 0158")
# Needs build/bin/xpose; writes under eval/wrist (ignored by git).
set -euo pipefail
cd "$(dirname "$0")/.."
starts=${1:-20}
bones=${2:-mc3 rad uln}
frames=${3:-0002 0158}
xpose=${XPOSE:-build/bin/xpose}
W=../shared/data/real-biplane-wrist
[ -d "$W" ] || { echo "skipped: $W is absent"; exit 0; }
out=eval/wrist
mkdir -p "$out"
"$xpose" geometry --camera-calibration "$W/xr_calib_wrist_cam01.txt" "$W/xr_calib_wrist_cam02.txt" --pixel-spacing 0.2 \
  --out "$out/wrist.json" | head -1
echo "| bone | frame | found from nothing | status | DRR edges to the X-ray's, A / B (moved 3 mm) (mm) | starts ok | spread of ok ends tx ty tz (mm) | pitch roll yaw (deg) | ends near the median: translation / pose | median time (s) |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for bone in $bones; do
  for frame in $frames; do
    common=(--ct "$W/${bone}_dcm_cropped.tif" --voxel-size 0.39625,0.39625,0.625 --geometry "$out/wrist.json"
      --xray "$W/xr_rad_uln_cam01_UND.$frame.tif" --xray "$W/xr_rad_uln_cam02_UND.$frame.tif" --size 440x440)
    dir=$out/$bone-$frame
    rm -rf "$dir" "$dir.times" "$dir.all"
    "$xpose" register "${common[@]}" --out-dir "$dir/found" --report "$dir/found/report" > "$dir.log" 2>&1 || true
    found=$(grep '^misalignment:' "$dir.log" | sed 's/misalignment: t = (\(.*\)) mm, pitch \(.*\), roll \(.*\), yaw \(.*\) deg/\1,\2,\3,\4/; s/ //g')
    status=$(grep '^status:' "$dir.log" | awk '{print $2}')
    # "edges, view A: the DRR's lie 1.31 mm from the X-ray's (1.46 mm with the DRR moved 3 mm)"
    edges=$(grep '^edges, view' "$dir.log" | sed "s/.*lie \([0-9.-]*\) mm.*(\([0-9.-]*\) mm.*/\1 (\2)/" | paste -sd/ | sed 's#/# / #g')
    : > "$dir.ends"
    for ((s = 1; s <= starts; s++)); do
      start=$(awk -v seed="$s" -v p="$found" 'BEGIN { srand(seed); n = split(p, v, ",");
        for (i = 1; i <= n; i++) printf "%s%.4f", (i > 1 ? "," : ""), v[i] + 10 * (rand() - 0.5) }')
      ok=0
      "$xpose" register "${common[@]}" --initial-pose="$start" --out-dir "$dir/start-$s" > "$dir/start-$s.log" 2>&1 || ok=$?
      end=$(grep '^misalignment:' "$dir/start-$s.log" | sed 's/misalignment: t = (\(.*\)) mm, pitch \(.*\), roll \(.*\), yaw \(.*\) deg/\1,\2,\3,\4/; s/ //g' || true)
      if [ -n "$end" ]; then
        echo "$end" >> "$dir.all"
        if [ "$ok" = 0 ]; then echo "$end" >> "$dir.ends"; fi
      fi
      grep -o 'total [0-9.]* s' "$dir/start-$s.log" | awk '{print $2}' >> "$dir.times" || true
    done
    awk -F, -v bone="$bone" -v frame="$frame" -v found="$found" -v status="$status" -v edges="$edges" -v starts="$starts" '
      { n++; for (i = 1; i <= 6; i++) { if (n == 1 || $i < lo[i]) lo[i] = $i; if (n == 1 || $i > hi[i]) hi[i] = $i } }
      END { printf "| %s | %s | %s | %s | %s | %d/%d | ", bone, frame, found, status, edges, n, starts
        if (n) printf "%.2f %.2f %.2f | %.2f %.2f %.2f |", hi[1]-lo[1], hi[2]-lo[2], hi[3]-lo[3], hi[4]-lo[4], hi[5]-lo[5], hi[6]-lo[6]
        else printf "- | - |" }' "$dir.ends"
    touch "$dir.all"
    for i in 1 2 3 4 5 6; do cut -d, -f$i "$dir.all" | sort -g | awk '{ v[NR] = $1 } END { printf "%s%s", (NR ? v[int((NR + 1) / 2)] : 0), "\n" }'; done |
      paste -sd, > "$dir.median"
    awk -F, -v starts="$starts" 'NR == FNR { split($0, m, ","); next }
      { t = 1; p = 1; for (i = 1; i <= 6; i++) { d = $i - m[i]; d = d < 0 ? -d : d; if (d > 0.5) { p = 0; if (i <= 3) t = 0 } }
        nt += t; np += p }
      END { printf " %d/%d / %d/%d |", nt, starts, np, starts }' "$dir.median" "$dir.all"
    sort -n "$dir.times" | awk '{ t[NR] = $1 } END { printf " %.1f |\n", NR ? t[int((NR + 1) / 2)] : 0 }'
  done
done
# The radius and the ulna as found from nothing in each frame: the ulna's pose in the radius's
# coordinates, whose change between frames a reader can judge (the two bones turn about each
# other in pronation, and neither shortens).
if [[ " $bones " == *" rad "* && " $bones " == *" uln "* ]]; then
  reference=() moving=()
  for frame in $frames; do
    reference+=("$out/rad-$frame/found/result.json")
    moving+=("$out/uln-$frame/found/result.json")
  done
  echo
  "$xpose" relative --reference "${reference[@]}" --moving "${moving[@]}" || true
fi
