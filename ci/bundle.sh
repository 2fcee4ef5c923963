#!/usr/bin/env bash
# A relocatable penumbra for a bare Linux x86-64 machine (a GPU server with a driver and little else):
#   ci/bundle.sh [OUT_DIR]     (default OUT_DIR: build/bundle)
# writes OUT_DIR/penumbra-bundle/ and OUT_DIR/penumbra-bundle.tar.gz (at most 60 MiB, or it fails):
#   penumbra, bin/penumbra   the wrapper: sets LD_LIBRARY_PATH to lib/, PN_ASSETS to assets/, the
#                            Vulkan layer path to the bundled validation layer and, when no Vulkan
#                            driver manifest is in the standard places, NVIDIA's (VK_DRIVER_FILES);
#                            then runs libexec/penumbra. Works from any directory.
#   bin/bundle-env CMD...    runs any command in that environment (ldd, the oracles)
#   libexec/penumbra         the binary; libexec/test_exact_oracle, test_alpha_oracle: the test
#                            programs that check exact (and rayquery) against Embree 3 ray by ray
#   lib/                     every shared library ldd lists except glibc's (libc, libm, libdl,
#                            libpthread, librt, ld-linux): the Vulkan loader, OpenEXRCore, GLFW and
#                            X11, tinygltf, stb, Embree 3 and TBB, zlib, libstdc++ and libgcc_s
#                            (a bare machine may have older ones); the Khronos validation layer
#   share/vulkan/explicit_layer.d/  its manifest, pointing at lib/
#   assets/                  the meshes of the bench's standard views (engine/apps/bench/bench_views.c)
#   gpu-check.sh             ci/gpu-check.sh: device, correctness, validation, bench in one run
# Not bundled: a Vulkan driver. Mesa's lavapipe needs libLLVM-15 (about 120 MB): far over the
# budget, and a GPU machine brings its own driver; lavapipe is the fallback of a machine with Mesa.
# The binary is build/penumbra (or PN_BIN), built with ci/build.sh only when it is missing.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
out=${1:-$repo/build/bundle}
mkdir -p "$out"
out=$(cd "$out" && pwd)
max_bytes=$((60 * 1024 * 1024))
die() { echo "ci/bundle.sh: $*" >&2; exit 1; }

bin=${PN_BIN:-$repo/build/penumbra}
if [ ! -x "$bin" ]; then
  [ -z "${PN_BIN:-}" ] || die "PN_BIN=$PN_BIN is not an executable"
  echo "ci/bundle.sh: $bin missing: building (ci/build.sh)" >&2
  "$repo/ci/build.sh"
fi
bin=$(readlink -f "$bin")
build_dir=$(dirname "$bin")
assets=${PN_ASSETS:-$repo/../shared/assets}
[ -d "$assets" ] || die "no assets folder at $assets (set PN_ASSETS)"
assets=$(cd "$assets" && pwd)

# The standard views' meshes: every "*.glb" named in bench_views.c's table.
views_src=$repo/engine/apps/bench/bench_views.c
meshes=$(grep -o '"[^"]*\.glb"' "$views_src" | tr -d '"' | sort -u)
[ -n "$meshes" ] || die "found no standard view meshes in $views_src"

name=penumbra-bundle
tree=$out/$name
tarball=$out/$name.tar.gz
rm -rf "$tree" "$tarball"
mkdir -p "$tree/bin" "$tree/libexec" "$tree/lib" "$tree/assets" "$tree/share/vulkan/explicit_layer.d"

cp "$bin" "$tree/libexec/penumbra"
oracles=()
for t in test_exact_oracle test_alpha_oracle; do
  if [ -x "$build_dir/tests/$t" ]; then
    cp "$build_dir/tests/$t" "$tree/libexec/$t"
    oracles+=("$tree/libexec/$t")
  else
    echo "ci/bundle.sh: warning: $build_dir/tests/$t missing: gpu-check will skip the Embree ray checks" >&2
  fi
done

# The validation layer, if installed here: its manifest with the library beside the others.
layer_json=""
for d in /usr/share/vulkan/explicit_layer.d /etc/vulkan/explicit_layer.d /usr/local/share/vulkan/explicit_layer.d; do
  [ -f "$d/VkLayer_khronos_validation.json" ] && { layer_json=$d/VkLayer_khronos_validation.json; break; }
done
layer_lib=""
if [ -n "$layer_json" ]; then
  lp=$(sed -n 's/.*"library_path"[[:space:]]*:[[:space:]]*"\([^"]*\)".*/\1/p' "$layer_json" | head -n1)
  case $lp in
    /*) layer_lib=$lp ;;
    */*) layer_lib=$(dirname "$layer_json")/$lp ;;
    *) layer_lib=$(/sbin/ldconfig -p 2>/dev/null | awk -v n="$lp" '$1 == n && /x86-64/ && !f {f = 1; print $NF}') ;;
  esac
  [ -n "$layer_lib" ] || for d in /usr/lib/x86_64-linux-gnu /lib/x86_64-linux-gnu /usr/lib; do
    [ -f "$d/$lp" ] && { layer_lib=$d/$lp; break; }
  done
fi
if [ -n "$layer_lib" ] && [ -f "$layer_lib" ]; then
  cp -L "$layer_lib" "$tree/lib/libVkLayer_khronos_validation.so"
  # A relative library_path is relative to the manifest (Vulkan loader): share/vulkan/explicit_layer.d -> lib/.
  sed 's#"library_path"[[:space:]]*:[[:space:]]*"[^"]*"#"library_path": "../../../lib/libVkLayer_khronos_validation.so"#' \
    "$layer_json" >"$tree/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json"
else
  echo "ci/bundle.sh: warning: the Khronos validation layer is not installed here: not bundled" >&2
fi

# Every library the programs and the layer load, but glibc's own.
is_glibc() {
  case $1 in
    linux-vdso.so.* | ld-linux*.so.* | libc.so.* | libm.so.* | libdl.so.* | libpthread.so.* | librt.so.* | \
      libresolv.so.* | libutil.so.* | libmvec.so.* | libanl.so.* | libnsl.so.*) return 0 ;;
  esac
  return 1
}
objects=("$tree/libexec/penumbra" "${oracles[@]}")
[ -f "$tree/lib/libVkLayer_khronos_validation.so" ] && objects+=("$tree/lib/libVkLayer_khronos_validation.so")
for o in "${objects[@]}"; do
  ldd "$o" | grep "not found" >/dev/null && die "$o: ldd finds a library missing here: $(ldd "$o" | grep "not found" | tr -s ' \t' ' ')"
  ldd "$o" | awk '$2 == "=>" && $3 ~ /^\// {print $1, $3}'
done | sort -u | while read -r soname path; do
  is_glibc "$soname" && continue
  cp -L "$path" "$tree/lib/$soname"
done
# Loaded with dlopen, so ldd does not list it: TBB's scalable allocator, which Embree's builds use
# when it is there (TBB falls back to malloc without it). Its own needs are glibc's.
dlopened=(libtbbmalloc.so.2)
for extra in "${dlopened[@]}"; do
  found=""
  for d in /lib/x86_64-linux-gnu /usr/lib/x86_64-linux-gnu /usr/lib64 /usr/lib; do
    [ -e "$d/$extra" ] && { found=$d/$extra; break; }
  done
  if [ -n "$found" ]; then
    cp -L "$found" "$tree/lib/$extra"
  else
    echo "ci/bundle.sh: note: $extra not installed here: not bundled (TBB then allocates with malloc)" >&2
  fi
done

# The wrapper: the environment (bin/bundle-env) and penumbra in it (bin/penumbra).
cat >"$tree/bin/bundle-env" <<'EOF'
#!/bin/sh
# Runs a command in the bundle's environment: its lib/ first on LD_LIBRARY_PATH, PN_ASSETS at its
# assets/ (unless set), its validation layer found by the Vulkan loader, and a Vulkan driver: if
# neither VK_DRIVER_FILES nor VK_ICD_FILENAMES is set and no driver manifest is in the loader's
# standard folders, NVIDIA's from where GPU containers put it (VK_DRIVER_FILES); if the standard
# folders hold other drivers but not NVIDIA's and it is there, it is added (VK_ADD_DRIVER_FILES).
set -eu
self=$(readlink -f "$0")
root=$(cd "$(dirname "$self")/.." && pwd)
LD_LIBRARY_PATH=$root/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
: "${PN_ASSETS:=$root/assets}"
VK_ADD_LAYER_PATH=$root/share/vulkan/explicit_layer.d${VK_ADD_LAYER_PATH:+:$VK_ADD_LAYER_PATH}
export LD_LIBRARY_PATH PN_ASSETS VK_ADD_LAYER_PATH
if [ -z "${VK_DRIVER_FILES:-}" ] && [ -z "${VK_ICD_FILENAMES:-}" ]; then
  std="" nv_std=0
  dirs="${XDG_CONFIG_DIRS:-/etc/xdg}:/etc:${XDG_DATA_DIRS:-/usr/local/share:/usr/share}:${XDG_DATA_HOME:-${HOME:-/nonexistent}/.local/share}"
  IFS=:
  for d in $dirs; do
    for f in "$d"/vulkan/icd.d/*.json; do
      [ -f "$f" ] || continue
      std=1
      case ${f##*/} in nvidia*) nv_std=1 ;; esac
    done
  done
  unset IFS
  nv=""
  for f in /usr/local/nvidia/share/vulkan/icd.d/*.json /usr/local/nvidia/vulkan/icd.d/*.json \
    /usr/local/nvidia/icd.d/*.json /usr/local/nvidia/etc/vulkan/icd.d/*.json /usr/share/nvidia/*icd*.json; do
    [ -f "$f" ] && nv=${nv:+$nv:}$f
  done
  if [ -n "$nv" ] && [ "$nv_std" = 0 ]; then
    if [ -z "$std" ]; then
      VK_DRIVER_FILES=$nv
      export VK_DRIVER_FILES
    else
      VK_ADD_DRIVER_FILES=$nv${VK_ADD_DRIVER_FILES:+:$VK_ADD_DRIVER_FILES}
      export VK_ADD_DRIVER_FILES
    fi
    # The driver's libraries (libGLX_nvidia.so.0, ...) where those containers put them.
    for d in /usr/local/nvidia/lib64 /usr/local/nvidia/lib; do
      [ -d "$d" ] && LD_LIBRARY_PATH=$LD_LIBRARY_PATH:$d
    done
    export LD_LIBRARY_PATH
  fi
fi
exec "$@"
EOF
cat >"$tree/bin/penumbra" <<'EOF'
#!/bin/sh
# penumbra from this bundle, from any directory: bin/bundle-env sets the environment.
self=$(readlink -f "$0")
here=$(dirname "$self")
exec "$here/bundle-env" "$here/../libexec/penumbra" "$@"
EOF
chmod +x "$tree/bin/bundle-env" "$tree/bin/penumbra"
ln -s bin/penumbra "$tree/penumbra"

cp "$repo/ci/gpu-check.sh" "$tree/gpu-check.sh"
chmod +x "$tree/gpu-check.sh"

for m in $meshes; do
  if [ -f "$assets/$m" ]; then
    cp "$assets/$m" "$tree/assets/$m"
  else
    echo "ci/bundle.sh: warning: $assets/$m missing: its standard views are not in the bundle" >&2
  fi
done

commit=$(git -C "$repo" rev-parse --short HEAD 2>/dev/null || echo unknown)
dirty=""
if git -C "$repo" status --porcelain --untracked-files=no 2>/dev/null | grep . >/dev/null; then
  dirty=" (with uncommitted changes)"
fi
{
  echo "penumbra bundle"
  echo "commit:  $commit$dirty"
  echo "made:    $(date -u +%Y-%m-%dT%H:%M:%SZ) on $(uname -srm)"
  echo "binary:  $bin"
  echo
  echo "Run:     ./penumbra info; ./penumbra render builtin:default -o out.exr; ./penumbra bench --quick"
  echo "Check:   ./gpu-check.sh OUT_DIR [--size N] [--quick]"
  echo "Driver:  none bundled; the machine's Vulkan driver (NVIDIA's manifest is found in"
  echo "         /usr/local/nvidia/... when the standard folders have none; or set VK_DRIVER_FILES)."
  echo
  echo "Files:"
  (cd "$tree" && find . -type f -printf '%s\t%p\n' | sort -k2)
} >"$tree/BUNDLE.txt"

# The tarball: one top folder, owned by nobody in particular.
tar -C "$out" --owner=0 --group=0 --numeric-owner -cf - "$name" | gzip -9 >"$tarball.tmp"
mv "$tarball.tmp" "$tarball"
bytes=$(stat -c %s "$tarball")
mib=$(awk -v b="$bytes" 'BEGIN {printf "%.1f", b / 1048576}')
echo "ci/bundle.sh: $tree"
echo "ci/bundle.sh: $tarball: $bytes bytes ($mib MiB; limit 60 MiB)"
echo "ci/bundle.sh: largest members (uncompressed):"
(cd "$tree" && find . -type f -printf '%s %p\n' | sort -rn |
  awk 'NR <= 8 {printf "  %7.1f MiB  %s\n", $1 / 1048576, $2}')
if [ "$bytes" -gt "$max_bytes" ]; then
  echo "ci/bundle.sh: FAIL: the tarball is $mib MiB, over the 60 MiB limit" >&2
  exit 1
fi
