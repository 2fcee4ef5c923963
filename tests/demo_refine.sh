#!/usr/bin/env bash
# The demo's progressive refinement with adaptive samples (--spp MIN:MAX, cmd_demo.c
# refines_adaptively): each accumulated frame continues the last one's samples, with twice the most
# and the pixel error over sqrt(2), so rays go only to the pixels still uncertain. A scripted session
# saves frame 0 and frame 3 (key P); then:
#  - frame 0 is render's frame for the same options: 4:16 rays per pixel (MIN x 2^k, at most 16);
#  - frame 3 says what it continued to (penumbra.demo.refined_spp 128), every pixel took MIN x 2^k
#    <= 128 rays and never fewer than in frame 0, some took more than 16 (refinement happened) and
#    most no more than in frame 0 (the rays went where V was uncertain);
#  - against a converged reference (render, exact, 1024 samples, another seed) frame 3's V has a
#    lower MAE than frame 0's.
# The renderer-level checks of continuing (bit-exact sums, the stopping rule) are test_refine.c's.
set -u
BIN=${PN_BIN:?PN_BIN not set}
T=${PN_TEST_TMP:-/tmp}/demo_refine
rm -rf "$T" && mkdir -p "$T"
command -v xvfb-run >/dev/null || { echo "SKIP: xvfb-run not installed (ci/deps.sh installs xvfb)"; exit 77; }
command -v oiiotool >/dev/null || { echo "SKIP: oiiotool not installed (ci/deps.sh installs openimageio-tools)"; exit 77; }
view=(--size 160x120 --camera-pos 2.5,3.2,5.5 --camera-target 0,0.6,0 --mode exact --filter none)
printf 'frame 0 key P\nframe 3 key P\n' > "$T/session.script"
xvfb-run -a -s "-screen 0 1280x720x24" "$BIN" demo "${view[@]}" --seed 3 --spp 4:16 --pixel-error 0.05 --frames 4 \
  --script "$T/session.script" --save-prefix "$T/demo" > "$T/demo.txt" 2>&1 \
  || { echo "FAIL: demo exited $?"; tail -20 "$T/demo.txt"; exit 1; }
"$BIN" render "${view[@]}" --seed 46524401 --spp 1024 -o "$T/reference.exr" > /dev/null \
  || { echo "FAIL: reference render exited $?"; exit 1; }
for f in demo-0001 demo-0002 reference; do
  for ch in shadow.V shadow.rays; do
    [ $f = reference ] && [ $ch = shadow.rays ] && continue
    oiiotool "$T/$f.exr" --ch $ch -o "$T/$f.$ch.fits" || { echo "FAIL: $f.exr has no $ch"; exit 1; }
  done
  exrheader "$T/$f.exr" > "$T/$f.header" || { echo "FAIL: exrheader $f.exr"; exit 1; }
done
TESTS=$(dirname "$0") python3 - "$T" <<'PY'
import os, re, sys
sys.path.insert(0, os.environ["TESTS"])
import fits
T = sys.argv[1]
def attr(f, name):
    m = re.search(r"^%s \(type \w+\): (\S+)" % re.escape(name), open("%s/%s.header" % (T, f)).read(), re.M)
    assert m, (f, name)
    return float(m.group(1))
_, _, ref = fits.read(T + "/reference.shadow.V.fits")
_, _, v0 = fits.read(T + "/demo-0001.shadow.V.fits")
_, _, r0 = fits.read(T + "/demo-0001.shadow.rays.fits")
_, _, v3 = fits.read(T + "/demo-0002.shadow.V.fits")
_, _, r3 = fits.read(T + "/demo-0002.shadow.rays.fits")
assert attr("demo-0001", "penumbra.demo.accumulated_frames") == 1
assert attr("demo-0002", "penumbra.demo.accumulated_frames") == 4
assert attr("demo-0002", "penumbra.demo.refined_spp") == 128, attr("demo-0002", "penumbra.demo.refined_spp")
covered = [i for i in range(len(r0)) if r0[i] > 0]
assert len(covered) > len(r0) // 4, len(covered)
legal = lambda n, most: n in [4 << k for k in range(8) if 4 << k <= most]
assert all(legal(r0[i], 16) for i in covered), sorted(set(r0))
assert all(legal(r3[i], 128) and r3[i] >= r0[i] for i in covered), sorted(set(r3))
more = sum(r3[i] > 16 for i in covered)
same = sum(r3[i] == r0[i] for i in covered)
mae = lambda v: sum(abs(v[i] - ref[i]) for i in covered) / len(covered)
m0, m3 = mae(v0), mae(v3)
rays = lambda r: sum(r[i] for i in covered) / len(covered)
print("frame 0: %.2f rays per pixel, MAE %.5f; frame 3: %.2f rays per pixel, MAE %.5f; %d of %d pixels past 16 rays, "
      "%d kept frame 0's rays" % (rays(r0), m0, rays(r3), m3, more, len(covered), same))
assert more > 0, "no pixel was refined past 16 rays"
assert same > len(covered) // 2, (same, len(covered))
assert m3 < m0, (m3, m0)
print("demo refinement: ok")
PY
