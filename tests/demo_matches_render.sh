#!/usr/bin/env bash
# penumbra demo's screenshot of a fixed view equals the offscreen render of the same view and
# parameters: same camera, light, tree, mode, sampler, spp and seed, accumulation off.
#
# Tolerance: zero. Both commands run the same passes (pn_renderer) on the same inputs with the same
# seed on the same device, and tone-map with the same function (pn_tonemap_srgb8).
# llvmpipe: deterministic for a fixed input (other drivers: assumed, not checked).
# The demo adds a camera that must stay bit-identical when nothing
# moves, a tree built the same way (culled for the same light; its candidate lists do not change
# the tree), a BGRA swapchain copy and a CPU composition; any difference, even one 8-bit step,
# means one of those changed the image, which is what this test is for.
set -u
BIN=${PN_BIN:?PN_BIN not set}
TMP=${PN_TEST_TMP:-/tmp}/demo_matches_render
rm -rf "$TMP" && mkdir -p "$TMP"
command -v xvfb-run >/dev/null || { echo "SKIP: xvfb-run not installed (ci/deps.sh installs xvfb)"; exit 77; }
command -v idiff >/dev/null || { echo "SKIP: idiff not installed (ci/deps.sh installs openimageio-tools)"; exit 77; }

fail=0
check() { # NAME ARGS...: the same view through demo and render
  local name=$1; shift
  local view=(--size 240x160 --camera-pos 2.5,3.2,5.5 --camera-target 0,0.6,0 --seed 7 --tree 6,3 "$@")
  xvfb-run -a -s "-screen 0 1280x720x24" "$BIN" demo "${view[@]}" --frames 3 --no-accumulate \
    --screenshot "$TMP/$name.demo.png" >/dev/null || { echo "FAIL: demo $name exited $?"; fail=1; return; }
  "$BIN" render "${view[@]}" -o "$TMP/$name.exr" --preview "$TMP/$name.render.png" >/dev/null \
    || { echo "FAIL: render $name exited $?"; fail=1; return; }
  if idiff -fail 0 -failpercent 0 "$TMP/$name.demo.png" "$TMP/$name.render.png"; then
    echo "ok: $name: demo screenshot equals render --preview"
  else
    echo "FAIL: $name: demo screenshot differs from render --preview"; fail=1
  fi
}
LS=(--light-size 1.2,0.8)
check linespace --mode linespace --spp 4 "${LS[@]}"
check hybrid_packet_grid --mode hybrid --traversal packet --sampler grid --spp 9 "${LS[@]}"
check ls_plane --mode ls-plane --spp 4 "${LS[@]}"
check exact --mode exact --spp 4 "${LS[@]}"
# Two lights (--light groups): one tree for both, a shadow and shading pass each, summed.
check two_lights --mode linespace --spp 4 --light 1,4,1:-0.2,-1,-0.2:0,0,1:1.2,0.8:3 \
  --light -2,3,2:0.5,-1,-0.5:0,0,1:0.6,0.6:1,2,4
exit $fail
