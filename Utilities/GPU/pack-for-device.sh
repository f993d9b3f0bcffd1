#!/usr/bin/env bash
# Packs what device-check.sh needs on a GPU machine without xpose's Debian packages: xpose and its
# GPU tests as built here (build/), every shared library they load but the C and C++ runtimes
# (the machine's own, of the same or a later version), Eigen's headers for the harness, and the
# pelvis CT as a MetaImage (export-ct.py). Run after Utilities/setup.sh, on the same processor
# architecture as the GPU machine (x86-64).
# Usage: pack-for-device.sh CT_FOLDER PACK_DIR
set -euo pipefail
ct=$1 pack=$2
cd "$(dirname "$0")/../.."
rm -rf "$pack"
mkdir -p "$pack/bin" "$pack/lib"
binaries=(build/bin/xpose build/bin/TestXPDRR build/bin/TestXPRegistration)
cp "${binaries[@]}" "$pack/bin/"
ldd "${binaries[@]}" | awk '$3 ~ /^\// {print $3}' | sort -u |
  grep -vE '/(libc|libm|libstdc\+\+|libgcc_s|libpthread|libdl|librt|libresolv|ld-linux-x86-64)\.so' |
  xargs -I{} cp -L {} "$pack/lib/"
cp -r /usr/include/eigen3 "$pack/eigen3"
PYTHONPATH=build/lib/python3/dist-packages /usr/bin/python3 Utilities/GPU/export-ct.py "$ct" "$pack/pelvis.mhd"
du -sh "$pack"
