#!/usr/bin/env python3
"""Writes an animated glTF for tests/animation.sh: a box turning and sliding over a ground plane
under a point light that moves, 3 seconds, and the node transforms the engine must pose at a
frame, computed here in double as glTF's samplers define them.

    anim_gltf.py OUT.gltf [--break WHAT]       the file (--break: one malformed variant)
    anim_gltf.py --pose SECONDS                 the box's --node-transform and the light's --light
                                                at that time, as command-line values

Frame times are multiples of 1/8 s (fps 8, 24 frames), exact in float: the box's rotation has a key
at every frame (a pose equals a key to the bit), its translation a key every 4 frames (LINEAR, the
frames between interpolate a + s (b - a) with s a multiple of 1/4), its scale steps once at 1.5 s
(STEP), and the light slides from its first key at 0 to its last at 3 s (LINEAR). Every value here
is a float32 as the file stores it; the interpolation is the engine's order of operations in
double, so the poses match to the bit.
"""
import base64
import json
import math
import struct
import sys

FPS = 8
END = 3.0


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


ROT_TIMES = [f32(k / FPS) for k in range(int(END * FPS) + 1)]
ROT_KEYS = [[0.0, f32(math.sin(0.5 * t * 1.2)), 0.0, f32(math.cos(0.5 * t * 1.2))] for t in ROT_TIMES]
MOVE_TIMES = [f32(k / FPS) for k in range(0, int(END * FPS) + 1, 4)]
MOVE_KEYS = [[f32(-1.2 + 0.8 * t), f32(0.6 + 0.15 * math.sin(3 * t)), f32(0.3 * math.cos(2 * t))] for t in MOVE_TIMES]
SCALE_TIMES = [0.0, 1.5]
SCALE_KEYS = [[1.0, 1.0, 1.0], [f32(1.25), f32(0.8), f32(1.25)]]
LIGHT_TIMES = [0.0, END]
LIGHT_KEYS = [[-1.5, 3.0, 0.5], [1.5, f32(3.5), -0.5]]
LIGHT_INTENSITY = 30.0


def sample(times, keys, t, interp="LINEAR"):
    """glTF's sampler at t, in the engine's arithmetic (pn_anim_sample)."""
    if len(times) == 1 or not t > times[0]:
        return list(keys[0])
    if t >= times[-1]:
        return list(keys[-1])
    lo, hi = 0, len(times) - 1
    while hi - lo > 1:
        mid = lo + (hi - lo) // 2
        if times[mid] <= t:
            lo = mid
        else:
            hi = mid
    s = (t - times[lo]) / (times[hi] - times[lo])
    a, b = keys[lo], keys[hi]
    if interp == "STEP" or s == 0:
        return list(a)
    assert len(a) == 3, "the rotation is sampled at its keys only"
    return [a[k] + s * (b[k] - a[k]) for k in range(3)]


def pose(t):
    tr = sample(MOVE_TIMES, MOVE_KEYS, t)
    rot = sample(ROT_TIMES, ROT_KEYS, t)
    sc = sample(SCALE_TIMES, SCALE_KEYS, t, "STEP")
    light = [f32(v) for v in sample(LIGHT_TIMES, LIGHT_KEYS, t)]
    fmt = lambda v: ",".join(repr(x) for x in v)
    return f"1:{fmt(tr)}:{fmt(rot)}:{fmt(sc)}", f"omni:{fmt(light)}:{LIGHT_INTENSITY!r}"


def box():
    pos, nrm, idx = [], [], []
    h = [0.3, 0.15, 0.2] # half extents
    for axis in range(3):
        for sgn in (-1.0, 1.0):
            n = [0.0, 0.0, 0.0]
            n[axis] = sgn
            u, v = (axis + 1) % 3, (axis + 2) % 3
            base = len(pos)
            for cu, cv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0.0, 0.0, 0.0]
                p[axis], p[u], p[v] = h[axis] * sgn, h[u] * cu, h[v] * cv
                pos.append(p)
                nrm.append(n)
            quad = [0, 1, 2, 0, 2, 3] if sgn > 0 else [0, 2, 1, 0, 3, 2]
            idx += [base + q for q in quad]
    return pos, nrm, idx


def write(path, brk=None):
    blob = bytearray()
    views, accessors = [], []

    def add(values, fmt, comp, kind, count, minmax=None):
        while len(blob) % 4:
            blob.append(0)
        off = len(blob)
        for v in values:
            blob.extend(struct.pack("<" + fmt, *(v if isinstance(v, (list, tuple)) else [v])))
        views.append({"buffer": 0, "byteOffset": off, "byteLength": len(blob) - off})
        acc = {"bufferView": len(views) - 1, "componentType": comp, "count": count, "type": kind}
        if minmax:
            acc["min"], acc["max"] = minmax
        accessors.append(acc)
        return len(accessors) - 1

    def vec3_minmax(vs):
        return [min(v[k] for v in vs) for k in range(3)], [max(v[k] for v in vs) for k in range(3)]

    bpos, bnrm, bidx = box()
    gpos = [[-3, 0, -3], [3, 0, -3], [3, 0, 3], [-3, 0, 3]]
    gnrm = [[0, 1, 0]] * 4
    a_bpos = add(bpos, "3f", 5126, "VEC3", len(bpos), vec3_minmax(bpos))
    a_bnrm = add(bnrm, "3f", 5126, "VEC3", len(bnrm))
    a_bidx = add(bidx, "H", 5123, "SCALAR", len(bidx))
    a_gpos = add(gpos, "3f", 5126, "VEC3", 4, vec3_minmax(gpos))
    a_gnrm = add(gnrm, "3f", 5126, "VEC3", 4)
    a_gidx = add([0, 2, 1, 0, 3, 2], "H", 5123, "SCALAR", 6)

    rot_times = list(ROT_TIMES)
    move_keys = [list(k) for k in MOVE_KEYS]
    if brk == "nan":
        move_keys[2][1] = float("nan")
    if brk == "order":
        rot_times[5], rot_times[6] = rot_times[6], rot_times[5]
    samplers = []

    def sampler(times, keys, kind, interp="LINEAR"):
        t = add(times, "f", 5126, "SCALAR", len(times), ([min(times)], [max(times)]))
        o = add(keys, "4f" if kind == "VEC4" else "3f", 5126, kind, len(keys))
        samplers.append({"input": t, "output": o, "interpolation": interp})
        return len(samplers) - 1

    s_move = sampler(MOVE_TIMES, move_keys, "VEC3")
    s_rot = sampler(rot_times, ROT_KEYS, "VEC4")
    s_scale = sampler(SCALE_TIMES, SCALE_KEYS, "VEC3", "STEP")
    s_light = sampler(LIGHT_TIMES, LIGHT_KEYS, "VEC3")
    channels = [
        {"sampler": s_move, "target": {"node": 1, "path": "translation"}},
        {"sampler": s_rot, "target": {"node": 1, "path": "rotation"}},
        {"sampler": s_scale, "target": {"node": 1, "path": "scale"}},
        {"sampler": s_light, "target": {"node": 2, "path": "translation"}},
    ]
    if brk == "sampler":
        channels[1]["sampler"] = 9
    doc = {
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": LIGHT_INTENSITY}]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"name": "ground", "mesh": 0},
            {"name": "box", "mesh": 1, "translation": MOVE_KEYS[0], "rotation": ROT_KEYS[0]},
            {"name": "lamp", "translation": LIGHT_KEYS[0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
        ],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": a_gpos, "NORMAL": a_gnrm}, "indices": a_gidx}]},
            {"primitives": [{"attributes": {"POSITION": a_bpos, "NORMAL": a_bnrm}, "indices": a_bidx}]},
        ],
        "animations": [{"name": "move", "channels": channels, "samplers": samplers}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(blob),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(blob)).decode()}],
    }
    with open(path, "w") as f:
        json.dump(doc, f)


if __name__ == "__main__":
    if sys.argv[1] == "--pose":
        node, light = pose(float(sys.argv[2]))
        print(node, light)
    else:
        write(sys.argv[1], sys.argv[3] if len(sys.argv) > 3 and sys.argv[2] == "--break" else None)
