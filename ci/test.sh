#!/usr/bin/env bash
# Set-up and the whole test suite: installs what is missing, builds, runs ctest. Every GPU test
# runs on lavapipe with the Khronos validation layer and synchronization validation on.
set -euo pipefail
cd "$(dirname "$0")/.."
./ci/build.sh
cd build
ctest --output-on-failure --timeout 1800 -j"$(nproc)" "$@"
