#!/usr/bin/env bash
# Animated glTF (scene/anim.h): a box turning, sliding and scaling over a ground under a moving
# point light, 3 s at 8 frames per second (tests/anim_gltf.py writes it and computes the poses).
#  - render --time k/8 equals, bit for bit, a render of the same file with the box's node given the
#    pose anim_gltf.py computes on the command line (--node-transform) and the light there (--light):
#    frames 0 (first keys), 5 and 13 (between translation keys, after the scale's step) and 24 (last
#    keys), in exact and linespace; and the frames differ from one another (the animation moves);
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

for mode in exact linespace; do
  for k in 0 5 13 24; do
    t=$(python3 -c "print($k / 8)")
    read -r NODE LIGHT < <(python3 "$HERE/anim_gltf.py" --pose "$t")
    "$BIN" render "$T/anim.gltf" "${VIEW[@]}" --mode "$mode" --time "$t" -o "$T/time_${mode}_$k.exr" > /dev/null 2> "$T/err" ||
      { echo "FAIL: --time $t exited $?"; cat "$T/err"; fail=1; continue; }
    "$BIN" render "$T/anim.gltf" "${VIEW[@]}" --mode "$mode" --node-transform "$NODE" --light "$LIGHT" \
      -o "$T/static_${mode}_$k.exr" > /dev/null 2> "$T/err" || { echo "FAIL: the static render exited $?"; cat "$T/err"; fail=1; continue; }
    same "$T/time_${mode}_$k.exr" "$T/static_${mode}_$k.exr" "$mode frame $k: --time $t equals --node-transform $NODE --light $LIGHT"
  done
  # The animation moves: every frame differs from the others.
  for pair in "0 5" "5 13" "13 24"; do
    set -- $pair
    if idiff -fail 0 -failpercent 0 -warn 0 "$T/time_${mode}_$1.exr" "$T/time_${mode}_$2.exr" >/dev/null 2>&1; then
      echo "FAIL: $mode frames $1 and $2 are the same picture"; fail=1
    fi
  done
done

# Past the last key: the last pose.
"$BIN" render "$T/anim.gltf" "${VIEW[@]}" --time 10 -o "$T/late.exr" > /dev/null 2>&1 || { echo "FAIL: --time 10"; fail=1; }
same "$T/late.exr" "$T/time_exact_24.exr" "a time past the last key renders the last pose"

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
for b in nan order sampler; do
  python3 "$HERE/anim_gltf.py" "$T/$b.gltf" --break "$b" || exit 1
done
expect 1 "$T/nan.gltf: animation 0 channel 0: sampler 0: value 2 is not finite" "$T/nan.gltf" --time 1
expect 1 "$T/order.gltf: animation 0 channel 1: sampler 1: key times are not strictly increasing" "$T/order.gltf"
expect 1 "$T/sampler.gltf: animation 0 channel 1: sampler 9 does not exist" "$T/sampler.gltf"
[ $fail = 0 ] && echo "animation: ok"
exit $fail
