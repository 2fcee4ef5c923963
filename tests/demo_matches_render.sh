#!/usr/bin/env bash
# penumbra demo's screenshot of a fixed view equals the offscreen render of the same view and
# parameters: same camera, light, tree, mode, sampler, spp and seed, accumulation off; and after the
# demo moves an object live, render of the scene loaded moved (below).
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
# Adaptive samples: the demo's first frame is render's (its later frames continue them, demo_refine).
check exact_adaptive --mode exact --spp 4:16 --pixel-error 0.05 "${LS[@]}"
# Two lights (--light groups): one tree for both, a shadow and shading pass each, summed.
check two_lights --mode linespace --spp 4 --light 1,4,1:-0.2,-1,-0.2:0,0,1:1.2,0.8:3 \
  --light -2,3,2:0.5,-1,-0.5:0,0,1:0.6,0.6:1,2,4

# Moving objects live (demo script 'move-object', cmd_demo.c apply_moves): three instanced dragons
# (tests/instances.py); the demo draws frame 0, moves object 1 before frame 1 and saves frame 2,
# which must equal render --move-object, which loads the scene already moved and builds everything
# for it. Everything the view takes from the scene's bounds is given instead (camera; a --light
# group: the default light's radiance follows the bounds, which render takes after its move), but
# the ground plane, which render places under the moved scene: with it, the move stays inside the
# bounds. A screenshot must also differ from the unmoved render, or the check proves nothing.
MESH=${PN_ASSETS:-../shared/assets}/stanford-dragon-res4-11k.glb
HERE=$(cd "$(dirname "$0")" && pwd)
check_move() { # NAME I:DX,DY,DZ EXPECT ARGS...: EXPECT is what the demo's stdout says the move cost;
  # RENDER_ONLY: render's own options
  local name=$1 move=$2 expect=$3 render_only=(${RENDER_ONLY:-}); shift 3
  local view=("$TMP/d3.glb" --size 240x160 --camera-pos 0.4,0.55,0.9 --camera-target 0.4,0.08,0 --seed 7
              --tree 6,3 --spp 4 "$@")
  printf 'frame 1 move-object %s %s\nframe 2 screenshot %s\n' "${move%%:*}" "$(tr , ' ' <<<"${move#*:}")" \
    "$TMP/$name.demo.png" > "$TMP/$name.script"
  local out
  out=$(xvfb-run -a -s "-screen 0 1280x720x24" "$BIN" demo "${view[@]}" --frames 3 --no-accumulate \
    --script "$TMP/$name.script") || { echo "FAIL: demo $name exited $?"; fail=1; return; }
  echo "$out" | grep "moved in"
  grep -q "$expect" <<<"$out" || { echo "FAIL: $name: the demo does not say '$expect'"; fail=1; }
  "$BIN" render "${view[@]}" "${render_only[@]}" --move-object "$move" -o "$TMP/$name.exr" --preview "$TMP/$name.render.png" \
    >/dev/null || { echo "FAIL: render $name exited $?"; fail=1; return; }
  "$BIN" render "${view[@]}" "${render_only[@]}" -o "$TMP/$name.still.exr" --preview "$TMP/$name.still.png" >/dev/null \
    || { echo "FAIL: render $name unmoved exited $?"; fail=1; return; }
  if ! idiff -fail 0 -failpercent 0 "$TMP/$name.demo.png" "$TMP/$name.render.png" >/dev/null; then
    echo "FAIL: $name: the demo's frame after the move differs from render --move-object $move"; fail=1
  elif idiff -fail 0 -failpercent 0 "$TMP/$name.demo.png" "$TMP/$name.still.png" >/dev/null; then
    echo "FAIL: $name: the move does not change the picture"; fail=1
  else
    echo "ok: $name: demo after move-object $move equals render --move-object, and differs unmoved"
  fi
}
if [ ! -f "$MESH" ]; then
  echo "SKIP (moving objects): $MESH missing"
else
  python3 "$HERE/instances.py" "$MESH" "$TMP/d3.glb" --grid 3,1,1 --spacing 2.0 || exit 1
  ABOVE=(--light 0.3,0.7,0.3:-0.1,-1,-0.3:0,0,1:0.15,0.15:40)
  # Per-object trees: the top level alone is rebuilt; the ground stays culled (the object moves
  # along x between its neighbours, over the ground).
  check_move objects_ground 1:0.15,0,0 "per-object trees: no tree rebuilt" --trees object "${ABOVE[@]}"
  # Out of the bounds, 100 units away: the clip planes and scene_mag (the rays' origin offset)
  # follow the new bounds (keeping the old scene_mag changes 19 pixels here).
  check_move objects_far 1:100,0,0 "per-object trees: no tree rebuilt" --trees object --no-ground \
    --light 1.2,0.4,0.3:-1,-0.3,-0.2:0,1,0:0.15,0.15:40
  # The scene-wide tree is rebuilt on the worker thread; the screenshot waits for it (render
  # without view culling, which the demo's trees do not do).
  RENDER_ONLY=--no-view-cull check_move scene_tree 1:0.15,0,0 "rebuilt on a worker thread" "${ABOVE[@]}"
  # Refused before a window opens, with the script's line: an object that does not exist, a command
  # short of a number.
  printf 'frame 1 move-object 3 0.1 0 0\n' > "$TMP/bad_index.script"
  printf '# comment\nframe 1 move-object 1 0.1 0\n' > "$TMP/bad_args.script"
  for bad in "bad_index:bad_index.script:1: move-object 3: .* has 3 object" "bad_args:bad_args.script:2: move-object needs"; do
    out=$("$BIN" demo "$TMP/d3.glb" --frames 1 --script "$TMP/${bad%%:*}.script" 2>&1); rc=$?
    if [ $rc -ne 0 ] && grep -q "${bad#*:}" <<<"$out"; then
      echo "ok: ${bad%%:*} refused (exit $rc): $out"
    else
      echo "FAIL: ${bad%%:*}: exit $rc, expected a refusal matching '${bad#*:}': $out"; fail=1
    fi
  done
fi
exit $fail
