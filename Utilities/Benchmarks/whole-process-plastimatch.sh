#!/usr/bin/env bash
# Whole-process time of a stereo DRR pair, as a user meets it: start, read the CT file, render both
# views, write, exit. `xpose drr` against `plastimatch drr -i exact` (plastimatch's fastest CPU
# mode) on the same .mha, the same two views and the same cores, run alternately.
# Usage: whole-process-plastimatch.sh [CT_DICOM_DIR] [COLSxROWS] [RUNS] [short|float]
# (needs: apt-get install plastimatch). xpose writes a 16-bit PNG, a display PNG and a float
# MetaImage per view; plastimatch a float PFM per view and its projection matrices.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
ct=${1:-$root/../shared/data/ct/vhm-pelvis}
size=${2:-1024x768}
runs=${3:-7}
type=${4:-short}
xpose=${XPOSE:-$root/build/bin/xpose}
geometry=$root/Data/geometry/stereo-oblique-90.json
ct_type=$type
source "$root/Utilities/Benchmarks/plastimatch-setup.sh"

pm_exact() { pm_drr exact "$cols $rows"; }
xp_drr() {
  "$xpose" drr --ct "$work/ct.mha" --geometry "$geometry" --size "$size" --out-dir "$work/xpose" >"$work/xpose.log"
}
median() { sort -g | awk '{v[NR]=$1} END {print (NR % 2) ? v[(NR+1)/2] : (v[NR/2] + v[NR/2+1]) / 2}'; }

pm_exact; xp_drr # warm the page cache and the file system
: >"$work/pm.txt"; : >"$work/xp.txt"
for _ in $(seq "$runs"); do
  seconds pm_exact >>"$work/pm.txt"
  seconds xp_drr >>"$work/xp.txt"
done
pm=$(median <"$work/pm.txt"); xp=$(median <"$work/xp.txt")
pm_min=$(sort -g "$work/pm.txt" | head -1); xp_min=$(sort -g "$work/xp.txt" | head -1)

printf 'CT %s as %s .mha (%s MB), %s per view, 2 views, %s threads, %s runs each, alternating\n' "$ct" "$type" \
  "$(( $(stat -c %s "$work/ct.mha") / 1000000 ))" "$size" "$(nproc)" "$runs"
printf '%-32s %12s %12s %18s\n' "whole process" "median (s)" "best (s)" "plastimatch/xpose"
printf '%-32s %12.3f %12.3f %18s\n' "plastimatch drr -i exact" "$pm" "$pm_min" "1.00"
printf '%-32s %12.3f %12.3f %18.2f\n' "xpose drr (trilinear)" "$xp" "$xp_min" "$(echo "$pm / $xp" | bc -l)"
echo "xpose's last run, as it prints its stages:"
grep -E "read in|prepared|rays in" "$work/xpose.log" | sed 's/^/  /'
