#!/usr/bin/env bash
# --filter interleaved on the default scene (exact, 4 spp):
#  - the EXR keeps the unfiltered V as shadow.V_raw; V stays in [0, 1] and 0 on the background;
#  - the filtered V is what filter.comp documents, recomputed here in double precision from the
#    render's own P, N, view depth, V_raw and penumbra widths (an independent implementation of the
#    geometric, the penumbra and the range weights, the latter two acting on some taps);
#  - the penumbra width is FLT_MAX exactly where no valid ray was blocked (V_raw = 1), and finite
#    and not negative where one was;
#  - at 4 spp every pixel the light reaches above its horizon has a valid ray (the samples are
#    drawn in the part above, shadow_frame.glsl's horizon_box); at 1 spp some miss it, and those
#    take their neighbours' V as filter.comp says (recomputed at those pixels);
#  - so is a window other than 3x3 (2x4: even, so off centre, and not square), whose pipeline the
#    renderer specialises for it (filter_pass.c);
#  - the filter pays: against the converged reference (exact, 1024 spp, another seed) the filtered
#    V's mean error is below the unfiltered V's of the same frame.
set -u
BIN=${PN_BIN:?PN_BIN not set}
T=${PN_TEST_TMP:-/tmp}/filter
rm -rf "$T" && mkdir -p "$T"
view=(builtin:default --size 480x360 --fov 45 --mode exact)
"$BIN" render "${view[@]}" --spp 4 --filter interleaved --tile 3x3 --aovs -o "$T/f.exr" >/dev/null \
  || { echo "FAIL: filtered render"; exit 1; }
"$BIN" render "${view[@]}" --spp 1 --filter interleaved --tile 3x3 --aovs -o "$T/f1.exr" >/dev/null \
  || { echo "FAIL: filtered render at 1 spp"; exit 1; }
"$BIN" render "${view[@]}" --spp 4 --filter interleaved --tile 2x4 --aovs -o "$T/f24.exr" >/dev/null \
  || { echo "FAIL: filtered render with a 2x4 tile"; exit 1; }
"$BIN" render "${view[@]}" --spp 1024 --filter none --seed 46524401 -o "$T/ref.exr" >/dev/null || { echo "FAIL: reference"; exit 1; }
for f in f f1 f24; do
  for c in shadow.V shadow.V_raw shadow.valid shadow.penumbra A P.X P.Y P.Z N.X N.Y N.Z Z; do
    oiiotool "$T/$f.exr" --ch "$c" -d float -o "$T/$f.$c.fits" || { echo "FAIL: no channel $c in $T/$f.exr"; exit 1; }
  done
done
oiiotool "$T/ref.exr" --ch shadow.V -d float -o "$T/ref.fits" || exit 1
exrheader "$T/f.exr" | grep "penumbra.light" > "$T/light.txt" || { echo "FAIL: no light in the header"; exit 1; }
TESTS=$(dirname "$0") python3 - "$T" <<'PY'
import math, re, struct, sys
import os
sys.path.insert(0, os.environ["TESTS"])
import fits as fits_module  # tests/fits.py
T = sys.argv[1]
# The light's corners, from the EXR's header.
L = {}
for line in open(T + "/light.txt"):
    m = re.match(r"\s*penumbra\.light\.(\w+) \(type \w+\): \(?([-0-9.e+ ]+)\)?", line)
    if m:
        L[m.group(1)] = [float(v) for v in m.group(2).split()]
ln, up = L["normal"], L["up"]
dot = lambda a, b: sum(a[k] * b[k] for k in range(3))
vv = [up[k] - dot(up, ln) * ln[k] for k in range(3)]
vv = [c / math.sqrt(dot(vv, vv)) for c in vv]
uu = [ln[1] * vv[2] - ln[2] * vv[1], ln[2] * vv[0] - ln[0] * vv[2], ln[0] * vv[1] - ln[1] * vv[0]]
corners = [[L["pos"][k] + su * L["width"][0] / 2 * uu[k] + sv * L["height"][0] / 2 * vv[k] for k in range(3)]
           for su in (-1, 1) for sv in (-1, 1)]
size = max(L["width"][0], L["height"][0])
fits = fits_module.read
_, _, REF = fits(T + "/ref.fits")
ulp = lambda x: max(abs(x), 1e-30) * 1.1920929e-7
def offset(p, n, footprint, q):
    mag = max(max(abs(c) for c in p), max(abs(c) for c in q))
    off = max(abs(sum(n[k] * (q[k] - p[k]) for k in range(3))) - 8 * ulp(mag), 0.0)
    return off / max(footprint, 1e-30)
FLT_MAX = struct.unpack(">f", bytes.fromhex("7f7fffff"))[0]

# Recomputes the filter of the render in T/<tag>.*.fits at spp samples per pixel over a tile (w, h)
# window; with `unknown_only` only at its pixels without a valid ray. Returns the counters and the
# render's V, V_raw, coverage.
def check(tag, spp, unknown_only, tile=(3, 3)):
    w, h, V = fits(T + "/%s.shadow.V.fits" % tag)
    _, _, R = fits(T + "/%s.shadow.V_raw.fits" % tag)
    _, _, VALID = fits(T + "/%s.shadow.valid.fits" % tag)
    _, _, WIDTH = fits(T + "/%s.shadow.penumbra.fits" % tag)
    _, _, A = fits(T + "/%s.A.fits" % tag)
    P = [fits(T + "/%s.P.%s.fits" % (tag, c))[2] for c in "XYZ"]
    N = [fits(T + "/%s.N.%s.fits" % (tag, c))[2] for c in "XYZ"]
    _, _, Z = fits(T + "/%s.Z.fits" % tag)
    covered = [i for i in range(w * h) if A[i] > 0]
    assert len(covered) > w * h // 2, len(covered)
    assert all(0.0 <= V[i] <= 1.0 for i in range(w * h)), "V outside [0, 1]"
    assert all(V[i] == 0.0 for i in range(w * h) if A[i] <= 0), "background V is not 0"
    assert any(V[i] != R[i] for i in covered), "the filter changed nothing"
    for i in covered:
        if VALID[i] > 0:
            none = R[i] == 1.0  # no valid ray blocked
            assert (WIDTH[i] == FLT_MAX) == none and 0 <= WIDTH[i], (i, R[i], WIDTH[i])
    finite = [WIDTH[i] for i in covered if VALID[i] > 0 and WIDTH[i] < FLT_MAX]
    assert len(finite) > 100 and max(finite) > 0, "no pixel with a finite penumbra width"
    pixel_angle = 2 * math.tan(math.radians(45) / 2) / h
    tally = dict(worst=0.0, partial=0, kept=0, borrowed=0, unsure=0, pen_cut=0)
    for i in covered:
        if unknown_only and VALID[i] > 0:
            continue
        x, y = i % w, i // w
        p = [P[k][i] for k in range(3)]; n = [N[k][i] for k in range(3)]
        # No valid ray: does any of the light lie above the horizon, in front of the light? Where a
        # corner lies within rounding of the tangent plane (1e-5 of the light's size: the shader tests
        # from the ray origin, raised off the surface), either answer is the shader's to give.
        reaches = None
        if VALID[i] == 0:
            heights = [dot([c[k] - p[k] for k in range(3)], n) for c in corners]
            front = dot(ln, [p[k] - corners[0][k] for k in range(3)])
            reaches = front > 0 and max(heights) > 0
            if abs(front) < 1e-5 * size or abs(max(heights)) < 1e-5 * size:
                reaches = None
                tally["unsure"] += 1
                continue
            if not reaches:
                assert V[i] == R[i] == 1.0, (i, V[i], R[i])  # the convention, kept
                tally["kept"] += 1
                continue
        taps = []
        # The window's first offset, -(edge - 1) / 2 rounded toward zero as GLSL's integer division
        # does: odd edges are centred, even ones reach one pixel further right and down.
        lo = [-((e - 1) // 2) for e in tile]
        for dy in range(lo[1], lo[1] + tile[1]):
            for dx in range(lo[0], lo[0] + tile[0]):
                # FITS stores the bottom row first (oiiotool flips the EXR's top-down rows), so the
                # image's dy rows down are -dy rows here: it matters for windows not symmetric in y.
                qx, qy = x + dx, y - dy
                if not (0 <= qx < w and 0 <= qy < h):
                    continue
                j = qy * w + qx
                if A[j] <= 0 or VALID[j] == 0:
                    continue  # background, or no estimate of V
                q = [P[k][j] for k in range(3)]; m = [N[k][j] for k in range(3)]
                px = max(abs(dx), abs(dy))
                rho = max(offset(p, n, Z[i] * pixel_angle * px, q), offset(q, m, Z[j] * pixel_angle * px, p))
                c = max(sum(n[k] * m[k] for k in range(3)), 0.0)
                wg = max(1 - rho * rho, 0.0) * c * c
                # The penumbra weight: V changes by up to distance / width over the narrower penumbra;
                # the weight falls to 0 where that reaches 1/2 (a pixel without a V of its own skips it).
                if not reaches:
                    tol = min(WIDTH[i], WIDTH[j]) * 0.5
                    dist2 = sum((q[k] - p[k]) ** 2 for k in range(3))
                    wp = max(1 - dist2 / tol ** 2, 0.0) if tol > 0 else 0.0
                    tally["pen_cut"] += wg > 0 and wp < 1
                    wg *= wp
                taps.append((wg, R[j]))
        # The range weight: neighbours whose V_raw is more than 2.5 standard deviations of a difference
        # of two 4-sample means of the window's geometry-weighted V away from the pixel's drop out.
        wsum = sum(t[0] for t in taps)
        if reaches:  # no V of its own: its neighbours' geometric mean
            want = min(max(sum(t[0] * t[1] for t in taps) / wsum, 0.0), 1.0) if wsum > 0 else 1.0
            tally["worst"] = max(tally["worst"], abs(want - V[i]))
            tally["borrowed"] += wsum > 0
            continue
        mean = min(max(sum(t[0] * t[1] for t in taps) / wsum, 0.0), 1.0)
        spread = 2.5 * math.sqrt(2 * mean * (1 - mean) / spp)
        s = wsum = 0.0
        for wg, v in taps:
            d = abs(v - R[i])
            wt = wg * (1.0 if d == 0 else max(1 - (d / max(spread, 1e-30)) ** 2, 0.0))
            s += wt * v; wsum += wt
            tally["partial"] += 0 < wt < wg
        tally["worst"] = max(tally["worst"], abs(min(max(s / wsum, 0.0), 1.0) - V[i]))
    return tally, V, R, covered
tally, V, R, covered = check("f", 4, False)
# float against double: the weights' rounding moves a mean of values in [0, 1] by a few float ulps.
print("filtered V against the recomputed filter: max |difference| %.2e over %d pixels, %d taps cut by the range"
      " weight, %d by the penumbra weight; without a valid ray: %d keep V = 1 (the light is below the horizon),"
      " %d take their neighbours' V, %d too close to call" % (tally["worst"], len(covered), tally["partial"], tally["pen_cut"],
                                                              tally["kept"], tally["borrowed"], tally["unsure"]))
assert tally["worst"] < 1e-4, tally["worst"]
assert tally["partial"] > 0, "the range weight never acted"
assert tally["pen_cut"] > 0, "the penumbra weight never acted"
assert tally["kept"] > 0, "the rule for pixels below the light's plane never acted"
# At 4 spp every pixel the light reaches has a valid ray: its samples are one per quarter of the box
# of the part of the light above its horizon (horizon_box), and that part holds a whole quarter.
assert tally["borrowed"] == 0, "a pixel the light reaches without a valid ray at 4 spp"
# At 1 spp a grazing pixel's one sample misses the part above (about half of its box) now and then:
# those pixels take their neighbours' V.
tally1, _, _, _ = check("f1", 1, True)
print("1 spp: %d pixels take their neighbours' V, %d keep V = 1, max |difference| %.2e"
      % (tally1["borrowed"], tally1["kept"], tally1["worst"]))
assert tally1["worst"] < 1e-4, tally1["worst"]
assert tally1["borrowed"] > 0, "the rule for pixels the light reaches without a valid ray never acted"
tally24, _, _, _ = check("f24", 4, False, (2, 4))
print("2x4 tile: max |difference| %.2e, %d taps cut by the range weight, %d by the penumbra weight"
      % (tally24["worst"], tally24["partial"], tally24["pen_cut"]))
assert tally24["worst"] < 1e-4, tally24["worst"]
assert tally24["partial"] > 0 and tally24["pen_cut"] > 0, tally24
mae_f = sum(abs(V[i] - REF[i]) for i in covered) / len(covered)
mae_r = sum(abs(R[i] - REF[i]) for i in covered) / len(covered)
print("MAE against the converged reference, 4 spp: filtered %.4f, unfiltered %.4f" % (mae_f, mae_r))
assert mae_f < mae_r, (mae_f, mae_r)
print("filter: ok")
PY
