#!/usr/bin/env bash
# Builds the readers' libFuzzer targets (clang, ASan + UBSan) into build-fuzz/ and runs each one
# from seeds that xpose and its tests make, then prints executions, coverage and findings.
# Usage: bash Utilities/fuzz.sh [RUNS] [MAX_SECONDS] [TARGET...]
#   RUNS: executions per target (default 1000000); MAX_SECONDS: time cap per target (1800).
# Crashing inputs land in build-fuzz/fuzz/artifacts/TARGET/ (emptied when TARGET starts); add
# them, once fixed, to Testing/Fuzzing/regressions/TARGET/, which ctest replays in every build.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-1000000}
seconds=${2:-1800}
shift $(( $# > 2 ? 2 : $# )) || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(DICOMSeries DICOMXRay PNG TIFF MetaImage NIfTI Geometry)
command -v clang++ >/dev/null || { echo "fuzz.sh: needs clang (apt-get install clang libclang-rt-14-dev)"; exit 2; }

build=build-fuzz
CC=clang CXX=clang++ cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DXPOSE_BUILD_FUZZERS=ON -DXPOSE_WRAP_PYTHON=OFF >/dev/null
cmake --build "$build" --target xpose TestXPFileFormats TestXPDICOM $(printf 'xpFuzz%s ' "${targets[@]}")

# Seeds: what the IO tests write, and a small phantom CT, DRR and mask made by xpose.
work="$build/fuzz"
seeds="$work/seeds"
rm -rf "$seeds" && mkdir -p "$seeds"/{DICOMSeries,DICOMXRay,PNG,TIFF,MetaImage,NIfTI,Geometry} "$work/made"
export ASAN_OPTIONS=detect_leaks=0
(cd "$build/Modules/FileFormats/Testing" && ./../../../bin/TestXPFileFormats --gtest_filter='VolumeIO.*:TIFF.*' >/dev/null)
(cd "$build/Modules/DICOM/Testing" && ./../../../bin/TestXPDICOM --gtest_filter='DICOMXRay.*' >/dev/null)
files="$build/Modules/FileFormats/Testing" dicom="$build/Modules/DICOM/Testing"
cp "$files/tmp-mha/ct.mha" "$seeds/MetaImage/"
cp "$files/tmp-nifti/ct.nii.gz" "$seeds/NIfTI/" && gzip -dc "$files/tmp-nifti/ct.nii.gz" > "$seeds/NIfTI/ct.nii"
cp "$dicom/tmp-dicom-dx/dx.dcm" "$dicom/tmp-dicom-cr/cr.dcm" "$seeds/DICOMXRay/"
cp "$files"/tmp-tiff-xray/x16.tif "$files"/tmp-tiff-xray/x8.tif "$files"/tmp-tiff-volume/bone.tif "$seeds/TIFF/"
made="$work/made"
rm -rf "$made" && mkdir -p "$made"
"$build/bin/xpose" phantom --out "$made/ct" --spacing 8 >/dev/null
"$build/bin/xpose" drr --ct "$made/ct" --geometry Data/geometry/stereo-oblique-90.json --size 64x48 --out-dir "$made/drr" >/dev/null
"$build/bin/xpose" mask --xray "$made/drr/drr_A.png" --window 3 --out-dir "$made/mask" >/dev/null || true
cp "$made"/drr/drr_A.png "$made"/drr/drr_A_display.png "$seeds/PNG/"
[ -f "$made/mask/mask.png" ] && cp "$made/mask/mask.png" "$seeds/PNG/"
slices=("$made"/ct/*.dcm)
{ cat "${slices[0]}"; printf 'XPSLICE\n'; cat "${slices[1]}"; } > "$seeds/DICOMSeries/two-slices"
cp "${slices[0]}" "$seeds/DICOMSeries/one-slice.dcm"
cp Data/geometry/*.json "$seeds/Geometry/"

printf '\n| target | executions | seconds | exec/s | coverage (cov) | features (ft) | crashes, hangs, leaks |\n|---|---|---|---|---|---|---|\n' > "$work/summary.md"
for target in "${targets[@]}"; do
  corpus="$work/corpus/$target"
  artifacts="$work/artifacts/$target"
  rm -rf "$artifacts"
  mkdir -p "$corpus" "$artifacts"
  log="$work/$target.log"
  start=$(date +%s)
  status=0
  "$build/bin/xpFuzz$target" "$corpus" "$seeds/$target" -runs="$runs" -max_total_time="$seconds" -timeout=1 \
    -rss_limit_mb=4096 -artifact_prefix="$artifacts/" -print_final_stats=1 >"$log" 2>&1 || status=$?
  elapsed=$(( $(date +%s) - start ))
  executed=$(grep -o 'number_of_executed_units: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*$' || echo 0)
  last=$(grep -E '^#[0-9]+' "$log" | tail -1)
  cov=$(echo "$last" | grep -o 'cov: [0-9]*' | grep -o '[0-9]*' || echo "?")
  ft=$(echo "$last" | grep -o 'ft: [0-9]*' | grep -o '[0-9]*' || echo "?")
  found=$(ls "$artifacts" | wc -l)
  printf '| %s | %s | %s | %s | %s | %s | %s%s |\n' "$target" "$executed" "$elapsed" \
    "$(( executed / (elapsed > 0 ? elapsed : 1) ))" "$cov" "$ft" "$found" \
    "$([ $status -ne 0 ] && echo " (exit $status, see $log)")" | tee -a "$work/summary.md"
done
echo
cat "$work/summary.md"
