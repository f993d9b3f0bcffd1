#!/usr/bin/env bash
# What a user waits for: the wall time of whole `xpose register` processes (CT read included) on
# X-rays that `xpose simulate` writes at the geometry's full panel, as a user's files come,
# registered at --size. Per pose: the process's wall time, the verdict, the error against the
# truth (translation mm, largest angle), the evaluations, each view's kept fraction and
# result.json's timing_s; then the median and the largest wall time.
# Usage: register-wall.sh CT GEOMETRY [SIZE [PRESET [REGISTER_OPTIONS...]]]
#   (XPOSE=path/to/xpose; default build/bin/xpose; SIZE 512x384; PRESET clinical)
set -euo pipefail
ct=$1 geometry=$2 size=${3:-512x384} preset=${4:-clinical}
shift $(($# < 4 ? $# : 4))
xpose=${XPOSE:-build/bin/xpose}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# Five fixed misalignments, 3-16 mm and up to 3 degrees, in room terms (mm, degrees).
poses="4,-3,2,1,-1,2 -8,5,-10,-2,3,1 12,-6,4,2,2,-3 -3,9,6,-1,-2,-1 6,2,-14,3,1,2"
for pose in $poses; do
  dir="$work/$pose"
  "$xpose" simulate --ct "$ct" --geometry "$geometry" --pose "$pose" --preset "$preset" --out-dir "$dir/sim" > "$dir.sim.log" 2>&1
  start=$(date +%s%N)
  "$xpose" register --ct "$ct" --geometry "$geometry" --xray "$dir/sim/xray_A.png" --xray "$dir/sim/xray_B.png" \
    --size "$size" "$@" --out-dir "$dir/reg" > "$dir.log" 2>&1 || true
  end=$(date +%s%N)
  echo "$pose $(((end - start) / 1000000))" >> "$work/walls.txt"
done
python3 - "$work" <<'PY'
import json, math, sys
work = sys.argv[1]
walls = []
print("| pose (mm, deg) | wall (s) | status | translation error (mm) | largest angle error (deg) | evaluations | kept A / B | timing_s: prealign, fine, total |")
print("|---|---|---|---|---|---|---|---|")
for line in open(f"{work}/walls.txt"):
    pose, ms = line.split()
    wall = int(ms) / 1000.0
    walls.append(wall)
    try:
        r = json.load(open(f"{work}/{pose}/reg/result.json"))
    except OSError:
        print(f"| {pose} | {wall:.2f} | no result (see the log) | | | | | |")
        continue
    truth = json.load(open(f"{work}/{pose}/sim/truth.json"))["misalignment"]
    found = r["misalignment"]
    dt = math.dist(found["translation_mm"], truth["translation_mm"])
    da = max(abs(found["rotation_deg"][k] - truth["rotation_deg"][k]) for k in ("pitch", "roll", "yaw"))
    t = r["timing_s"]
    kept = r["mask_valid_fraction"]
    print(f"| {pose} | {wall:.2f} | {r['status']} | {dt:.3f} | {da:.3f} | {r['evaluations']} | "
          f"{kept['A']:.2f} / {kept['B']:.2f} | {t['prealign']:.2f}, {t['fine']:.2f}, {t['total']:.2f} |")
walls.sort()
print(f"median wall {walls[len(walls) // 2]:.2f} s, largest {walls[-1]:.2f} s over {len(walls)} registrations")
PY
