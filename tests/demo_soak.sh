#!/usr/bin/env bash
# A long demo run: 5000 frames at 96x72, 1 spp, validation on, under Xvfb, with memory sampled
# every 50 frames (penumbra demo --stats). The script repeats one 500-frame cycle ten times: the
# camera orbits; an object moves out and back, the light moves and is reset (R), the mode, the
# view (error: a second renderer) and the tree (N, D; pressed again while the worker builds)
# switch and switch back. Object moves and light changes rebuild the scene-wide tree on the worker
# while frames render.
#
# Asserted:
# - exit 0 and no validation message;
# - device memory: after warm-up (the first two cycles, 20% of the frames), at each sample the
#   engine's tally of live VkDeviceMemory (bytes and allocations) equals the tally at the same
#   point of every other cycle. The state there is the same in each cycle: the samples fall on
#   frames where a screenshot first waited for the tree builds due (settle_tree), the moves are
#   exact in float (below) and R restores the light bit for bit; the configuration and the
#   tree's pool bytes are checked equal too, so a mismatch names what changed. A leaked or
#   doubled buffer, image or pool shows as a difference of at least one allocation.
# - resident memory and malloc'd bytes (the demo hands malloc's free pages back before each sample,
#   demo_stats.c: without that, where long-lived allocations fell moved the figure by 16-23 MiB
#   once the device kept its pipelines): growth from the first cycle after warm-up to the last,
#   at the same points of the cycle (the median over the points for the resident figure, which
#   moves by +-7 MiB at one point; every point for the malloc'd bytes), under 4 MiB plus 1 MiB per
#   cycle after warm-up (12 MiB). The 4 MiB: pages the allocator, lavapipe and LLVM touch once and keep
#   (without the layer, the malloc'd bytes of these events converge: +40, +38, +29, +14 KiB per
#   300 frames of tree switches), and the resident figure's spread at one point of the cycle
#   (+-3 MiB). The 1 MiB per cycle: the validation layer's own growth, about 40 KiB of malloc'd
#   bytes per renderer or tree it sees created and destroyed, 0.7 MiB per cycle (linear with the
#   layer, converging without it; +3 KiB over 2000 frames with it and no events). What it catches: in
#   the 4000 frames after warm-up the demo renders 4000 frames and swaps in 64 trees and 100
#   renderer sets; a leak of 3 KiB a frame, 200 KiB a tree (a tree's CPU copy is >= 0.5 MB) or
#   100 KiB a renderer set (a 96x72 frame's images are 0.5 MB) would exceed the bound.
#   glibc's per-thread arenas are limited to one (MALLOC_ARENA_MAX=1): each tree build runs on
#   new threads, and with an arena each the resident figure swings +-10-15 MiB between the same
#   points of two cycles depending on which arenas the builds landed in (the malloc'd bytes are
#   the same either way).
# The driver's VK_EXT_memory_budget figure is printed, not asserted (lavapipe's figure is the whole
# machine's memory in use, other processes' included).
set -u
BIN=${PN_BIN:?PN_BIN not set}
case "${PN_SANITIZER:-}" in
  address | thread)
    echo "SKIP: the $PN_SANITIZER sanitizer's allocator holds freed memory back: its resident memory says nothing here"
    exit 77 ;;
esac
command -v xvfb-run >/dev/null || { echo "SKIP: xvfb-run not installed (ci/deps.sh installs xvfb)"; exit 77; }
MESH=${PN_ASSETS:-../shared/assets}/stanford-dragon-res4-11k.glb
[ -f "$MESH" ] || { echo "SKIP: $MESH missing"; exit 77; }
TMP=${PN_TEST_TMP:-/tmp}/demo_soak
rm -rf "$TMP" && mkdir -p "$TMP"
HERE=$(cd "$(dirname "$0")" && pwd)
CYCLES=10 PERIOD=500 EVERY=50 WARMUP_CYCLES=2
RSS_BOUND_MIB=$((4 + 1 * (CYCLES - WARMUP_CYCLES)))
FRAMES=$((CYCLES * PERIOD))

# Three dragons whose world coordinates are multiples of 2^-14 below 2 in magnitude (positions
# rounded to that grid, translations multiples of 1/2): moving one by 1/16 and back is exact in
# float, so each cycle rebuilds the very same trees.
python3 - "$HERE" "$MESH" "$TMP/d3q.glb" <<'PY' || exit 1
import struct, sys
sys.path.insert(0, sys.argv[1])
from instances import read_glb, write_glb
doc, data = read_glb(sys.argv[2])
data = bytearray(data)
q = 2.0 ** -14
acc = doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"]]
view = doc["bufferViews"][acc["bufferView"]]
base, stride = view.get("byteOffset", 0) + acc.get("byteOffset", 0), view.get("byteStride", 12)
lo, hi = [1e30] * 3, [-1e30] * 3
for i in range(acc["count"]):
    p = [round(v / q) * q for v in struct.unpack_from("<3f", data, base + i * stride)]
    struct.pack_into("<3f", data, base + i * stride, *p)
    lo, hi = [min(a, b) for a, b in zip(lo, p)], [max(a, b) for a, b in zip(hi, p)]
acc["min"], acc["max"] = lo, hi
doc["meshes"] = doc["meshes"][:1]
doc["nodes"] = [{"mesh": 0, "translation": [0.5 * i, 0.0, 0.0]} for i in range(3)]
doc["scenes"], doc["scene"] = [{"nodes": [0, 1, 2]}], 0
write_glb(sys.argv[3], doc, bytes(data))
PY

# One cycle's events at their offsets; a screenshot (which waits for the tree builds due) on the
# frame before each sample, which is taken after frames EVERY-1, 2*EVERY-1, ...
{
  for ((c = 0; c < CYCLES; c++)); do
    b=$((c * PERIOD))
    for ((k = 0; k < PERIOD; k += 10)); do echo "frame $((b + k + 5)) orbit 7.2 0.5"; done
    cat <<EOF | while read -r off rest; do echo "frame $((b + off)) $rest"; done
20 move-object 1 0.0625 0 0
60 key left
110 key M
140 key N
145 key shift+D
210 key E
260 move-object 1 -0.0625 0 0
290 key E
310 key shift+M
340 key shift+N
345 key D
410 key R
455 key V
470 key V
EOF
    for ((k = EVERY - 1; k < PERIOD; k += EVERY)); do echo "frame $((b + k)) screenshot $TMP/shot.png"; done
  done
} > "$TMP/soak.script"

t0=$SECONDS
MALLOC_ARENA_MAX=1 xvfb-run -a -s "-screen 0 1280x720x24" "$BIN" demo "$TMP/d3q.glb" --size 96x72 --spp 1 --frames "$FRAMES" \
  --no-vsync --no-accumulate --script "$TMP/soak.script" --stats "$TMP/stats.tsv" --stats-every "$EVERY" \
  >"$TMP/stdout" 2>"$TMP/stderr"
rc=$?
seconds=$((SECONDS - t0))
grep -v "swapped in\|moved in\|^penumbra: saved" "$TMP/stderr" | head -n 20
grep -E "^demo:|memory after|medians|while a tree" "$TMP/stdout"
fail=0
[ "$rc" -eq 0 ] || { echo "FAIL: penumbra demo exited $rc (3: validation messages)"; fail=1; }
grep -q "validation" "$TMP/stderr" && { echo "FAIL: validation messages on stderr"; fail=1; }
grep -q "^demo: $FRAMES frames" "$TMP/stdout" || { echo "FAIL: expected $FRAMES frames"; fail=1; }
echo "trees swapped in: $(grep -c "swapped in" "$TMP/stderr"); runtime ${seconds} s"

python3 - "$TMP/stats.tsv" "$PERIOD" "$((WARMUP_CYCLES * PERIOD))" "$RSS_BOUND_MIB" <<'PY' || fail=1
import sys
path, period, warmup, bound = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4])
lines = [l.rstrip("\n").split("\t") for l in open(path) if not l.startswith("#")]
head, rows = lines[0], [dict(zip(lines[0], l)) for l in lines[1:]]
mib = lambda b: int(b) / 1048576
bad = 0
if not rows or int(rows[-1]["frame"]) < warmup + period:
    sys.exit(f"FAIL: {len(rows)} samples in {path}, not enough to compare cycles")
# Device memory: the same at each point of every cycle after warm-up.
by_phase = {}
for r in rows:
    f = int(r["frame"])
    if f > warmup:
        by_phase.setdefault(f % period, []).append(r)
compared = 0
for phase, rs in sorted(by_phase.items()):
    first = rs[0]
    for r in rs[1:]:
        compared += 1
        for key in ("config", "pools", "device", "allocations"):
            if r[key] != first[key]:
                bad += 1
                print(f"FAIL: {key} at frame {r['frame']} is {r[key]}, at frame {first['frame']} (same point of an "
                      f"earlier cycle) {first[key]}")
print(f"device memory: {compared} samples after warm-up compared with the same point of the first cycle after it, "
      f"{len(by_phase)} points per cycle")
end_warm = max((r for r in rows if int(r["frame"]) <= warmup), key=lambda r: int(r["frame"]))
last = rows[-1]
dev = [mib(r["device"]) for r in rows if int(r["frame"]) > warmup]
print(f"device memory at frame {end_warm['frame']} (end of warm-up): {mib(end_warm['device']):.3f} MiB in "
      f"{end_warm['allocations']} allocations; at frame {last['frame']}: {mib(last['device']):.3f} MiB in "
      f"{last['allocations']}; after warm-up between {min(dev):.3f} and {max(dev):.3f} MiB by configuration")
if int(rows[0]["malloc"]) >= 0:
    print(f"malloc'd bytes: {mib(end_warm['malloc']):.2f} MiB at frame {end_warm['frame']}, "
          f"{mib(last['malloc']):.2f} MiB at frame {last['frame']}: {mib(last['malloc']) - mib(end_warm['malloc']):+.2f} MiB")
heap = [int(r["heap_usage"]) for r in rows]
if heap[0] >= 0:
    print(f"driver heap usage (VK_EXT_memory_budget, the machine's, not asserted): {mib(heap[0]):.0f} MiB at the first "
          f"sample, {mib(heap[-1]):.0f} MiB at the last")
# Growth after warm-up, point by point of the cycle: the last cycle's sample against the first
# cycle's after warm-up at the same point. The resident figure at one point moves by up to +-7 MiB
# from cycle to cycle (measured: 0.4 to 13.7 MiB over the ten points of one run, whose malloc'd
# bytes grew 4.5 to 4.8 at every one of them; a run failed on one point's 12.1): it is compared
# by its median over the points. The malloc'd bytes, which do not move so, must stay within the
# bound at every point.
import statistics
rss_growth = [mib(rs[-1]["rss"]) - mib(rs[0]["rss"]) for rs in by_phase.values()]
growth = statistics.median(rss_growth)
rss_after = [mib(r["rss"]) for r in rows if int(r["frame"]) >= int(end_warm["frame"])]
print(f"resident memory: {mib(rows[0]['rss']):.1f} MiB at frame {rows[0]['frame']}, {mib(end_warm['rss']):.1f} MiB at "
      f"frame {end_warm['frame']} (end of warm-up), {mib(last['rss']):.1f} MiB at frame {last['frame']}; growth from the "
      f"first cycle after warm-up to the last, by point of the cycle: {min(rss_growth):+.1f} to {max(rss_growth):+.1f} "
      f"MiB, median {growth:+.2f} MiB (bound {bound:g}); after warm-up between {min(rss_after):.1f} and "
      f"{max(rss_after):.1f} MiB; peak {mib(last['peak_rss']):.1f} MiB")
if growth >= bound:
    bad += 1
    print(f"FAIL: resident memory grew {growth:.2f} MiB after warm-up (median over the cycle's points), bound {bound:g} MiB")
if int(rows[0]["malloc"]) < 0:
    bad += 1
    print("FAIL: no malloc'd bytes in the samples (glibc's mallinfo2)")
else:
    heap_growth = max(mib(rs[-1]["malloc"]) - mib(rs[0]["malloc"]) for rs in by_phase.values())
    print(f"malloc'd bytes: growth from the first cycle after warm-up to the last at most {heap_growth:+.2f} MiB "
          f"over the cycle's points (bound {bound:g})")
    if heap_growth >= bound:
        bad += 1
        print(f"FAIL: malloc'd bytes grew {heap_growth:.2f} MiB after warm-up, bound {bound:g} MiB")
sys.exit(1 if bad else 0)
PY
[ $fail -eq 0 ] && echo "ok: $FRAMES frames, device memory equal at each point of every cycle, resident growth within ${RSS_BOUND_MIB} MiB"
exit $fail
