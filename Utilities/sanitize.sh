#!/usr/bin/env bash
# Builds xpose with AddressSanitizer and UndefinedBehaviorSanitizer (float-cast-overflow
# included) into build-asan/ and runs the whole test suite there: any finding fails the test.
# Usage: bash Utilities/sanitize.sh  (after Utilities/setup.sh has installed the packages)
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DXP_SANITIZE=ON
cmake --build build-asan
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1
export LSAN_OPTIONS=suppressions=$PWD/Utilities/sanitizer-suppressions.txt:print_suppressions=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
ctest --test-dir build-asan --output-on-failure -j2
