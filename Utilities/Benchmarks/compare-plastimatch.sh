#!/usr/bin/env bash
# Renders the two views of a stereo geometry with `plastimatch drr` and with xpose at the same
# output size on the same CT, and prints rays per second and the xpose / plastimatch ratio.
# Usage: compare-plastimatch.sh [CT_DICOM_DIR] [COLSxROWS]   (needs: apt-get install plastimatch)
# plastimatch's render time is its wall time at the size minus its wall time at 8x6 (start-up
# and CT load), for both views in one process; xpose's is `xpose bench drr` (CT already loaded).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
ct=${1:-$root/../shared/data/ct/vhm-pelvis}
size=${2:-1024x768}
xpose=${XPOSE:-$root/build/bin/xpose}
geometry=$root/Data/geometry/stereo-oblique-90.json
command -v plastimatch >/dev/null || { echo "plastimatch not found: apt-get install plastimatch" >&2; exit 2; }
[ -x "$xpose" ] || { echo "xpose not built at $xpose" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cols=${size%x*}; rows=${size#*x}

plastimatch convert --input "$ct" --output-img "$work/ct.mha" >/dev/null
# Isocentre = CT centre (xpose's default): origin + (size - 1) / 2 * spacing, LPS, axial CT.
read -r iso < <(plastimatch header "$work/ct.mha" | awk '
  /^Origin/ {o1=$3; o2=$4; o3=$5} /^Size/ {s1=$3; s2=$4; s3=$5} /^Spacing/ {p1=$3; p2=$4; p3=$5}
  END {printf "%.3f %.3f %.3f\n", o1+(s1-1)/2*p1, o2+(s2-1)/2*p2, o3+(s3-1)/2*p3}')

pm_drr() { # $1 = exact|uniform, $2 = "cols rows"; panel 400 x 300 mm, SAD 1000, SID 1500, gantry 225 and 315 deg
  plastimatch drr -I "$work/ct.mha" -O "$work/pm_" -i "$1" -r "$2" -z "400 300" --sad 1000 --sid 1500 \
    -o "$iso" --vup "0 0 1" -t pfm -y 3.926990817 -N 90 -a 2 >/dev/null
}
seconds() { local s e; s=$(date +%s.%N); "$@"; e=$(date +%s.%N); echo "$e - $s" | bc -l; }
best() { local b=999999 t; for _ in 1 2 3; do t=$(seconds "$@"); b=$(echo "if ($t < $b) $t else $b" | bc -l); done; echo "$b"; }

rays=$((2 * cols * rows))
small=$(best pm_drr exact "8 6")
pm_time=$(echo "$(best pm_drr exact "$cols $rows") - $small" | bc -l)
pm_rate=$(echo "$rays / $pm_time / 1000000" | bc -l)
pm_uniform_time=$(echo "$(best pm_drr uniform "$cols $rows") - $small" | bc -l)
pm_uniform_rate=$(echo "$rays / $pm_uniform_time / 1000000" | bc -l)

bench=$("$xpose" bench drr --ct "$ct" --geometry "$geometry" --sizes "$size" --mask-size 8x6 --valid 0.5 --repetitions 3)
threads=$(nproc)
xp_tri=$(echo "$bench" | awk -v s="$size" -v t="$threads" '$1=="trilinear" && $2==s && $3==t {print $6}')
xp_sid=$(echo "$bench" | awk -v s="$size" -v t="$threads" '$1=="siddon" && $2==s && $3==t {print $6}')

printf 'CT %s, %s per view, 2 views, %s threads, isocentre (LPS) %s\n' "$ct" "$size" "$threads" "$iso"
printf '%-34s %10s %12s %18s\n' "renderer" "time (s)" "M rays/s" "xpose/plastimatch"
printf '%-34s %10.3f %12.2f %18s\n' "plastimatch drr -i exact" "$pm_time" "$pm_rate" "1.00"
printf '%-34s %10.3f %12.2f %18.2f\n' "plastimatch drr -i uniform" "$pm_uniform_time" "$pm_uniform_rate" "$(echo "$pm_uniform_rate / $pm_rate" | bc -l)"
printf '%-34s %10s %12.2f %18.2f\n' "xpose trilinear (per voxel plane)" "-" "$xp_tri" "$(echo "$xp_tri / $pm_rate" | bc -l)"
printf '%-34s %10s %12.2f %18.2f\n' "xpose siddon (exact)" "-" "$xp_sid" "$(echo "$xp_sid / $pm_rate" | bc -l)"
printf 'xpose trilinear / plastimatch uniform (the same sampling and accuracy): %.2f\n' "$(echo "$xp_tri / $pm_uniform_rate" | bc -l)"
