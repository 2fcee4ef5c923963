"""The Python module over the C API (engine/api/python): the README example's four points through
penumbra.visibility, printed as the C example prints them (tests/api_install.sh compares the two,
and both with render's V); then a scene from arrays against a closed form, and errors raised."""
import sys

import numpy as np

import penumbra

print("penumbra from", penumbra.__file__, "version", penumbra.version(), file=sys.stderr)
p = np.array([[0, 0, 0], [0.6, 0, 0.4], [-1.2, 0, 0.8], [2, 0, -2]], dtype=np.float32)
n = np.tile(np.array([0, 1, 0], dtype=np.float32), (4, 1))
scene = penumbra.Scene("builtin:default")
light = scene.lights()[0]
v = penumbra.visibility(p, n, scene, light, spp=64, seed=1)
assert v.dtype == np.float32 and v.shape == (4,)
for i in range(4):
    print("V(%g, %g, %g) = %.9f" % (p[i][0], p[i][1], p[i][2], v[i]))
# Two lights at once: (2, N), each row the light's V alone.
both = penumbra.visibility(p, n, scene, [light, light], spp=64, seed=1)
assert both.shape == (2, 4) and (both[0] == v).all() and (both[1] == v).all()

# A unit square occluder at height 1 and a point under its centre, a unit light at height 2 facing
# down: from the origin the occluder covers the light's whole plane patch, V = 0; 3 units aside, 1.
quad = penumbra.Scene.from_arrays(
    np.array([[-0.5, 1, -0.5], [0.5, 1, -0.5], [0.5, 1, 0.5], [-0.5, 1, 0.5]]), np.array([[0, 1, 2], [0, 2, 3]]))
rect = penumbra.Light(kind=penumbra.Light.RECT, position=(0, 2, 0), normal=(0, -1, 0), up=(0, 0, 1), size=(1, 1))
pts = np.array([[0, 0, 0], [3, 0, 0]], dtype=np.float32)
vq = penumbra.visibility(pts, np.tile([0, 1, 0], (2, 1)), quad, rect, spp=256)
assert vq[0] == 0.0 and vq[1] == 1.0, vq
assert quad.info()["triangles"] == 2

for bad, what in (
    (lambda: penumbra.visibility(np.array([[np.nan, 0, 0]]), np.array([[0, 1, 0]]), quad, rect), "point 0"),
    (lambda: penumbra.visibility(pts, np.tile([0, 1, 0], (2, 1)), quad, rect, mode="magic"), "mode"),
    (lambda: penumbra.Scene("missing.glb"), "missing.glb"),
):
    try:
        bad()
        raise AssertionError("no error for " + what)
    except penumbra.Error as e:
        assert what in str(e), (what, str(e))
print("python checks passed", file=sys.stderr)
