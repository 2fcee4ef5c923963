#!/usr/bin/env bash
# render --frames --temporal (the temporal history, engine/gpu/history_pass.h) from the command
# line, on builtin:default at 96x54 (a still scene: every frame adds to the history):
#  - the EXR carries shadow.history, the samples behind each pixel's V, and it grows: frame 7's
#    mean is more than 7 times frame 0's (oiiotool's statistics);
#  - the error against a converged reference (exact, 1024 samples, another seed) falls: frame 7
#    under half of frame 0's;
#  - determinism: the sequence twice gives the same frames bit for bit, and so do two shards
#    (--shard K/2: the second renders the frames before its first for their history, unwritten);
#    with --history 2 the second shard renders 2 frames before its own, and its frames differ from
#    the whole sequence's only by what the exponential window keeps of older frames: MAE under
#    0.002 (printed);
#  - refusals: --temporal or --history without --frames, --history without --temporal, --history
#    0, each a clear message and exit 2, nothing written.
set -u
BIN=${PN_BIN:?PN_BIN not set}
T=${PN_TEST_TMP:-/tmp}/temporal
rm -rf "$T" && mkdir -p "$T"
fail=0
VIEW=(builtin:default --size 96x54 --spp 4)

"$BIN" render "${VIEW[@]}" --frames 0:7 --temporal -o "$T/a.%02d.exr" >"$T/a.log" 2>&1 ||
  { echo "FAIL: the temporal sequence"; tail -5 "$T/a.log"; exit 1; }
"$BIN" render "${VIEW[@]}" --frames 0:7 --temporal -o "$T/b.%02d.exr" >/dev/null 2>&1 || { echo "FAIL: again"; exit 1; }
"$BIN" render builtin:default --size 96x54 --spp 1024 --filter none --seed 99 -o "$T/ref.exr" >/dev/null 2>&1 ||
  { echo "FAIL: the reference"; exit 1; }

mean_history() { # the mean of shadow.history over the image (the background holds 0), or "none"
  oiiotool "$1" --ch shadow.history --printstats 2>/dev/null | awk '/Stats Avg/ {print $3; found=1} END {if (!found) print "none"}'
}
h0=$(mean_history "$T/a.00.exr"); h7=$(mean_history "$T/a.07.exr")
echo "shadow.history mean: frame 0 $h0, frame 7 $h7"
if [ "$h0" = none ] || ! python3 -c "import sys; sys.exit(0 if $h7 > 7 * $h0 else 1)"; then
  echo "FAIL: shadow.history missing or not growing"; fail=1
fi
mae() { "$BIN" diff "$1" "$2" --json 2>/dev/null | python3 -c 'import json,sys; print(json.load(sys.stdin)["mae"])'; }
e0=$(mae "$T/a.00.exr" "$T/ref.exr"); e7=$(mae "$T/a.07.exr" "$T/ref.exr")
echo "MAE against the reference: frame 0 $e0, frame 7 $e7"
python3 -c "import sys; sys.exit(0 if $e7 < 0.5 * $e0 else 1)" || { echo "FAIL: the error does not fall"; fail=1; }

same() { # same A B WHAT
  if idiff -fail 0 -failpercent 0 -warn 0 "$1" "$2" >/dev/null 2>&1; then :; else
    echo "FAIL: $3: $1 and $2 differ"; fail=1
  fi
}
for f in 00 03 07; do same "$T/a.$f.exr" "$T/b.$f.exr" "the sequence twice, frame $f"; done
for k in 1 2; do
  "$BIN" render "${VIEW[@]}" --frames 0:7 --temporal --shard $k/2 -o "$T/s.%02d.exr" >"$T/s$k.log" 2>&1 ||
    { echo "FAIL: shard $k/2"; tail -3 "$T/s$k.log"; fail=1; }
done
grep -q "rendered for the history" "$T/s2.log" || { echo "FAIL: shard 2/2 rendered no frame before its own"; fail=1; }
for f in 00 01 02 03 04 05 06 07; do same "$T/a.$f.exr" "$T/s.$f.exr" "shard against the whole, frame $f"; done
"$BIN" render "${VIEW[@]}" --frames 0:7 --temporal --history 2 -o "$T/h.%02d.exr" >/dev/null 2>&1 || { echo "FAIL: --history 2"; fail=1; }
"$BIN" render "${VIEW[@]}" --frames 0:7 --temporal --history 2 --shard 2/2 -o "$T/hs.%02d.exr" >/dev/null 2>&1 ||
  { echo "FAIL: --history 2 --shard 2/2"; fail=1; }
d=$(mae "$T/hs.04.exr" "$T/h.04.exr")
echo "--history 2, shard 2/2 against the whole sequence, frame 4: MAE $d"
python3 -c "import sys; sys.exit(0 if $d < 0.002 else 1)" || { echo "FAIL: the shard's frame 4 is too far"; fail=1; }

refuse() { # refuse WHAT ARGS...
  local what=$1; shift
  rm -f "$T/r.exr" "$T"/r.*.exr
  "$BIN" render "${VIEW[@]}" "$@" >"$T/r.log" 2>&1
  local rc=$?
  if [ $rc -ne 2 ] || ! grep -q -- "$what" "$T/r.log" || ls "$T"/r.*exr >/dev/null 2>&1; then
    echo "FAIL: $* should be refused naming $what (exit $rc):"; cat "$T/r.log"; fail=1
  fi
}
refuse "--temporal" --temporal -o "$T/r.exr"
refuse "--history" --history 4 -o "$T/r.exr"
refuse "--history" --frames 0:1 --history 4 -o "$T/r.%02d.exr"
refuse "--history" --frames 0:1 --temporal --history 0 -o "$T/r.%02d.exr"
[ $fail -eq 0 ] && echo "all temporal checks passed"
exit $fail
