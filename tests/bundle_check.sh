#!/usr/bin/env bash
# The relocatable bundle (ci/bundle.sh) works on its own: it is made from this build's penumbra
# (PN_BIN), its tarball is at most 60 MiB, and unpacked elsewhere, in an environment with nothing
# but HOME, PATH=/usr/bin:/bin, VK_DRIVER_FILES (lavapipe) and Mesa's shader cache folder (the
# caller's), started from another folder:
#  - ldd, under the bundle's wrapper environment, resolves every library of the binary, the oracle
#    programs and the validation layer inside the bundle, except glibc's;
#  - it renders builtin:default to an EXR, V bit for bit the build's own render, and the bunny;
#  - bench measures two standard views (the bunny from the bundle's assets, the canopy) at 32x32;
#  - gpu-check.sh --quick --size 32 (on the bunny, the bench on two views) runs to the end and passes.
# Not in the sanitizer builds (their penumbra needs the sanitizer runtimes and LD_PRELOAD).
set -euo pipefail
BIN=${PN_BIN:?PN_BIN not set}
if [ -n "${PN_SANITIZER:-}" ]; then
  echo "skipped: the bundle is made from the plain build, not the sanitizer one"
  exit 77
fi
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/.." && pwd)
T=${PN_TEST_TMP:-/tmp}/bundle_check
rm -rf "$T"
mkdir -p "$T/home" "$T/cwd"
T=$(cd "$T" && pwd)
fail=0
bad() { echo "FAIL: $*"; fail=1; }
t0=$SECONDS
lap() { echo "-- $1 ($((SECONDS - t0)) s)"; }

icd=$(ls /usr/share/vulkan/icd.d/lvp_icd*.json 2>/dev/null | head -n1 || true)
[ -n "$icd" ] || { echo "FAIL: lavapipe's ICD file is not in /usr/share/vulkan/icd.d (mesa-vulkan-drivers: ci/deps.sh)"; exit 1; }

# 1. The bundle and its tarball.
PN_BIN=$BIN "$repo/ci/bundle.sh" "$T/out" || { echo "FAIL: ci/bundle.sh exited $?"; exit 1; }
tarball=$T/out/penumbra-bundle.tar.gz
bytes=$(stat -c %s "$tarball")
echo "tarball: $bytes bytes"
[ "$bytes" -le $((60 * 1024 * 1024)) ] || bad "the tarball is $bytes bytes, over 60 MiB"
mkdir -p "$T/unpacked"
tar -C "$T/unpacked" -xzf "$tarball"
rm -rf "$T/out/penumbra-bundle" # only the unpacked copy from here on
B=$T/unpacked/penumbra-bundle
for f in penumbra bin/penumbra bin/bundle-env libexec/penumbra gpu-check.sh lib/libvulkan.so.1 lib/libembree3.so.3 \
  assets/stanford-bunny-69k.glb; do
  [ -e "$B/$f" ] || bad "the bundle has no $f"
done
lap "bundle made and unpacked"

# Mesa's shader cache is the caller's (the suite's), not the new HOME's: an empty cache is what a
# new machine has, not what the bundle is checked for, and it made this test compile every
# pipeline of its renders, bench and gpu-check again on every run (1366 s on a new machine).
# The bundle runs the system's lavapipe (VK_DRIVER_FILES), whose cache entries these are.
cache=${MESA_SHADER_CACHE_DIR:-${XDG_CACHE_HOME:-${HOME:-/nonexistent}/.cache}}
E=(env -i "HOME=$T/home" PATH=/usr/bin:/bin "VK_DRIVER_FILES=$icd" "MESA_SHADER_CACHE_DIR=$cache"
  ${PN_PIPELINE_LOG:+"PN_PIPELINE_LOG=$PN_PIPELINE_LOG"})
cd "$T/cwd"

# 2. Every library from the bundle, but glibc's: for the programs and for every bundled library.
for o in libexec/penumbra libexec/test_exact_oracle libexec/test_alpha_oracle lib/libVkLayer_khronos_validation.so; do
  [ -e "$B/$o" ] || bad "the bundle has no $o"
done
for o in $(cd "$B" && ls libexec/* lib/*); do
  out=$("${E[@]}" "$B/bin/bundle-env" ldd "$B/$o" 2>&1) || { bad "ldd $o: $out"; continue; }
  outside=$(awk -v lib="$B/lib/" '
    /not found/ {print; next}
    $1 ~ /^(linux-vdso|ld-linux|libc|libm|libdl|libpthread|librt|libresolv|libutil|libmvec)[.-]/ {next}
    $1 ~ /^\/lib64\/ld-linux/ {next}
    $2 == "=>" && index($3, lib) != 1 {print}' <<<"$out")
  if [ -n "$outside" ]; then
    bad "$o resolves libraries outside the bundle:"
    echo "$outside"
  else
    n=$(grep -c "=> $B/lib/" <<<"$out" || true)
    case $o in libexec/* | lib/libVkLayer*) echo "$o: $n libraries from the bundle, the rest glibc's" ;; esac
  fi
done
lap "ldd"

# 3. Renders: builtin:default (V as the build's own) and the bunny.
run() { "${E[@]}" "$B/penumbra" "$@"; }
run info >"$T/info.txt" 2>&1 || { cat "$T/info.txt"; bad "penumbra info from the bundle"; }
grep -q "llvmpipe" "$T/info.txt" || bad "the bundle's penumbra did not find lavapipe: $(cat "$T/info.txt")"
if run render builtin:default --size 160x90 -o default.exr >render.log 2>&1 && [ -s default.exr ]; then
  "$BIN" render builtin:default --size 160x90 -o "$T/default_build.exr" >/dev/null 2>&1 ||
    bad "the build's own render of builtin:default"
  "$BIN" diff "$T/default_build.exr" default.exr --fail max=0 >/dev/null ||
    bad "the bundle's render of builtin:default differs from the build's"
  echo "render builtin:default: ok, V as the build's"
else
  cat render.log
  bad "render builtin:default from the bundle"
fi
# The mesh by a path relative to the folder the command starts in (not the bundle's).
cp "$B/assets/stanford-bunny-69k.glb" bunny.glb
if run render bunny.glb --size 96x96 --spp 4 -o bunny.exr >render.log 2>&1 && [ -s bunny.exr ]; then
  echo "render bunny: ok"
else
  cat render.log
  bad "render of the bunny from the bundle"
fi
lap "renders"

# 4. The bench on standard views: the bunny's mesh found through the wrapper's PN_ASSETS.
if run bench --views bunny,canopy --size 32x32 --spp 4 --modes exact,linespace --trees 6,3 --filter none \
  --reference-spp 64 --repeat 1 --warmup 1 --out "$T/bench" >bench.log 2>&1; then
  for v in bunny canopy; do
    grep -q "^$v,32,32," "$T/bench/bench.csv" || bad "bench.csv has no row of the $v view"
  done
  echo "bench: ok"
else
  tail -n 20 bench.log
  bad "bench from the bundle"
fi
lap "bench"

# 5. gpu-check, quick, to the end.
# Each step on one scene, the bunny (the bundle's assets, through the wrapper's PN_ASSETS), and the
# bench on two views: what the bundle is checked for is that gpu-check runs from it, each step to
# its end; the steps' checks themselves are the suite's own tests (test_modes, test_exact_oracle,
# ...), which ran gpu-check's three scenes and the bench's seven views here in 153 s of this test's
# 190 (warm, issue 62).
if "${E[@]}" "$B/gpu-check.sh" "$T/gpu-check" --quick --size 32 --scenes bunny --bench-args "--views bunny,canopy" \
  >gpu-check.log 2>&1; then
  grep -q "^gpu-check: PASS" gpu-check.log || bad "gpu-check exited 0 without its PASS line"
  sed -n '/^== summary/,$p' gpu-check.log
else
  tail -n 60 gpu-check.log
  bad "gpu-check.sh --quick from the bundle (log: $T/cwd/gpu-check.log)"
fi
lap "gpu-check"
if [ $fail = 0 ]; then
  rm -rf "$T/unpacked" "$T/out" # 150 MB; the logs and gpu-check's outputs stay
  echo "bundle_check: ok ($((SECONDS - t0)) s)"
fi
exit $fail
