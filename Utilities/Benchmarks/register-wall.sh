#!/usr/bin/env bash
# What a user waits for: the wall time of whole `xpose register` processes (CT read included) on
# X-rays that `xpose simulate` writes at the geometry's full panel, as a user's files come,
# registered at SIZE. Per pose and build: the process's wall time, the verdict, the error
# against the truth (translation mm, largest angle), the evaluations and result.json's
# timing_s; then each build's median and largest wall time, and with two builds the ratio of
# their medians, measured in this one run (the builds take turns on each pose).
# Usage: register-wall.sh CT GEOMETRY [SIZE [PRESET [REGISTER_OPTIONS...]]]
#   one build: XPOSE=path/to/xpose (default build/bin/xpose);
#   builds compared: BUILDS="OLD_DIR NEW_DIR" (each holding bin/xpose and lib/; the X-rays are
#   made by the last one); an entry DIR:OPTION[,OPTION...] adds its own register options (CLI11's
#   --name=value form), so that one build's two settings take turns: BUILDS="build:--x=false
#   build:--x=true". SIZE 512x384, PRESET clinical by default.
# PRESET plastimatch[:DETECTOR]: X-rays from a renderer outside the project instead, `plastimatch
#   drr` through `xpose evaluate --scenario plastimatch --write-xrays` at SIZE (DETECTOR linear12
#   by default), at TRIALS misalignments (10 by default) drawn with SEED (1) as evaluate draws
#   them (up to 30 mm and 5 degrees per angle by default; POSES does not apply); each pose is a
#   trial's truth, rounded in the table's first column. Needs plastimatch (apt-get install
#   plastimatch).
set -euo pipefail
ct=$1 geometry=$2 size=${3:-512x384} preset=${4:-clinical}
shift $(($# < 4 ? $# : 4))
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
run() { # BUILD_DIR_OR_EMPTY ARGS...: xpose from a build folder, or $XPOSE
  local dir=${1%%:*}
  shift
  if [ -n "$dir" ]; then LD_LIBRARY_PATH="$dir/lib" "$dir/bin/xpose" "$@"; else "${XPOSE:-build/bin/xpose}" "$@"; fi
}
builds=(${BUILDS:-""})
# Five fixed misalignments, 5-16 mm and up to 3 degrees, in room terms (mm, degrees); POSES overrides.
poses=${POSES:-"4,-3,2,1,-1,2 -8,5,-10,-2,3,1 12,-6,4,2,2,-3 -3,9,6,-1,-2,-1 6,2,-14,3,1,2"}
if [[ $preset == plastimatch* ]]; then
  detector=linear12
  [[ $preset == plastimatch:* ]] && detector=${preset#plastimatch:}
  run "${builds[-1]}" evaluate --ct "$ct" --geometry "$geometry" --approaches B --trials "${TRIALS:-10}" --seed "${SEED:-1}" \
    --size "$size" --scenario plastimatch --detector "$detector" --write-xrays --out-dir "$work/pm" > "$work/pm.log" 2>&1 ||
    { echo "register-wall.sh: xpose evaluate could not make the plastimatch X-rays:" >&2; tail -5 "$work/pm.log" >&2; exit 1; }
  geometry=$work/pm/xrays/geometry.json
  # One folder per trial, named by its pose, as `xpose simulate` would write it.
  poses=$(python3 - "$work" <<'PY'
import csv, json, os, shutil, sys
work = sys.argv[1]
for row in csv.DictReader(open(f"{work}/pm/trials.csv")):
    t = [float(row[f"initial_{k}"]) for k in ("tx", "ty", "tz")]
    r = {k: float(row[f"initial_{k}"]) for k in ("pitch", "roll", "yaw")}
    pose = ",".join(f"{v:.1f}" for v in t + list(r.values()))
    os.makedirs(f"{work}/{pose}/sim")
    for view in "AB":
        shutil.copy(f"{work}/pm/xrays/trial_{row['trial']}_{view}.png", f"{work}/{pose}/sim/xray_{view}.png")
    json.dump({"misalignment": {"translation_mm": t, "rotation_deg": r}}, open(f"{work}/{pose}/sim/truth.json", "w"))
    print(pose)
PY
)
fi
for pose in $poses; do
  dir="$work/$pose"
  [ -d "$dir/sim" ] ||
    run "${builds[-1]}" simulate --ct "$ct" --geometry "$geometry" --pose "$pose" --preset "$preset" --out-dir "$dir/sim" > "$dir.sim.log" 2>&1
  for b in "${!builds[@]}"; do
    start=$(date +%s%N)
    entry=${builds[$b]} own=()
    [[ $entry == *:* ]] && IFS=, read -r -a own <<< "${entry#*:}"
    run "$entry" register --ct "$ct" --geometry "$geometry" --xray "$dir/sim/xray_A.png" --xray "$dir/sim/xray_B.png" \
      --size "$size" "$@" "${own[@]}" --out-dir "$dir/reg-$b" > "$dir.$b.log" 2>&1 || true
    end=$(date +%s%N)
    echo "$pose $b $(((end - start) / 1000000))" >> "$work/walls.txt"
  done
done
python3 - "$work" "${BUILDS:-${XPOSE:-build/bin/xpose}}" <<'PY'
import json, math, sys
work, names = sys.argv[1], sys.argv[2].split()
walls = {}
print("| pose (mm, deg) | build | wall (s) | status | translation error (mm) | largest angle error (deg) | evaluations | timing_s: read, prealign, fine, total |")
print("|---|---|---|---|---|---|---|---|")
for line in open(f"{work}/walls.txt"):
    pose, b, ms = line.split()
    wall = int(ms) / 1000.0
    name = names[int(b)]
    walls.setdefault(name, []).append(wall)
    try:
        r = json.load(open(f"{work}/{pose}/reg-{b}/result.json"))
    except OSError:
        print(f"| {pose} | {name} | {wall:.2f} | no result (see the log) | | | | |")
        continue
    truth = json.load(open(f"{work}/{pose}/sim/truth.json"))["misalignment"]
    found = r["misalignment"]
    dt = math.dist(found["translation_mm"], truth["translation_mm"])
    da = max(abs(found["rotation_deg"][k] - truth["rotation_deg"][k]) for k in ("pitch", "roll", "yaw"))
    t = r["timing_s"]
    print(f"| {pose} | {name} | {wall:.2f} | {r['status']} | {dt:.3f} | {da:.3f} | {r['evaluations']} | "
          f"{t.get('read', 0):.2f}, {t.get('prealign', 0):.2f}, {t.get('fine', 0):.2f}, {t.get('total', 0):.2f} |")
medians = {}
for name, w in walls.items():
    w.sort()
    medians[name] = w[len(w) // 2]
    print(f"{name}: median wall {medians[name]:.2f} s, largest {w[-1]:.2f} s over {len(w)} registrations")
if len(names) == 2:
    print(f"median {names[1]} / {names[0]}: {medians[names[1]] / medians[names[0]]:.2f}")
PY
