#!/usr/bin/env bash
# The GPU checks and figures in one run on a machine with an NVIDIA GPU and the CUDA toolkit but
# without xpose's Debian packages (README.md beside this file): the VTK-free harness built there
# and run on the analytic phantom and the pelvis, the GPU tests of xpose's own suite, registrations
# of the pelvis on both devices, and xpose's benchmarks on both.
# Usage: device-check.sh PACK_DIR OUT_DIR
#   PACK_DIR (pack-for-device.sh): bin/ (xpose, TestXPDRR, TestXPRegistration), lib/ (their
#   shared libraries but the C and C++ runtimes), eigen3/, pelvis.mhd and pelvis.raw.
set -uo pipefail
pack=$(cd "$1" && pwd) out=$2
cd "$(dirname "$0")/../.."
mkdir -p "$out"
export LD_LIBRARY_PATH="$pack/lib"
step() { echo; echo "=== $* ($(date +%T))"; }

step "machine"
nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv
nproc
lscpu | grep -m1 "Model name"

step "harness: build (cmake, nvcc) and run"
cmake -S Utilities/GPU -B /tmp/xpose-gpu-check -G Ninja -DEIGEN3_INCLUDE_DIR="$pack/eigen3" > /tmp/harness-configure.log 2>&1 \
  || { tail -20 /tmp/harness-configure.log; exit 1; }
cmake --build /tmp/xpose-gpu-check > /tmp/harness-build.log 2>&1 || { tail -30 /tmp/harness-build.log; exit 1; }
/tmp/xpose-gpu-check/xpose-gpu-check --ct "$pack/pelvis.mhd" 2>&1 | tee "$out/harness.txt"

step "harness under compute-sanitizer memcheck (analytic phantom, 128x96)"
if command -v compute-sanitizer > /dev/null; then
  timeout 300 compute-sanitizer --tool memcheck --error-exitcode 9 /tmp/xpose-gpu-check/xpose-gpu-check --size 128x96 \
    --repetitions 3 > /tmp/memcheck.log 2>&1
  echo "compute-sanitizer exit $? (9: memory errors found; 1: a harness check failed, its time limit included, which the sanitizer's slowdown misses)"
  grep -E "ERROR SUMMARY|Invalid|FAIL" /tmp/memcheck.log | head -5
else
  echo "compute-sanitizer: not on this machine"
fi

step "xpose's GPU tests"
"$pack/bin/TestXPDRR" --gtest_filter='CudaRayCaster.*' 2>&1 | tail -12
"$pack/bin/TestXPRegistration" --gtest_filter='*OnGPU*' 2>&1 | tail -12

step "the README's phantom registered on both devices"
"$pack/bin/xpose" phantom --out /tmp/demo/ct > /dev/null
"$pack/bin/xpose" simulate --ct /tmp/demo/ct --geometry Data/geometry/stereo-oblique-90.json --pose 5,-3,2,1,-1,2 --noise 30 \
  --kv-contrast --out-dir /tmp/demo/xray > /dev/null
for device in cpu cuda; do
  "$pack/bin/xpose" register --ct /tmp/demo/ct --geometry Data/geometry/stereo-oblique-90.json --xray /tmp/demo/xray/xray_A.png \
    --xray /tmp/demo/xray/xray_B.png --size 512x384 --device $device --out-dir /tmp/demo/$device 2>&1 | grep -E "^device|^status|^misalignment|^DRRs"
done

step "registrations of the pelvis on both devices (simulate's clinical X-rays, 512x384)"
geometry=Data/geometry/stereo-oblique-90.json
for pose in 4,-3,2,1,-1,2 -8,5,-10,-2,3,1 12,-6,4,2,2,-3; do
  dir=/tmp/reg/$pose
  "$pack/bin/xpose" simulate --ct "$pack/pelvis.mhd" --geometry $geometry --pose "$pose" --preset clinical --out-dir "$dir/sim" > /dev/null
  for device in cpu cuda; do
    start=$(date +%s%N)
    "$pack/bin/xpose" register --ct "$pack/pelvis.mhd" --geometry $geometry --xray "$dir/sim/xray_A.png" --xray "$dir/sim/xray_B.png" \
      --size 512x384 --device $device --out-dir "$dir/$device" > "$dir/$device.log" 2>&1
    echo "$pose $device wall $(( ($(date +%s%N) - start) / 1000000 )) ms: $(grep -h '^status\|^DRRs' "$dir/$device.log" | tr '\n' ' ')"
  done
  python3 - "$dir" "$pose" <<'PY'
import json, sys
d, pose = sys.argv[1], sys.argv[2]
c, g = (json.load(open(f"{d}/{x}/result.json")) for x in ("cpu", "cuda"))
m = lambda r: r["misalignment"]["translation_mm"] + [r["misalignment"]["rotation_deg"][k] for k in ("pitch", "roll", "yaw")]
a, b = m(c), m(g)
print(f"  {pose}: cpu {c['status']} {[round(x, 3) for x in a]}, cuda {g['status']} {[round(x, 3) for x in b]} ({g.get('device')}); "
      f"apart {sum((a[i] - b[i]) ** 2 for i in range(3)) ** 0.5:.4f} mm, {max(abs(a[i] - b[i]) for i in range(3, 6)):.4f} deg; "
      f"timing cpu {c['timing_s']['total']:.2f} s, cuda {g['timing_s']['total']:.2f} s")
PY
done 2>&1 | tee "$out/registrations.txt"

step "xpose drr on both devices (pelvis, 512x384, the filter's bottom-row-first grid)"
for device in cpu cuda; do
  "$pack/bin/xpose" drr --ct "$pack/pelvis.mhd" --geometry $geometry --size 512x384 --pose 3,-2,1,1,0.5,-1 --device $device \
    --out-dir /tmp/drr-$device | grep -E "^device|rays in"
done
python3 - <<'PY'
import numpy as np
from PIL import Image
for view in ("A", "B"):
    a, b = (np.asarray(Image.open(f"/tmp/drr-{d}/drr_{view}.png")).astype(int) for d in ("cpu", "cuda"))
    print(f"drr_{view}.png: {a.size} pixels, largest difference {np.abs(a - b).max()} of 4095 grey levels, "
          f"{np.count_nonzero(a != b)} pixels differ")
PY

step "xpose bench drr --device cuda (pelvis)"
"$pack/bin/xpose" bench drr --ct "$pack/pelvis.mhd" --geometry $geometry --methods trilinear --device cuda 2>&1 | tee "$out/bench-drr.txt"

step "xpose bench register, cpu and cuda (pelvis, 3 trials)"
for device in cpu cuda; do
  "$pack/bin/xpose" bench register --ct "$pack/pelvis.mhd" --geometry $geometry --trials 3 --optimizers nelder-mead \
    --device $device 2>&1 | tee "$out/bench-register-$device.txt"
done
step "done"
