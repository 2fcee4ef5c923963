#!/usr/bin/env bash
# Per-object line spaces (--trees object, engine/accel/objects.h), on scenes that instance a real mesh
# (tests/instances.py writes them from ../shared/assets into the test's temporary directory):
#  1. memory: 64 instances of the dragon on a 4x4x4 lattice one extent apart, so that the scene-wide
#     LS(4,4) and the per-object LS(4,3) have leaves of the same width; the per-object pools must be
#     at most 1/20 of the scene-wide tree's (one tree shared by all instances), and every instance
#     placed in the top level;
#  2. a moving object: render moves object 1 out of the light's way (--move-object); the per-object
#     render must follow it, i.e. be far nearer the exact render of the moved scene than the exact
#     render of the unmoved one (exact mode is the independent oracle, on the scene-wide BVH);
#  3. refusals: per-object trees with a mode other than linespace, a move of an object that does
#     not exist.
set -u
BIN=${PN_BIN:?PN_BIN not set}
HERE=$(cd "$(dirname "$0")" && pwd)
MESH=${PN_ASSETS:-../shared/assets}/stanford-dragon-res4-11k.glb
[ -f "$MESH" ] || { echo "SKIP: $MESH missing"; exit 77; }
T=${PN_TEST_TMP:-/tmp}/objects
rm -rf "$T" && mkdir -p "$T"

# 1. Memory, same leaf width.
python3 "$HERE/instances.py" "$MESH" "$T/d64.glb" --grid 4,4,4 --spacing 1.0 || exit 1
"$BIN" build "$T/d64.glb" --no-ground --trees both --tree 4,4 --object-tree 4,3 --updates 3 --json > "$T/build.json" || exit 1
python3 - "$T/build.json" <<'PY' || exit 1
import json, sys
b = json.load(open(sys.argv[1]))
s = b["single"]
print("64 instances: per-object pools %.2f MB vs scene-wide %.2f MB (%.4fx), leaves %.6g vs %.6g; "
      "build %.0f ms vs %.0f ms; a move %.3f ms" % (b["pool_bytes"] / 1e6, s["pool_bytes"] / 1e6, b["pool_ratio"],
      b["leaf_min"], s["leaf"], b["build_ms"], s["build_ms"], b["update_ms"]))
assert b["objects"] == 64 and b["meshes"] == 1 and b["trees"] == 1 and b["placed"] == 64, b
# The comparison is fair only for equal leaves (both roots are the bounds made cubic, grown by a
# few ulps of slack: equal to float precision).
assert abs(b["leaf_min"] / s["leaf"] - 1) < 1e-5 and b["leaf_max"] == b["leaf_min"], b
assert b["pool_bytes"] * 20 <= s["pool_bytes"], "per-object pools above 1/20 of the scene-wide tree's"
assert b["updates"] == 3
PY

# 2. A moving object. Two dragons side by side under the light; object 1 goes far away along x.
python3 "$HERE/instances.py" "$MESH" "$T/d2.glb" --grid 2,1,1 --spacing 0.9 --scale 1:1.4,0.7,1.2 || exit 1
view=(--size 96x96 --spp 16 --filter none --camera-pos 0.12,0.35,0.45 --camera-target 0.12,0.02,0
      --light-pos 0.12,0.6,0.1 --light-normal 0,-1,0 --light-size 0.1,0.1)
away=(--move-object 1:100,0,0)
"$BIN" render "$T/d2.glb" "${view[@]}" --mode exact -o "$T/exact.exr" > /dev/null || exit 1
"$BIN" render "$T/d2.glb" "${view[@]}" "${away[@]}" --mode exact -o "$T/exact_moved.exr" > /dev/null || exit 1
"$BIN" render "$T/d2.glb" "${view[@]}" "${away[@]}" --trees object -o "$T/objects_moved.exr" > /dev/null || exit 1
"$BIN" render "$T/d2.glb" "${view[@]}" --trees object -o "$T/objects.exr" > /dev/null || exit 1
mae() { "$BIN" diff "$1" "$2" | sed -n 's/.*MAE \([0-9.e+-]*\).*/\1/p'; }
follow=$(mae "$T/exact_moved.exr" "$T/objects_moved.exr")
stale=$(mae "$T/exact.exr" "$T/objects_moved.exr")
still=$(mae "$T/exact.exr" "$T/objects.exr")
moved=$(mae "$T/exact.exr" "$T/exact_moved.exr")
echo "moving object 1: MAE of the per-object render against exact moved $follow, exact unmoved $stale;" \
     "unmoved per-object against exact unmoved $still; the move changes exact by $moved"
python3 - "$follow" "$stale" "$still" "$moved" <<'PY' || { echo "FAIL: the per-object render does not follow the move"; exit 1; }
import sys
follow, stale, still, moved = map(float, sys.argv[1:])
assert moved > 0.01, "the move must change the picture"  # else the check below proves nothing
# Following the move, its error is the method's bias; missing it, the error holds the whole shadow.
assert follow < 0.25 * stale
PY

# 3. Refusals, each with a message naming the problem.
out=$("$BIN" render "$T/d2.glb" --size 16x16 --trees object --mode exact -o "$T/bad.exr" 2>&1)
[ $? -ne 0 ] && grep -q "linespace" <<<"$out" && [ ! -e "$T/bad.exr" ] || { echo "FAIL: --trees object --mode exact: $out"; exit 1; }
out=$("$BIN" render "$T/d2.glb" --size 16x16 --move-object 2:1,0,0 -o "$T/bad.exr" 2>&1)
[ $? -ne 0 ] && grep -q "no object 2" <<<"$out" && [ ! -e "$T/bad.exr" ] || { echo "FAIL: --move-object 2: $out"; exit 1; }
# An object far from the origin: its leaves, carried into world space, must stay 16 float steps
# wide there (as the scene-wide tree's must), though they are wide enough in its own frame.
out=$("$BIN" render "$T/d2.glb" --size 16x16 --trees object --tree 6,3 --no-ground --move-object 0:100000,0,0 \
  -o "$T/bad.exr" 2>&1)
[ $? -ne 0 ] && grep -q "object 0: LS(6,3) leaves .* float steps" <<<"$out" && [ ! -e "$T/bad.exr" ] \
  || { echo "FAIL: object at 1e5 with LS(6,3): $out"; exit 1; }
echo "objects: ok"
