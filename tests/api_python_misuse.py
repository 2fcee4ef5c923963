#!/usr/bin/env python3
"""The Python module's misuse (issue 65): each wrong argument raises TypeError or ValueError naming
the argument, before anything reaches the library (whose own checks would accept some of them after
a silent conversion: float indices truncated, a 2-tuple zero-filled, -1 wrapped to 4294967295).
And what the misuse list's right forms do: a 4x4 transform moves the object as its 3x4 does, a
single mesh given as nested lists is one mesh. Run by ctest with PYTHONPATH at build/python."""
import sys

import numpy as np

import penumbra

failures = 0


def raises(exc, words, fn, *args, **kwargs):
    """fn(*args, **kwargs) must raise `exc` with every one of `words` in its message."""
    global failures
    try:
        fn(*args, **kwargs)
    except exc as e:
        missing = [w for w in words if w not in str(e)]
        if missing:
            failures += 1
            print("FAIL: %s raised %s(%r), which does not name %s" % (fn.__name__, exc.__name__, str(e), missing))
        else:
            print("ok: %s: %s" % (exc.__name__, e))
        return
    except Exception as e:  # noqa: BLE001 -- the wrong kind is the failure reported
        failures += 1
        print("FAIL: %s raised %s(%r), expected %s" % (fn.__name__, type(e).__name__, str(e), exc.__name__))
        return
    failures += 1
    print("FAIL: %s(%r, %r) raised nothing, expected %s naming %s" % (fn.__name__, args, kwargs, exc.__name__, words))


def check(cond, what):
    global failures
    if not cond:
        failures += 1
        print("FAIL: " + what)
    else:
        print("ok: " + what)


ctx = penumbra.Context(validation=True)
quad = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], dtype=np.float32)
# A floating square over a ground: the square (object 1) casts a shadow on the ground's centre.
ground = quad * 4
square = quad * 0.5 + np.array([0, 1, 0], dtype=np.float32)
tris = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int32)

# Indices: integers only (1.7 would become 1), in range, the right shape.
raises(TypeError, ["indices", "integers", "float"], penumbra.Scene.from_arrays, quad, tris.astype(np.float64), ctx)
raises(ValueError, ["indices", "range"], penumbra.Scene.from_arrays, quad, tris - 5, ctx)
raises(ValueError, ["indices", "shape"], penumbra.Scene.from_arrays, quad, np.zeros((2, 4), np.int32), ctx)
raises(ValueError, ["positions", "shape"], penumbra.Scene.from_arrays, quad[:, :2], tris, ctx)
raises(TypeError, ["positions", "numbers"], penumbra.Scene.from_arrays, [["a", "b", "c"]], [[0, 0, 0]], ctx)
raises(ValueError, ["indices", "one index array per mesh"], penumbra.Scene.from_arrays, [ground, square], [tris], ctx)
# A single mesh as nested lists is one mesh, not a list of three-number meshes.
one = penumbra.Scene.from_arrays(quad.tolist(), tris.tolist(), context=ctx)
check(one.info()["objects"] == 1 and one.info()["triangles"] == 2,
      "one mesh as nested lists: %s" % one.info())
one.close()

scene = penumbra.Scene.from_arrays([ground, square], [tris, tris], context=ctx)
check(scene.info()["objects"] == 2, "two meshes as a list of arrays: %s" % scene.info())

# Lights: exactly three numbers for a position (ctypes would zero-fill (0, 2)), known fields only.
raises(ValueError, ["position", "3 numbers"], penumbra.Light, kind=penumbra.Light.RECT, position=(0, 2))
raises(ValueError, ["size", "2 numbers"], penumbra.Light, kind=penumbra.Light.RECT, size=(1, 1, 1))
raises(TypeError, ["positon"], penumbra.Light, kind=penumbra.Light.RECT, positon=(0, 2, 0))
raises(TypeError, ["kind", "integer"], penumbra.Light, kind="rect")
raises(ValueError, ["kind"], penumbra.Light, kind=9)
raises(TypeError, ["by name"], penumbra.Light, 0, (0, 2, 0))
light = penumbra.Light(kind=penumbra.Light.RECT, position=(0, 3, 0), normal=(0, -1, 0), up=(0, 0, 1), size=(0.5, 0.5))

# Transforms: object indices in range (-1 is not 4294967295), a 3x4, 12 numbers or an affine 4x4.
move = np.array([[1, 0, 0, 0.25], [0, 1, 0, 0], [0, 0, 1, 0]], dtype=np.float32)
raises(ValueError, ["obj", "-1"], scene.set_transform, -1, move)
raises(ValueError, ["obj", "2"], scene.set_transform, 2, move)
raises(TypeError, ["obj", "integer"], scene.set_transform, 1.0, move)
raises(ValueError, ["transform", "shape"], scene.set_transform, 1, np.eye(3))
raises(ValueError, ["transform", "last row"], scene.set_transform, 1, np.ones((4, 4)))

points = np.array([[0, 0, 0], [0.3, 0, 0.1], [3, 0, 3]], dtype=np.float32)
normals = np.tile(np.array([0, 1, 0], dtype=np.float32), (3, 1))
raises(TypeError, ["light", "penumbra.Light"], penumbra.visibility, points, normals, scene, 5)
raises(TypeError, ["light[1]"], penumbra.visibility, points, normals, scene, [light, "sun"])
raises(ValueError, ["spp"], penumbra.visibility, points, normals, scene, light, spp=-4)
raises(TypeError, ["spp", "integer"], penumbra.visibility, points, normals, scene, light, spp=4.5)
raises(TypeError, ["mode"], penumbra.visibility, points, normals, scene, light, mode=3)
raises(ValueError, ["tree"], penumbra.visibility, points, normals, scene, light, tree=(7,))
raises(ValueError, ["points", "shape"], penumbra.visibility, points[:, :2], normals[:, :2], scene, light)

# The right forms: a 4x4 moves the square as its 3x4 does, bit for bit.
scene.set_transform(1, move)
v34 = penumbra.visibility(points, normals, scene, light, spp=16)
m44 = np.vstack([move, [0, 0, 0, 1]]).astype(np.float64)
scene.set_transform(1, m44)
v44 = penumbra.visibility(points, normals, scene, light, spp=16)
scene.set_transform(1, move.reshape(12).tolist())
v12 = penumbra.visibility(points, normals, scene, light, spp=16)
check(np.array_equal(v34, v44) and np.array_equal(v34, v12),
      "a 3x4, a 4x4 and 12 numbers move the square alike: V %s, %s, %s" % (v34, v44, v12))
check(v34[0] < 1 and v34[2] == 1, "the moved square shades the ground under it and not its corner: V %s" % v34)
scene.close()
ctx.close()
print("%d failure(s)" % failures)
sys.exit(1 if failures else 0)
