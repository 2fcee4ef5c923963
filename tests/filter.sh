#!/usr/bin/env bash
# --filter interleaved on the default scene (exact, 4 spp):
#  - the EXR keeps the unfiltered V as shadow.V_raw; V stays in [0, 1] and 0 on the background;
#  - the filtered V is what filter.comp documents, recomputed here in double precision from the
#    render's own P, N, view depth and V_raw (an independent implementation of the geometric and
#    the range weights, the latter acting on some taps);
#  - the filter pays: against the converged reference (exact, 1024 spp, another seed) the filtered
#    V's mean error is below the unfiltered V's of the same frame.
set -u
BIN=${PN_BIN:?PN_BIN not set}
T=${PN_TEST_TMP:-/tmp}/filter
rm -rf "$T" && mkdir -p "$T"
view=(builtin:default --size 480x360 --fov 45 --mode exact)
"$BIN" render "${view[@]}" --spp 4 --filter interleaved --tile 3x3 --aovs -o "$T/f.exr" >/dev/null \
  || { echo "FAIL: filtered render"; exit 1; }
"$BIN" render "${view[@]}" --spp 1024 --filter none --seed 46524401 -o "$T/ref.exr" >/dev/null || { echo "FAIL: reference"; exit 1; }
for c in shadow.V shadow.V_raw A P.X P.Y P.Z N.X N.Y N.Z Z; do
  oiiotool "$T/f.exr" --ch "$c" -d float -o "$T/$c.fits" || { echo "FAIL: no channel $c in the filtered EXR"; exit 1; }
done
oiiotool "$T/ref.exr" --ch shadow.V -d float -o "$T/ref.fits" || exit 1
python3 - "$T" <<'PY'
import math, struct, sys
T = sys.argv[1]
def fits(path):
    b = open(path, "rb").read()
    hdr, off = {}, 0
    while True:
        card = b[off:off + 80].decode("ascii"); off += 80
        if card.startswith("END"):
            break
        if "=" in card[:10]:
            hdr[card[:8].strip()] = card[10:].split("/")[0].strip()
    off = (off + 2879) // 2880 * 2880
    w, h = int(hdr["NAXIS1"]), int(hdr["NAXIS2"])
    assert int(hdr["BITPIX"]) == -32, hdr
    return w, h, list(struct.unpack(">%df" % (w * h), b[off:off + 4 * w * h]))
w, h, V = fits(T + "/shadow.V.fits")
_, _, R = fits(T + "/shadow.V_raw.fits")
_, _, A = fits(T + "/A.fits")
P = [fits(T + "/P.%s.fits" % c)[2] for c in "XYZ"]
N = [fits(T + "/N.%s.fits" % c)[2] for c in "XYZ"]
_, _, Z = fits(T + "/Z.fits")
_, _, REF = fits(T + "/ref.fits")
covered = [i for i in range(w * h) if A[i] > 0]
assert len(covered) > w * h // 2, len(covered)
assert all(0.0 <= V[i] <= 1.0 for i in range(w * h)), "V outside [0, 1]"
assert all(V[i] == 0.0 for i in range(w * h) if A[i] <= 0), "background V is not 0"
assert any(V[i] != R[i] for i in covered), "the filter changed nothing"
pixel_angle = 2 * math.tan(math.radians(45) / 2) / h
ulp = lambda x: max(abs(x), 1e-30) * 1.1920929e-7
def offset(p, n, footprint, q):
    mag = max(max(abs(c) for c in p), max(abs(c) for c in q))
    off = max(abs(sum(n[k] * (q[k] - p[k]) for k in range(3))) - 8 * ulp(mag), 0.0)
    return off / max(footprint, 1e-30)
worst, partial = 0.0, 0
for i in covered:
    x, y = i % w, i // w
    p = [P[k][i] for k in range(3)]; n = [N[k][i] for k in range(3)]
    taps = []
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            qx, qy = x + dx, y + dy
            if not (0 <= qx < w and 0 <= qy < h):
                continue
            j = qy * w + qx
            if A[j] <= 0:
                continue
            q = [P[k][j] for k in range(3)]; m = [N[k][j] for k in range(3)]
            px = max(abs(dx), abs(dy))
            rho = max(offset(p, n, Z[i] * pixel_angle * px, q), offset(q, m, Z[j] * pixel_angle * px, p))
            c = max(sum(n[k] * m[k] for k in range(3)), 0.0)
            taps.append((max(1 - rho * rho, 0.0) * c * c, R[j]))
    # The range weight: neighbours whose V_raw is more than 2.5 standard deviations of a difference
    # of two 4-sample means of the window's geometry-weighted V away from the pixel's drop out.
    wsum = sum(t[0] for t in taps)
    mean = min(max(sum(t[0] * t[1] for t in taps) / wsum, 0.0), 1.0)
    spread = 2.5 * math.sqrt(2 * mean * (1 - mean) / 4)
    s = wsum = 0.0
    for wg, v in taps:
        d = abs(v - R[i])
        wt = wg * (1.0 if d == 0 else max(1 - (d / max(spread, 1e-30)) ** 2, 0.0))
        s += wt * v; wsum += wt
        partial += 0 < wt < wg
# float against double: the weights' rounding moves a mean of values in [0, 1] by a few float ulps.
print("filtered V against the recomputed filter: max |difference| %.2e over %d pixels, %d taps cut by the range"
      " weight" % (worst, len(covered), partial))
assert worst < 1e-4, worst
assert partial > 0, "the range weight never acted"
mae_f = sum(abs(V[i] - REF[i]) for i in covered) / len(covered)
mae_r = sum(abs(R[i] - REF[i]) for i in covered) / len(covered)
print("MAE against the converged reference, 4 spp: filtered %.4f, unfiltered %.4f" % (mae_f, mae_r))
assert mae_f < mae_r, (mae_f, mae_r)
print("filter: ok")
PY
