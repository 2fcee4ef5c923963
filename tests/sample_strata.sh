#!/usr/bin/env bash
# The stratified sampler at a sample count that is no square (shaders/glsl/shadow_common.glsl,
# light_sample): 2, 8, 32 samples a pixel make a grid of u x 2u cells, each twice as wide as it is
# tall, and each square of two cells holds its two samples in opposite halves of its width as well
# as of its height (a two-point net), chosen at random per square so that each sample is uniform over
# its cell. Checked on the ray dump (render --ray-dump) of builtin:plane under a square light that
# every pixel sees whole (its samples are the sampler's (s, t) on the light, horizon_box leaving
# them alone):
#  - per pixel (--filter none, a 1 x 1 tile), the light's u x u squares hold two samples each, in
#    different halves of the square along both of the light's axes;
#  - per 3 x 3 interleaving tile (--filter penumbra), the same over the union of its 9 pixels'
#    samples on the 3u x 3u squares (the sub-cells' grid);
#  - the halves are drawn at random: the pairs on the square's one diagonal are about half of all
#    (within 5 standard deviations of a fair coin's count); a fixed choice puts every pair on one.
# The light's axes are taken as the world's x and z (the light faces down, its up is -z), and
# which is the grid's wide one does not matter: both are checked alike. The dump's points carry the
# float rounding of o + (point - o) (|o| up to about 5 here, so up to about 3e-7): a square with a
# sample within 2e-6 of a boundary of the half-squares is left out as ambiguous, with its
# neighbours (at most 1% of them may be).
set -u
BIN=${PN_BIN:?PN_BIN not set}
T=${PN_TEST_TMP:-/tmp}/sample_strata
rm -rf "$T" && mkdir -p "$T"
light=(--light-pos 0,3,0 --light-normal 0,-1,0 --light-up 0,0,-1 --light-size 1,1)
for spp in 2 8 32; do
  for filter in none penumbra; do
    "$BIN" render builtin:plane --size 24x24 --mode exact --spp $spp --filter $filter "${light[@]}" \
      --ray-dump "$T/rays_${spp}_$filter.bin" -o "$T/v_${spp}_$filter.exr" >/dev/null \
      || { echo "FAIL: render $spp spp, filter $filter"; exit 1; }
  done
done
python3 - "$T" <<'PY'
import math, struct, sys
T = sys.argv[1]
diagonal = pairs = ambiguous = squares_seen = 0
NEAR = 2e-6
def near_boundary(c, m):
    x = c * m
    return abs(x - round(x)) < NEAR * m
for spp in (2, 8, 32):
    u = max(d for d in range(1, spp + 1) if d * d <= spp and spp % d == 0)   # shadow_pass.c's grid
    assert spp == 2 * u * u
    for filt, tile in (("none", 1), ("penumbra", 3)):
        b = open("%s/rays_%d_%s.bin" % (T, spp, filt), "rb").read()
        _, _, W, H, S, _ = struct.unpack("<6I", b[:24])
        f = struct.unpack("<%df" % ((len(b) - 24) // 4), b[24:])
        n = W * H
        def samples(x, y):
            p = y * W + x
            out = []
            for k in range(S):
                q = 4 * (n + p * S + k)
                flags = struct.unpack("<I", struct.pack("<f", f[q + 3]))[0]
                if not flags & 1:
                    return None
                out.append((f[q] + 0.5, f[q + 2] + 0.5))   # the light: centre (0, 3, 0), 1 x 1
            return out
        squares = u * tile
        groups = 0
        for ty in range(0, H, tile):
            for tx in range(0, W, tile):
                pts = [samples(tx + i, ty + j) for j in range(tile) for i in range(tile)]
                if any(p is None for p in pts):
                    continue
                groups += 1
                cells, unsure = {}, set()
                for s in (q for p in pts for q in p):
                    assert all(0.0 <= c < 1.0 for c in s), s
                    key = (int(s[0] * squares), int(s[1] * squares))
                    cells.setdefault(key, []).append(s)
                    if near_boundary(s[0], 2 * squares) or near_boundary(s[1], 2 * squares):
                        unsure.add(key)
                        # Rounding may have filed it in the neighbouring square: that one too.
                        for dx in (-1, 0, 1):
                            for dy in (-1, 0, 1):
                                unsure.add((key[0] + dx, key[1] + dy))
                squares_seen += squares * squares
                ambiguous += len([k for k in cells if k in unsure])
                assert unsure or len(cells) == squares * squares, (spp, filt, tx, ty, len(cells))
                for key, two in cells.items():
                    if key in unsure:
                        continue
                    assert len(two) == 2, (spp, filt, tx, ty, key, two)
                    halves = [(int(s[0] * 2 * squares) & 1, int(s[1] * 2 * squares) & 1) for s in two]
                    assert halves[0][0] != halves[1][0] and halves[0][1] != halves[1][1], (spp, filt, tx, ty, key, two)
                    diagonal += halves[0][0] == halves[0][1]
                    pairs += 1
        assert groups >= (W // tile) * (H // tile) // 2, (spp, filt, groups)
        print("%d spp, filter %s: %d groups, every %dx%d square holds a two-point net" % (spp, filt, groups, squares, squares))
assert ambiguous <= 0.01 * squares_seen, (ambiguous, squares_seen)
print("%d of %d squares left out as within rounding of a boundary" % (ambiguous, squares_seen))
# A fair coin per square: the count on one diagonal within 5 standard deviations of half.
dev = abs(diagonal - pairs / 2) / math.sqrt(pairs / 4)
print("pairs on one diagonal: %d of %d (%.2f standard deviations from half)" % (diagonal, pairs, dev))
assert dev < 5, (diagonal, pairs)
PY
