#!/usr/bin/env bash
# Set-up and a first render: installs what is missing, builds, renders the built-in default scene.
set -euo pipefail
cd "$(dirname "$0")/.."
./ci/build.sh
mkdir -p out
./build/penumbra render builtin:default -o out/default.exr --preview out/default.png --size 1280x720 "$@"
echo "wrote $(pwd)/out/default.exr"
echo "wrote $(pwd)/out/default.png"
