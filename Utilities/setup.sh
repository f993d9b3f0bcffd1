#!/usr/bin/env bash
# Installs xpose's dependencies from Debian 12 packages and builds it into ./build.
# Usage: bash Utilities/setup.sh        (as root, or with sudo available)
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  cmake ninja-build g++ pkg-config
  libvtk9-dev libvtkgdcm-dev libgdcm-dev      # VTK 9.1 and GDCM with its VTK bridge
  libeigen3-dev libnlopt-cxx-dev libopencv-dev libcli11-dev
  libgtest-dev libbenchmark-dev
  libpng-dev libtiff-dev                      # X-ray and volume files: PNG, TIFF (8/16-bit, stacks)
  libxrl-dev                                  # xraylib: X-ray cross sections for the simulator
  python3-vtk9 python3-dev                    # the xpose Python package, wrapped against Debian's VTK
  xvfb xauth                                  # off-screen rendering tests on a virtual display
  dicom3tools dcmtk                           # dciodvfy, dcmodify: the tests validate and edit the DICOM xpose writes
  libcurl4-openssl-dev                        # DICOMweb over HTTP(S): TLS, authentication, redirects
  libdcmtk-dev                                # DIMSE (C-FIND, C-GET, C-STORE, the listen node) through dcmtk
  orthanc orthanc-dicomweb                    # a real DICOM archive with DICOMweb for the `pacs` tests
  nginx-light openssl                         # the tests' TLS proxy in front of it, with a certificate they make
  plastimatch                                 # an X-ray renderer the project did not write (evaluate --scenario plastimatch)
)
sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
missing=$(dpkg-query -W -f='${Package} ${Status}\n' "${packages[@]}" 2>/dev/null | grep -vc "install ok installed" || true)
if [ "$missing" != "0" ] || ! dpkg-query -W "${packages[@]}" >/dev/null 2>&1; then
  $sudo apt-get update
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y --no-install-recommends "${packages[@]}"
fi

cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build
echo "xpose built: build/bin/xpose; run the tests with: ctest --test-dir build --output-on-failure"
