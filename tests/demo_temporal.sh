#!/usr/bin/env bash
# penumbra demo's accumulation is the renderer's temporal history (cmd_demo.c set_history), the
# same mechanism as render --temporal (issue 63):
#  - a still view: the demo's frame 5 (saved with P) has render --frames 0:5 --temporal's frame 5
#    V and history, bit for bit (same camera, light, seed, spp; the history's frames numbered
#    from 0 in both; the demo's --accumulate-max is render's --history);
#  - an orbit keeps the history: after 6 frames of 2 degrees each the history's mean samples a
#    pixel are over 3 times the first frame's (only newly uncovered surface starts again);
#  - a light move (the arrow key) drops the light's history: the frame after it holds at most one
#    frame's samples in every pixel;
#  - an object moved with the scene-wide tree (exact mode: the BVH rebuilt on the worker thread)
#    drops the history where its bounds, before and after, reach the pyramid to the light, once
#    the rebuild is swapped in, and keeps it elsewhere: some pixels back at one frame's samples,
#    most still above.
set -u
BIN=${PN_BIN:?PN_BIN not set}
T=${PN_TEST_TMP:-/tmp}/demo_temporal
rm -rf "$T" && mkdir -p "$T"
command -v xvfb-run >/dev/null || { echo "SKIP: xvfb-run not installed (ci/deps.sh installs xvfb)"; exit 77; }
fail=0
VIEW=(--size 160x90 --spp 4 --seed 5 --mode exact)
demo() { # demo NAME SCRIPT-LINES [ARGS...]: runs the demo with the script, saves to $T/NAME-NNNN.exr
  local name=$1 lines=$2; shift 2
  printf '%b' "$lines" > "$T/$name.script"
  xvfb-run -a -s "-screen 0 1280x720x24" "$BIN" demo "$@" --script "$T/$name.script" --save-prefix "$T/$name" \
    >"$T/$name.log" 2>&1 || { echo "FAIL: demo $name exited $?"; tail -5 "$T/$name.log"; fail=1; }
}
mean_history() { # the mean of shadow.history over the image, or "none"
  oiiotool "$1" --ch shadow.history --printstats 2>/dev/null | awk '/Stats Avg/ {print $3; found=1} END {if (!found) print "none"}'
}
# Pixels (with geometry) whose history holds more than LIMIT samples, all with geometry, and those
# of the ground (the lowest P.Y, to a thousandth) at most LIMIT: the ground never moves, so its
# history drops only where a moved object's bounds reach its pyramid to the light.
count_above() { # FILE LIMIT
  oiiotool "$1" --ch A,P.Y,shadow.history -o "$T/three.exr" >/dev/null 2>&1 && oiiotool --dumpdata "$T/three.exr" 2>/dev/null |
    awk -v lim="$2" '/Pixel/ && $4 > 0 { n++; y[n] = $5; h[n] = $6; if (n == 1 || $5 < lo) lo = $5 }
      END { for (i = 1; i <= n; i++) { k += h[i] > lim; g += h[i] <= lim && y[i] - lo <= 1e-3 * (lo < 0 ? -lo : lo) + 1e-6 }
            printf "%d %d %d\n", k, n, g }'
}

# 1. A still view: the same frames as render --temporal.
demo still 'frame 5 key P\n' "${VIEW[@]}" --frames 6
"$BIN" render builtin:default "${VIEW[@]}" --frames 0:5 --temporal --history 256 -o "$T/r.%02d.exr" >"$T/r.log" 2>&1 ||
  { echo "FAIL: render --temporal"; tail -3 "$T/r.log"; fail=1; }
for ch in shadow.V shadow.history; do
  d=$("$BIN" diff "$T/still-0001.exr" "$T/r.05.exr" --channel $ch --json 2>/dev/null |
      python3 -c 'import json,sys; print(json.load(sys.stdin)["max"])' 2>/dev/null || echo missing)
  echo "still view, frame 5: demo against render --temporal, $ch max difference $d"
  [ "$d" = 0.0 ] || [ "$d" = 0 ] || { echo "FAIL: the demo's still frames are not render --temporal's ($ch)"; fail=1; }
done

# 2. An orbit keeps the history; 3. a light move drops it.
demo orbit 'frame 0 key P\nframe 1 orbit 2 0\nframe 2 orbit 2 0\nframe 3 orbit 2 0\nframe 4 orbit 2 0\nframe 5 orbit 2 0\nframe 5 key P\nframe 6 key left\nframe 6 key P\n' \
  "${VIEW[@]}" --frames 7
h0=$(mean_history "$T/orbit-0001.exr"); h5=$(mean_history "$T/orbit-0002.exr")
echo "orbit: history mean samples a pixel, frame 0 $h0, frame 5 (after 5 steps of 2 degrees) $h5"
if [ "$h0" = none ] || ! python3 -c "import sys; sys.exit(0 if $h5 > 3 * $h0 else 1)"; then
  echo "FAIL: the orbit did not keep the history"; fail=1
fi
read -r above total ground < <(count_above "$T/orbit-0003.exr" 4)
echo "light moved: $above of $total pixels hold more than one frame's 4 samples"
[ "$total" -gt 0 ] && [ "$above" -eq 0 ] || { echo "FAIL: the light's move did not drop its history"; fail=1; }

# 4. An object moved: the history dropped where its bounds reach, kept elsewhere. The default
# scene's objects are generated, not glTF nodes: a scene with objects from the assets.
MESH=${PN_ASSETS:-../shared/assets}/stanford-dragon-res4-11k.glb
HERE=$(cd "$(dirname "$0")" && pwd)
if [ ! -f "$MESH" ]; then
  echo "SKIP (object move): $MESH missing"
else
  python3 "$HERE/instances.py" "$MESH" "$T/d3.glb" --grid 3,1,1 --spacing 2.0 >/dev/null || { echo "FAIL: instances.py"; exit 1; }
  demo move 'frame 4 key P\nframe 5 move-object 1 0.15 0 0\nframe 6 screenshot '"$T"'/move.png\nframe 6 key P\n' \
    "$T/d3.glb" --size 160x90 --spp 4 --seed 5 --mode exact --camera-pos 0.4,0.55,0.9 --camera-target 0.4,0.08,0 \
    --light 0.3,0.7,0.3:-0.1,-1,-0.3:0,0,1:0.15,0.15:40 --frames 7
  read -r before total ground0 < <(count_above "$T/move-0001.exr" 4)
  read -r after total2 ground < <(count_above "$T/move-0002.exr" 4)
  echo "object moved: pixels above one frame's samples, $before of $total before, $after of $total2 after the rebuild;" \
    "ground pixels (unmoved) back at one frame's: $ground0 before, $ground after"
  if ! python3 -c "import sys; sys.exit(0 if $total > 0 and $before > 0.9 * $total and 0.3 * $before < $after < $before else 1)"; then
    echo "FAIL: the move should drop some pixels' history and keep most"; fail=1
  fi
  [ "$ground" -gt 0 ] || { echo "FAIL: no pixel of the unmoved ground dropped its history: the moved bounds were not applied"; fail=1; }
fi
[ $fail -eq 0 ] && echo "demo_temporal: ok"
exit $fail
