#!/usr/bin/env bash
# Animated glTF (scene/anim.h): a box turning, sliding and scaling over a ground under a moving
# point light, 3 s at 8 frames per second (tests/anim_gltf.py writes it and computes the poses).
#  - render --time k/8 equals, bit for bit, a render of the same file with the box's node given the
#    pose anim_gltf.py computes on the command line (--node-transform) and the light there (--light):
#    frames 0 (first keys), 5 and 13 (between translation keys, after the scale's step) and 24 (last
#    keys), in exact, linespace and linespace over per-object trees; and the frames differ from one
#    another (the animation moves);
#  - render --frames 0:24 --fps 8 -o seq.%04d.exr writes the 25 frames, each equal to --time's bit
#    for bit (exact: built again per frame; per-object trees: built once, their top level updated
#    per frame, which the per-frame lines report), and three shards (--shard K/3) write exactly the
#    same frames between them, each frame once;
#  - per-object trees model only what moves: the box gets one, the ground joins the rest;
#  - a time past the last key renders the last pose; a node no animation reaches, or one out of
#    range, cannot be given a transform;
#  - malformed animations (a NaN key, key times out of order, a channel whose sampler does not
#    exist): a clear message naming the file and the problem, exit 1, nothing written.
set -u
BIN=${PN_BIN:?PN_BIN not set}
HERE=$(dirname "$0")
T=${PN_TEST_TMP:-/tmp}/animation
rm -rf "$T" && mkdir -p "$T"
fail=0
python3 "$HERE/anim_gltf.py" "$T/anim.gltf" || exit 1
VIEW=(--no-ground --size 160x120 --camera-pos 0,4,6 --camera-target 0,0.5,0 --spp 4)

same() { # same A B WHAT
  if idiff -fail 0 -failpercent 0 -warn 0 "$1" "$2" >/dev/null 2>&1; then
    echo "ok: $3"
  else
    echo "FAIL: $3: the pictures differ"; idiff "$1" "$2" | tail -3; fail=1
  fi
}

MODES=("--mode exact" "--mode linespace" "--trees object")
for mi in 0 1 2; do
  read -r -a MODE <<< "${MODES[$mi]}"
  mode=$mi
  for k in 0 5 13 24; do
    t=$(python3 -c "print($k / 8)")
    read -r NODE LIGHT < <(python3 "$HERE/anim_gltf.py" --pose "$t")
    "$BIN" render "$T/anim.gltf" "${VIEW[@]}" "${MODE[@]}" --time "$t" -o "$T/time_${mode}_$k.exr" > /dev/null 2> "$T/err" ||
      { echo "FAIL: --time $t exited $?"; cat "$T/err"; fail=1; continue; }
    "$BIN" render "$T/anim.gltf" "${VIEW[@]}" "${MODE[@]}" --node-transform "$NODE" --light "$LIGHT" \
      -o "$T/static_${mode}_$k.exr" > /dev/null 2> "$T/err" || { echo "FAIL: the static render exited $?"; cat "$T/err"; fail=1; continue; }
    same "$T/time_${mode}_$k.exr" "$T/static_${mode}_$k.exr" "${MODE[*]} frame $k: --time $t equals --node-transform $NODE --light $LIGHT"
  done
  # The animation moves: every frame differs from the others.
  for pair in "0 5" "5 13" "13 24"; do
    set -- $pair
    if idiff -fail 0 -failpercent 0 -warn 0 "$T/time_${mode}_$1.exr" "$T/time_${mode}_$2.exr" >/dev/null 2>&1; then
      echo "FAIL: ${MODE[*]} frames $1 and $2 are the same picture"; fail=1
    fi
  done
done

# Model only what moves: the box, which the animation moves, gets a per-object tree; the ground
# stands still and joins the triangles of no object (here all culled: nothing under it).
"$BIN" render "$T/anim.gltf" "${VIEW[@]}" --trees object --time 1 -o "$T/objects.exr" > "$T/objects.txt" 2>&1
grep -q "per-object trees: 1 for 1 objects.*2 triangles of no object left out" "$T/objects.txt" &&
  echo "ok: a per-object tree for the moving box alone, the ground with the rest" ||
  { echo "FAIL: per-object trees:"; cat "$T/objects.txt"; fail=1; }

# Past the last key: the last pose.
"$BIN" render "$T/anim.gltf" "${VIEW[@]}" --time 10 -o "$T/late.exr" > /dev/null 2>&1 || { echo "FAIL: --time 10"; fail=1; }
same "$T/late.exr" "$T/time_0_24.exr" "a time past the last key renders the last pose"

# Sequences: every frame as --time renders it; per-object trees built once.
for mi in 0 2; do
  read -r -a MODE <<< "${MODES[$mi]}"
  mkdir -p "$T/seq$mi"
  "$BIN" render "$T/anim.gltf" "${VIEW[@]}" "${MODE[@]}" --frames 0:24 --fps 8 -o "$T/seq$mi/f.%04d.exr" \
    > "$T/seq$mi.txt" 2> "$T/seq$mi.err" || { echo "FAIL: --frames (${MODE[*]}) exited $?"; cat "$T/seq$mi.err"; fail=1; continue; }
  n=$(ls "$T/seq$mi" | wc -l)
  [ "$n" = 25 ] || { echo "FAIL: ${MODE[*]}: $n frames written, expected 25"; fail=1; }
  for k in 0 5 13 24; do
    same "$T/seq$mi/f.$(printf %04d $k).exr" "$T/time_${mi}_$k.exr" "${MODE[*]} sequence frame $k equals --time"
  done
  grep -q "25/25 frames" "$T/seq$mi.err" || { echo "FAIL: no progress line for the last frame"; fail=1; }
done
# Per-object trees: built for the first frame only, then the top level follows the box, its cost
# on every frame's line.
grep -q "the shadow structure built 1 time" "$T/seq2.txt" || { echo "FAIL: per-object trees built more than once:"; tail -2 "$T/seq2.txt"; fail=1; }
ups=$(grep -c "top level updated in [0-9.]* ms" "$T/seq2.txt")
[ "$ups" = 24 ] && echo "ok: per-object trees built once, the top level updated on 24 frames" ||
  { echo "FAIL: $ups frames report a top-level update, expected 24"; fail=1; }
grep -q "the shadow structure built 25 times" "$T/seq0.txt" || { echo "FAIL: exact's BVH not built per frame"; fail=1; }
# Shards: three jobs write the same 25 frames between them, each once.
mkdir -p "$T/shards"
for k in 1 2 3; do
  "$BIN" render "$T/anim.gltf" "${VIEW[@]}" --trees object --frames 0:24 --fps 8 --shard "$k/3" \
    -o "$T/shards/f.%04d.exr" > "$T/shard$k.txt" 2>&1 || { echo "FAIL: shard $k/3 exited $?"; fail=1; }
done
n=$(ls "$T/shards" | wc -l)
written=$(grep -h -o "shards/f\.[0-9]*\.exr" "$T"/shard?.txt | sort | uniq -d | wc -l)
[ "$n" = 25 ] && [ "$written" = 0 ] && echo "ok: three shards wrote the 25 frames, none twice" ||
  { echo "FAIL: the shards wrote $n frames, $written of them twice"; fail=1; }
for k in 0 1 2 7 13 24; do
  same "$T/shards/f.$(printf %04d $k).exr" "$T/seq2/f.$(printf %04d $k).exr" "shard frame $k equals the one run's"
done

expect() { # expect RC PATTERN ARGS...: the exit code, the message, and no output file
  local want=$1 pattern=$2; shift 2
  rm -f "$T/bad.exr"
  "$BIN" render "$@" -o "$T/bad.exr" > /dev/null 2> "$T/err"; local rc=$?
  if [ "$rc" != "$want" ] || ! grep -qE -- "$pattern" "$T/err"; then
    echo "FAIL: render $* exited $rc (expected $want), stderr:"; sed 's/^/    /' "$T/err"; fail=1
  elif ls "$T"/bad.exr "$T"/.bad.exr.* > /dev/null 2>&1; then
    echo "FAIL: render $* left an output file"; fail=1
  else
    echo "ok: exit $rc, /$pattern/"
  fi
}
expect 2 "node 0 cannot be given a transform: no animation reaches it" "$T/anim.gltf" --node-transform 0:0,0,0:0,0,0,1:1,1,1
expect 2 "node 7 cannot be given a transform" "$T/anim.gltf" --node-transform 7:0,0,0:0,0,0,1:1,1,1
expect 2 "--node-transform rotation: a quaternion must not be zero" "$T/anim.gltf" --node-transform 1:0,0,0:0,0,0,0:1,1,1
expect 2 "--node-transform scale: expected 3" "$T/anim.gltf" --node-transform 1:0,0,0:0,0,0,1:1,1
expect 2 "--time: expected seconds" "$T/anim.gltf" --time nan
expect 2 "--shard 4/3: shard K of N needs 1 <= K <= N" "$T/anim.gltf" --frames 0:3 --shard 4/3
expect 2 "--shard 0/0: shard K of N needs 1 <= K <= N" "$T/anim.gltf" --frames 0:3 --shard 0/0
expect 2 "--shard: shares out the frames of --frames" "$T/anim.gltf" --shard 1/2
expect 2 "--frames: expected FIRST:LAST" "$T/anim.gltf" --frames 5:2
expect 2 "with --frames, the name takes the frame number" "$T/anim.gltf" --frames 0:2
for b in nan order sampler; do
  python3 "$HERE/anim_gltf.py" "$T/$b.gltf" --break "$b" || exit 1
done
expect 1 "$T/nan.gltf: animation 0 channel 0: sampler 0: value 2 is not finite" "$T/nan.gltf" --time 1
expect 1 "$T/order.gltf: animation 0 channel 1: sampler 1: key times are not strictly increasing" "$T/order.gltf"
expect 1 "$T/sampler.gltf: animation 0 channel 1: sampler 9 does not exist" "$T/sampler.gltf"
[ $fail = 0 ] && echo "animation: ok"
exit $fail
