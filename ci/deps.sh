#!/usr/bin/env bash
# Installs every Debian package penumbra needs to build, render and test. The one list in one place.
# Idempotent: installs only what is missing; non-interactive; works as root or through sudo.
#
# The Vulkan driver: Mesa 25's lavapipe from Debian's bookworm-backports by default (Vulkan 1.4,
# VK_KHR_ray_query and acceleration structures; faster). The backports source is Debian's own
# archive, added as a deb822 file signed by the Debian archive keyring; backports are pinned low by
# apt, so nothing else is upgraded. PN_MESA=stock keeps Debian 12's own Mesa 22.3 instead (no
# backports source is added; the ray-query mode is then refused and its tests skip).
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config
  mesa-vulkan-drivers libvulkan-dev vulkan-tools vulkan-validationlayers
  glslang-tools spirv-tools
  libglfw3-dev libcglm-dev libtinygltf-dev
  libopenexr-dev openexr
  libpng-dev zlib1g-dev libmeshoptimizer-dev
  libembree-dev
  xvfb xauth openimageio-tools gnuplot-nox
  parallel
  assimp-testmodels
  python3 python3-numpy
  clang-14 clang libclang-rt-14-dev llvm-14
  gcovr
)

MESA=${PN_MESA:-backports}
case "$MESA" in
  backports | stock) ;;
  *) echo "ci/deps.sh: PN_MESA must be 'backports' (default) or 'stock', got '$MESA'" >&2; exit 1 ;;
esac

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
# Mesa 25 wanted and not there: mesa-vulkan-drivers comes from backports (below).
mesa_version=$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null || true)
want_backports=0
if [ "$MESA" = backports ] && ! dpkg --compare-versions "${mesa_version:-0}" ge 25; then
  want_backports=1
fi

if [ "$want_backports" = 1 ]; then
  keep=()
  for p in "${missing[@]}"; do [ "$p" = mesa-vulkan-drivers ] || keep+=("$p"); done
  missing=("${keep[@]}")
fi

if [ ${#missing[@]} -eq 0 ] && [ "$want_backports" = 0 ]; then
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

export DEBIAN_FRONTEND=noninteractive
if [ "$want_backports" = 1 ]; then
  # The main source's archive URI, so a mirror configured there is used for backports too.
  uri=$(sed -n 's/^URIs:[[:space:]]*\([^[:space:]]*debian\/\?\)[[:space:]]*$/\1/p' /etc/apt/sources.list.d/debian.sources 2>/dev/null | head -n1)
  uri=${uri:-http://deb.debian.org/debian}
  list=/etc/apt/sources.list.d/penumbra-bookworm-backports.sources
  if ! grep -rqs "bookworm-backports" /etc/apt/sources.list /etc/apt/sources.list.d/; then
    echo "ci/deps.sh: adding Debian's bookworm-backports ($uri) for Mesa 25's lavapipe" >&2
    printf 'Types: deb\nURIs: %s\nSuites: bookworm-backports\nComponents: main\nSigned-By: /usr/share/keyrings/debian-archive-keyring.gpg\n' \
      "$uri" | "${SUDO[@]}" tee "$list" >/dev/null
  fi
fi
echo "ci/deps.sh: installing ${missing[*]}${missing[*]:+ }$([ "$want_backports" = 1 ] && echo "mesa-vulkan-drivers (bookworm-backports)")" >&2
"${SUDO[@]}" apt-get update -qq
if [ ${#missing[@]} -gt 0 ]; then
  "${SUDO[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
if [ "$want_backports" = 1 ]; then
  "${SUDO[@]}" apt-get install -y -qq --no-install-recommends -t bookworm-backports mesa-vulkan-drivers >/dev/null
fi
