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
source "$root/Utilities/Benchmarks/plastimatch-setup.sh"
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
