#!/usr/bin/env bash
# Installs missing packages (ci/deps.sh), then configures and builds into build/.
set -euo pipefail
cd "$(dirname "$0")/.."
./ci/deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE="${CMAKE_BUILD_TYPE:-RelWithDebInfo}" >/dev/null
cmake --build build --parallel "$(nproc)"
