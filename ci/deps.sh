#!/usr/bin/env bash
# Installs every Debian package penumbra needs to build, render and test. The one list in one place.
# Idempotent: installs only what is missing; non-interactive; works as root or through sudo.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config
  mesa-vulkan-drivers libvulkan-dev vulkan-tools vulkan-validationlayers
  glslang-tools spirv-tools
  libglfw3-dev libcglm-dev libtinygltf-dev
  libopenexr-dev openexr
  libembree-dev
  xvfb xauth openimageio-tools gnuplot-nox
  assimp-testmodels
  python3
  clang-14 clang libclang-rt-14-dev llvm-14
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

if [ "$(id -u)" -eq 0 ]; then
  SUDO=()
elif command -v sudo >/dev/null 2>&1; then
  SUDO=(sudo -n)
else
  echo "ci/deps.sh: missing packages (${missing[*]}) and neither root nor sudo is available" >&2
  exit 1
fi

echo "ci/deps.sh: installing ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
"${SUDO[@]}" apt-get update -qq
"${SUDO[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
