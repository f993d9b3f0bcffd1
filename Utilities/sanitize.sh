#!/usr/bin/env bash
# Builds xpose with AddressSanitizer and UndefinedBehaviorSanitizer (float-cast-overflow
# included) into build-asan/ and runs the whole test suite there: any finding fails the test.
# Usage: bash Utilities/sanitize.sh  (after Utilities/setup.sh has installed the packages)
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DXP_SANITIZE=ON -DXPOSE_WRAP_PYTHON=OFF
cmake --build build-asan
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
# xraylib's own leftovers, named in the file; every other leak fails its test.
export LSAN_OPTIONS="suppressions=$PWD/Utilities/lsan-suppressions.txt:print_suppressions=0"
# Tests that draw through OpenGL load Mesa's driver, which leaks a few hundred bytes and is
# unloaded before LeakSanitizer looks, so its allocations can be neither named nor suppressed:
# those run with ASan and UBSan but without the leak check (the archive round trip and listen
# run xpose processes that write reports); every other test runs with it.
opengl='RoomScene\.|RegisterWritesAReport|ArchiveTest\.RegistersAStudyHeldOnlyInTheArchive|Listen\.'
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1 \
  ctest --test-dir build-asan --output-on-failure -j2 -E "$opengl"
ASAN_OPTIONS=detect_leaks=0:abort_on_error=1:strict_string_checks=1 \
  ctest --test-dir build-asan --output-on-failure -j2 -R "$opengl"
