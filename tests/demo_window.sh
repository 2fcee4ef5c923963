#!/usr/bin/env bash
# penumbra demo in a real window (Xvfb, lavapipe's X11 swapchain, validation on): 30 frames with a
# scripted camera orbit, a mode switch, views, an N-tree rebuild in the background and one window
# resize. It must exit 0: any validation message (swapchain recreation included) makes it exit 3.
set -u
BIN=${PN_BIN:?PN_BIN not set}
TMP=${PN_TEST_TMP:-/tmp}/demo_window
rm -rf "$TMP" && mkdir -p "$TMP"
command -v xvfb-run >/dev/null || { echo "SKIP: xvfb-run not installed (ci/deps.sh installs xvfb)"; exit 77; }

cat > "$TMP/script.txt" <<'SCRIPT'
# orbit around the scene, 12 degrees a frame, rising a little
frame 1 orbit 12 0
frame 2 orbit 12 2
frame 3 orbit 12 2
frame 4 orbit 12 0
frame 5 orbit 12 -2
frame 6 zoom 0.9
frame 7 pan 0.05 -0.02
frame 8 key M            # linespace -> ls-leaf
frame 10 key N           # tree LS(7,3) -> LS(8,3), built on a worker thread
frame 12 resize 400 300
frame 14 key 6           # exact
frame 16 key E           # error against exact (a second renderer)
frame 18 key C           # N-tree cells overlay
frame 20 key V           # visibility
frame 22 key 1           # back to linespace
frame 24 orbit -30 5
frame 29 screenshot SHOT
SCRIPT
sed -i "s|SHOT|$TMP/frame29.png|" "$TMP/script.txt"

out=$(xvfb-run -a -s "-screen 0 1280x720x24" \
  "$BIN" demo --size 320x240 --spp 4 --frames 30 --script "$TMP/script.txt" --screenshot "$TMP/last.png" 2>"$TMP/stderr")
rc=$?
cat "$TMP/stderr"
echo "$out"
fail=0
[ "$rc" -eq 0 ] || { echo "FAIL: penumbra demo exited $rc (3: validation messages)"; fail=1; }
grep -q "validation" "$TMP/stderr" && { echo "FAIL: validation messages on stderr"; fail=1; }
grep -q "^demo: 30 frames, the last 400x300" <<<"$out" || { echo "FAIL: expected 30 frames ending at 400x300"; fail=1; }
# Both PNGs exist at the resized size (IHDR width and height, big-endian, bytes 16..23).
for f in frame29.png last.png; do
  size=$(od -An -tu1 -j16 -N8 "$TMP/$f" 2>/dev/null | tr -s ' ')
  [ "$size" = " 0 0 1 144 0 0 1 44" ] || { echo "FAIL: $f missing or not 400x300 (IHDR:$size)"; fail=1; }
done
[ $fail -eq 0 ] && echo "ok: 30 frames, orbit, mode switch, tree rebuild, resize, no validation message"
exit $fail
