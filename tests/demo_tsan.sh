#!/usr/bin/env bash
# penumbra demo under ThreadSanitizer (the PN_TSAN build, build-tsan/; tests/sanitizers.md): a
# scripted session in which the worker thread builds trees while the frame loop renders, moves
# objects and lights and switches modes. Each TSan report fails it (TSan prints it, and penumbra
# then exits 66); tests/tsan.supp names only the uninstrumented Vulkan driver and layer.
# Skips (77) unless PN_SANITIZER=thread (tests/CMakeLists.txt sets it in the TSan build): in any
# other build there is nothing to detect races with.
#
# Two sessions over three dragons (tests/instances.py), validation on:
# - the scene-wide tree: N, D and light keys and object moves each rebuild it on the worker; the
#   keys are pressed again while a build runs (the next starts when it ends), the renderers are
#   recreated (modes, views, traversal, sampler, filter, spp, a resize) meanwhile, and
#   screenshots wait for the builds due (settle_tree);
# - per-object trees (--trees object): moves rebuild the top level on the frame loop's thread;
#   the rebuild of the trees (N, D) runs on the worker.
set -u
BIN=${PN_BIN:?PN_BIN not set}
[ "${PN_SANITIZER:-}" = thread ] || { echo "SKIP: not the ThreadSanitizer build (PN_TSAN=ON, build-tsan/)"; exit 77; }
# In the TSan build a missing X server would leave ci/test.sh's ThreadSanitizer step checking
# nothing: a failure there, not a skip.
command -v xvfb-run >/dev/null || { echo "FAIL: xvfb-run not installed (ci/deps.sh installs xvfb)"; exit 1; }
MESH=${PN_ASSETS:-../shared/assets}/stanford-dragon-res4-11k.glb
[ -f "$MESH" ] || { echo "SKIP: $MESH missing"; exit 77; }
TMP=${PN_TEST_TMP:-/tmp}/demo_tsan
rm -rf "$TMP" && mkdir -p "$TMP"
HERE=$(cd "$(dirname "$0")" && pwd)
python3 "$HERE/instances.py" "$MESH" "$TMP/d3.glb" --grid 3,1,1 --spacing 2.0 || exit 1

cat > "$TMP/scene_tree.script" <<'SCRIPT'
frame 1 orbit 20 5
frame 2 key N                 # LS(7,3) -> LS(8,3) on the worker
frame 3 orbit 10 0
frame 3 key shift+D           # again while it builds: LS(8,2) follows it
frame 4 move-object 1 0.1 0 0 # and an object moves during the build: one more rebuild due
frame 5 pan 0.05 0
frame 6 key left              # the light moves: rebuilt when the tree culls for it
frame 7 key ]
frame 8 key ,
frame 9 key M                 # modes and views recreate the renderers while the worker runs
frame 10 key T
frame 11 key shift+N          # LS(7,2)
frame 12 key E                # error view: an exact renderer beside the current one
frame 14 key 6                # exact
frame 15 key D                # LS(7,3) again
frame 16 zoom 0.9
frame 17 move-object 0 0 0.05 0
frame 18 screenshot SHOTA     # waits for every build due
frame 19 key E
frame 20 key V
frame 21 key 1
frame 22 key G
frame 23 key N
frame 24 move-object 2 -0.1 0 0
frame 25 key shift+D
frame 26 resize 200 150
frame 27 key F
frame 28 key =
frame 29 key pageup
frame 30 key shift+N
frame 31 key 2
frame 32 orbit -25 3
frame 34 move-object 1 -0.1 0 0
frame 35 key D
frame 36 key 1
frame 38 screenshot SHOTB
frame 39 key shift+D
frame 40 orbit 15 0
SCRIPT
sed -i -e "s|SHOTA|$TMP/scene_tree_18.png|" -e "s|SHOTB|$TMP/scene_tree_38.png|" "$TMP/scene_tree.script"

cat > "$TMP/objects.script" <<'SCRIPT'
frame 1 move-object 1 0.1 0 0  # top level rebuilt on the frame loop's thread
frame 2 key shift+D            # the trees rebuilt on the worker: LS(7,2)
frame 3 move-object 1 0 0.05 0 # moves while it builds: placed as they stand when it is swapped in
frame 4 orbit 20 0
frame 5 key N                  # again while it builds: LS(8,2)
frame 6 move-object 0 -0.05 0 0
frame 7 key left
frame 8 key T
frame 10 screenshot SHOT
frame 11 key shift+N
frame 12 move-object 2 0 0 0.1
frame 13 key D
frame 14 move-object 1 -0.1 -0.05 0
frame 16 key G
frame 18 orbit -20 0
SCRIPT
sed -i "s|SHOT|$TMP/objects_10.png|" "$TMP/objects.script"

fail=0
session() { # NAME FRAMES ARGS...
  local name=$1 frames=$2; shift 2
  local t0=$SECONDS
  xvfb-run -a -s "-screen 0 1280x720x24" "$BIN" demo "$TMP/d3.glb" --size 160x120 --spp 1 --frames "$frames" \
    --no-vsync --no-accumulate --script "$TMP/$name.script" "$@" >"$TMP/$name.out" 2>"$TMP/$name.err"
  local rc=$?
  local reports
  reports=$(grep -c "^WARNING: ThreadSanitizer" "$TMP/$name.err")
  grep -E "swapped in|moved" "$TMP/$name.err" "$TMP/$name.out" | sed 's/^[^:]*://' | head -n 40
  if [ "$rc" -ne 0 ] || [ "$reports" -ne 0 ]; then
    echo "FAIL: $name: exit $rc (66: TSan reports, 3: validation messages), $reports ThreadSanitizer report(s):"
    cat "$TMP/$name.err"
    fail=1
  else
    # TSan sees only what overlaps: the session must have rendered frames while the worker built
    # (the summary's count) and swapped trees in, or it watched no concurrency at all.
    local swaps overlapped
    swaps=$(grep -c "swapped in" "$TMP/$name.err")
    overlapped=$(sed -n 's/.*frames while a tree build ran on the worker: \([0-9]*\),.*/\1/p' "$TMP/$name.out")
    if [ "$swaps" -lt 2 ] || [ "${overlapped:-0}" -lt 1 ]; then
      echo "FAIL: $name: $swaps trees swapped in, ${overlapped:-0} frames rendered while a build ran: no concurrency to watch"
      fail=1
      return
    fi
    echo "ok: $name: $frames frames, $swaps trees built on the worker and swapped in, ${overlapped} frames rendered meanwhile, no TSan report, no validation message ($((SECONDS - t0)) s)"
  fi
}
session scene_tree 44
session objects 20 --trees object --mode linespace
for f in scene_tree_18 scene_tree_38 objects_10; do
  [ -s "$TMP/$f.png" ] || { echo "FAIL: screenshot $f.png missing"; fail=1; }
done
exit $fail
