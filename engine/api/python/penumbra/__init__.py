"""penumbra: soft shadows from area lights, points in and visibility out (the C API over ctypes).

    import numpy as np, penumbra
    scene = penumbra.Scene("builtin:default")           # or Scene.from_arrays(positions, indices)
    v = penumbra.visibility(points, normals, scene, scene.lights()[0], spp=64, mode="exact")

points and normals are (N, 3) float32 arrays (converted if not); V comes back as (N,) float32 for one
light, (L, N) for a list of L lights, equal bit for bit to the C API's penumbra_visibility. A
failure raises penumbra.Error with the library's message. The library is found beside the module
(the build tree's lib/, the install prefix's libdir), else by the name libpenumbra.so.0, else at
$PENUMBRA_LIBRARY.
"""
import ctypes
import os

import numpy as np

__all__ = ["Context", "Scene", "Light", "Error", "visibility", "version"]

_HERE = os.path.dirname(os.path.abspath(__file__))


def _load():
    names = []
    if os.environ.get("PENUMBRA_LIBRARY"):
        names.append(os.environ["PENUMBRA_LIBRARY"])
    # build/python/penumbra -> build/lib; PREFIX/lib/python3/dist-packages/penumbra -> PREFIX/lib*
    names.append(os.path.join(_HERE, "..", "..", "lib", "libpenumbra.so.0"))
    prefix = os.path.join(_HERE, "..", "..", "..", "..")
    for libdir in ("lib", os.path.join("lib", "x86_64-linux-gnu"), "lib64"):
        names.append(os.path.join(prefix, libdir, "libpenumbra.so.0"))
    names.append("libpenumbra.so.0")
    errors = []
    for n in names:
        if os.path.sep in n and not os.path.exists(n):
            continue
        try:
            return ctypes.CDLL(n)
        except OSError as e:
            errors.append(str(e))
    raise ImportError("penumbra: libpenumbra.so.0 not found (set PENUMBRA_LIBRARY): " + "; ".join(errors))


_lib = _load()


class Error(RuntimeError):
    """A failed call: .status is the penumbra_status, the message the library's."""

    def __init__(self, status, message):
        super().__init__(message)
        self.status = status


class _ContextDesc(ctypes.Structure):
    _fields_ = [("device", ctypes.c_char_p), ("validation", ctypes.c_int), ("log_level", ctypes.c_int)]


class _MeshDesc(ctypes.Structure):
    _fields_ = [("positions", ctypes.c_void_p), ("vertex_count", ctypes.c_uint32),
                ("indices", ctypes.c_void_p), ("index_count", ctypes.c_uint32),
                ("transform", ctypes.c_void_p), ("uvs", ctypes.c_void_p), ("alpha", ctypes.c_void_p),
                ("alpha_width", ctypes.c_uint32), ("alpha_height", ctypes.c_uint32),
                ("alpha_cutoff", ctypes.c_float)]


class _SceneInfo(ctypes.Structure):
    _fields_ = [("triangle_count", ctypes.c_uint64), ("object_count", ctypes.c_uint32),
                ("light_count", ctypes.c_uint32), ("bounds_min", ctypes.c_float * 3),
                ("bounds_max", ctypes.c_float * 3)]


class Light(ctypes.Structure):
    """penumbra_light: kind is one of Light.RECT, POINT, SUN, SPHERE, DISK."""
    RECT, POINT, SUN, SPHERE, DISK = range(5)
    _fields_ = [("kind", ctypes.c_int), ("position", ctypes.c_float * 3), ("normal", ctypes.c_float * 3),
                ("up", ctypes.c_float * 3), ("size", ctypes.c_float * 2), ("radius", ctypes.c_float),
                ("angle", ctypes.c_float), ("cone", ctypes.c_float * 2), ("range", ctypes.c_float)]

    # The array fields and their lengths: ctypes would fill a shorter sequence with zeros.
    _LENGTHS = {"position": 3, "normal": 3, "up": 3, "size": 2, "cone": 2}

    def __init__(self, *args, **kwargs):
        if args:
            raise TypeError("Light: pass its fields by name (kind=, position=, normal=, ...)")
        for name, value in kwargs.items():
            if name in self._LENGTHS:
                kwargs[name] = _floats(value, self._LENGTHS[name], "Light " + name)
            elif name in ("radius", "angle", "range"):
                kwargs[name] = _float(value, "Light " + name)
            elif name == "kind":
                kwargs[name] = _index(value, "Light kind", 5)
            else:
                raise TypeError("Light: no field %r (have kind, %s, radius, angle, range)"
                                % (name, ", ".join(self._LENGTHS)))
        super().__init__(**kwargs)

    def __repr__(self):
        return "Light(kind=%d, position=%s, normal=%s, size=%s)" % (
            self.kind, list(self.position), list(self.normal), list(self.size))


class _VisDesc(ctypes.Structure):
    _fields_ = [("mode", ctypes.c_char_p), ("traversal", ctypes.c_char_p), ("sampler", ctypes.c_char_p),
                ("spp", ctypes.c_uint32), ("seed", ctypes.c_uint32), ("tree_n", ctypes.c_uint32),
                ("tree_d", ctypes.c_uint32), ("width", ctypes.c_uint32), ("max_error", ctypes.c_float)]


_P = ctypes.c_void_p
_lib.penumbra_version.restype = ctypes.c_uint32
_lib.penumbra_context_create.argtypes = [ctypes.POINTER(_ContextDesc), ctypes.POINTER(_P)]
_lib.penumbra_context_destroy.argtypes = [_P]
_lib.penumbra_context_error.argtypes = [_P]
_lib.penumbra_context_error.restype = ctypes.c_char_p
_lib.penumbra_context_device.argtypes = [_P]
_lib.penumbra_context_device.restype = ctypes.c_char_p
_lib.penumbra_scene_create.argtypes = [_P, ctypes.POINTER(_MeshDesc), ctypes.c_uint32, ctypes.POINTER(_P)]
_lib.penumbra_scene_load.argtypes = [_P, ctypes.c_char_p, ctypes.POINTER(_P)]
_lib.penumbra_scene_destroy.argtypes = [_P]
_lib.penumbra_scene_get_info.argtypes = [_P, ctypes.POINTER(_SceneInfo)]
_lib.penumbra_scene_set_transform.argtypes = [_P, ctypes.c_uint32, _P]
_lib.penumbra_scene_lights.argtypes = [_P, ctypes.POINTER(Light), ctypes.c_uint32, ctypes.POINTER(ctypes.c_uint32)]
_lib.penumbra_visibility.argtypes = [_P, _P, ctypes.POINTER(_VisDesc), ctypes.POINTER(Light), ctypes.c_uint32,
                                     _P, _P, ctypes.c_size_t, _P]


def version():
    """The linked library's PENUMBRA_VERSION (major * 10000 + minor * 100 + patch)."""
    return _lib.penumbra_version()


class Context:
    """A device and its last error. device: None (the best), an index or part of a name."""

    def __init__(self, device=None, validation=False, log_level=0):
        self._h = _P()
        desc = _ContextDesc(str(device).encode() if device is not None else None, int(bool(validation)), int(log_level))
        st = _lib.penumbra_context_create(ctypes.byref(desc), ctypes.byref(self._h))
        if st != 0:
            msg = _lib.penumbra_context_error(self._h).decode()
            _lib.penumbra_context_destroy(self._h)
            self._h = None
            raise Error(st, msg)

    def _check(self, st):
        if st != 0:
            raise Error(st, _lib.penumbra_context_error(self._h).decode())

    @property
    def device(self):
        return _lib.penumbra_context_device(self._h).decode()

    def close(self):
        if self._h:
            _lib.penumbra_context_destroy(self._h)
            self._h = None

    def __del__(self):
        self.close()


_default_context = None


def _context(ctx):
    global _default_context
    if ctx is not None:
        return ctx
    if _default_context is None:
        _default_context = Context()
    return _default_context


def _numbers(a, what):
    """a as a numpy array of real numbers (not strings, objects or complex), else TypeError."""
    try:
        a = np.asarray(a)
    except ValueError as e:  # a ragged nesting
        raise ValueError("%s: not an array of numbers (%s)" % (what, e)) from None
    if a.dtype == np.bool_ or not (np.issubdtype(a.dtype, np.integer) or np.issubdtype(a.dtype, np.floating)):
        raise TypeError("%s: expected numbers, got an array of %s" % (what, a.dtype))
    return a


def _f32(a, cols, what):
    a = np.ascontiguousarray(_numbers(a, what), dtype=np.float32)
    if a.ndim != 2 or a.shape[1] != cols:
        raise ValueError("%s: expected an (N, %d) array, got shape %s" % (what, cols, a.shape))
    return a


def _floats(value, n, what):
    """Exactly n numbers (a sequence or an array of n), as a tuple of floats."""
    a = _numbers(value, what)
    if a.shape != (n,):
        raise ValueError("%s: expected %d numbers, got shape %s" % (what, n, a.shape))
    return tuple(float(x) for x in a)


def _float(value, what):
    a = _numbers(value, what)
    if a.shape != ():
        raise ValueError("%s: expected a number, got shape %s" % (what, a.shape))
    return float(a)


def _index(value, what, count=None):
    """A non-negative integer (below count when given), else TypeError or ValueError naming it."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError("%s: expected an integer, got %r" % (what, value))
    if value < 0 or value > 0xFFFFFFFF or (count is not None and value >= count):
        raise ValueError("%s: %d is out of range (0..%d)" % (what, value, (count if count is not None else 2 ** 32) - 1))
    return int(value)


def _indices(ix, what):
    """Triangle indices: integers (float indices would be truncated), 0..2^32-1, flattened."""
    a = _numbers(ix, what)
    if not np.issubdtype(a.dtype, np.integer):
        raise TypeError("%s: expected integers, got an array of %s" % (what, a.dtype))
    if a.ndim not in (1, 2) or (a.ndim == 2 and a.shape[1] != 3):
        raise ValueError("%s: expected a (T, 3) or (3T,) array, got shape %s" % (what, a.shape))
    if a.size and (a.min() < 0 or a.max() > 0xFFFFFFFF):
        raise ValueError("%s: an index is out of range (0..2^32-1): %d..%d" % (what, a.min(), a.max()))
    return np.ascontiguousarray(a, dtype=np.uint32).reshape(-1)


class Scene:
    """Scene(path): a glTF file or "builtin:NAME"; Scene.from_arrays(positions, indices) for triangles."""

    def __init__(self, path=None, context=None, _handle=None):
        self.context = _context(context)
        self._h = _P()
        if _handle is not None:
            self._h = _handle
        else:
            self.context._check(_lib.penumbra_scene_load(self.context._h, str(path).encode(), ctypes.byref(self._h)))

    @classmethod
    def from_arrays(cls, positions, indices, context=None):
        """One mesh: positions (V, 3) float, indices (T, 3) or (3T,) integers; or lists of both
        for several meshes (object i is mesh i)."""
        # One mesh (an array, or nested lists, of (V, 3) numbers) or a list of meshes.
        single = not isinstance(positions, (list, tuple))
        if not single:
            try:
                single = np.asarray(positions, dtype=np.float64).ndim == 2
            except (ValueError, TypeError):
                single = False  # ragged: several meshes of their own sizes
        if single:
            positions, indices = [positions], [indices]
        elif not isinstance(indices, (list, tuple)) or len(indices) != len(positions):
            raise ValueError("indices: expected one index array per mesh (%d meshes in positions)" % len(positions))
        ctx = _context(context)
        keep, descs = [], (_MeshDesc * len(positions))()
        for i, (p, ix) in enumerate(zip(positions, indices)):
            name = "" if single else "[%d]" % i
            p = _f32(p, 3, "positions" + name)
            ix = _indices(ix, "indices" + name)
            keep += [p, ix]
            descs[i].positions, descs[i].vertex_count = p.ctypes.data, p.shape[0]
            descs[i].indices, descs[i].index_count = ix.ctypes.data, ix.size
        h = _P()
        ctx._check(_lib.penumbra_scene_create(ctx._h, descs, len(positions), ctypes.byref(h)))
        return cls(context=ctx, _handle=h)

    def info(self):
        i = _SceneInfo()
        self.context._check(_lib.penumbra_scene_get_info(self._h, ctypes.byref(i)))
        return {"triangles": i.triangle_count, "objects": i.object_count, "lights": i.light_count,
                "bounds_min": list(i.bounds_min), "bounds_max": list(i.bounds_max)}

    def lights(self):
        """The lights penumbra render uses for this scene without --light options."""
        n = ctypes.c_uint32()
        self.context._check(_lib.penumbra_scene_lights(self._h, None, 0, ctypes.byref(n)))
        out = (Light * n.value)()
        self.context._check(_lib.penumbra_scene_lights(self._h, out, n.value, ctypes.byref(n)))
        return list(out)

    def set_transform(self, obj, transform):
        """Object obj's transform: 3 rows of 4 (a (3, 4) array, or 12 numbers), or a 4x4 matrix
        whose last row is 0, 0, 0, 1 (the numpy habit)."""
        obj = _index(obj, "set_transform: obj", self.info()["objects"])
        t = _numbers(transform, "set_transform: transform").astype(np.float64)
        if t.shape == (4, 4):
            if not np.array_equal(t[3], [0, 0, 0, 1]):
                raise ValueError("set_transform: transform: a 4x4 matrix's last row must be 0, 0, 0, 1 (an affine "
                                 "transform), got %s" % list(t[3]))
            t = t[:3]
        if t.shape not in ((3, 4), (12,)):
            raise ValueError("set_transform: transform: expected a (3, 4) or (4, 4) array or 12 numbers, got shape %s"
                             % (t.shape,))
        t = np.ascontiguousarray(t, dtype=np.float32).reshape(12)
        self.context._check(_lib.penumbra_scene_set_transform(self._h, obj, t.ctypes.data))

    def close(self):
        if self._h:
            _lib.penumbra_scene_destroy(self._h)
            self._h = None

    def __del__(self):
        self.close()


def visibility(points, normals, scene, light, spp=0, mode=None, seed=0, traversal=None, sampler=None,
               tree=(0, 0), width=0, max_error=0.0):
    """V per point (and light) as penumbra_visibility computes it; the arguments as its
    penumbra_visibility_desc (0 or None: the default)."""
    p, n = _f32(points, 3, "points"), _f32(normals, 3, "normals")
    if p.shape != n.shape:
        raise ValueError("points and normals: %s and %s differ in shape" % (p.shape, n.shape))
    single = isinstance(light, Light)
    try:
        lights = [light] if single else list(light)
    except TypeError:
        raise TypeError("light: expected a penumbra.Light or a list of them, got %r" % (light,)) from None
    for i, one in enumerate(lights):
        if not isinstance(one, Light):
            raise TypeError("light[%d]: expected a penumbra.Light, got %r" % (i, one))
    arr = (Light * len(lights))(*lights)
    if not isinstance(tree, (list, tuple)) or len(tree) != 2:
        raise ValueError("tree: expected (N, depth), got %r" % (tree,))
    for name, value in (("mode", mode), ("traversal", traversal), ("sampler", sampler)):
        if value is not None and not isinstance(value, str):
            raise TypeError("%s: expected a name (str) or None, got %r" % (name, value))
    desc = _VisDesc(mode.encode() if mode else None, traversal.encode() if traversal else None,
                    sampler.encode() if sampler else None, _index(spp, "spp"), _index(seed, "seed"),
                    _index(tree[0], "tree N"), _index(tree[1], "tree depth"), _index(width, "width"),
                    _float(max_error, "max_error"))
    v = np.empty((len(lights), p.shape[0]), dtype=np.float32)
    ctx = scene.context
    ctx._check(_lib.penumbra_visibility(ctx._h, scene._h, ctypes.byref(desc), arr, len(lights), p.ctypes.data,
                                        n.ctypes.data, p.shape[0], v.ctypes.data))
    return v[0] if single else v
