#!/usr/bin/env python3
"""Writes the seed corpus of fuzz_scene (tests/fuzz/corpus_scene/seed_*): small glTF files, each
valid, that between them use every feature the loader reads: .gltf with data: URIs and .glb with a
BIN chunk, indexed and non-indexed primitives, every triangle mode, u8/u16/u32 indices, normals,
texture coordinates, strided and sparse accessors, node hierarchies with matrix and TRS, a mirror
transform, a camera, materials and an embedded PNG texture. The fuzzer mutates from these.

Deterministic: running it again rewrites the same bytes. Run from anywhere:
    python3 tests/fuzz/make_corpus.py
Crash reproducers found by the fuzzer are kept next to the seeds as crash_* / regress_* files and
are not touched by this script.
"""
import base64
import json
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "corpus_scene")

CUBE_POS = [(x, y, z) for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]
# Two triangles per face, counter-clockwise from outside (vertex i = 4x + 2y + z of the corner).
CUBE_IDX = [0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1,
            2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3]


def f32(values):
    return b"".join(struct.pack("<f", v) for v in values)


def pad4(b, fill=b"\0"):
    return b + fill * (-len(b) % 4)


class Builder:
    """One buffer, views and accessors appended as data is added."""

    def __init__(self):
        self.bin = b""
        self.views, self.accessors = [], []

    def view(self, data, stride=None):
        self.bin = pad4(self.bin)
        v = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if stride:
            v["byteStride"] = stride
        self.bin += data
        self.views.append(v)
        return len(self.views) - 1

    def accessor(self, view, ctype, count, typ, **extra):
        a = {"componentType": ctype, "count": count, "type": typ}
        if view is not None:
            a["bufferView"] = view
        a.update(extra)
        self.accessors.append(a)
        return len(self.accessors) - 1

    def positions(self, pts):
        flat = [c for p in pts for c in p]
        lo = [min(p[k] for p in pts) for k in range(3)]
        hi = [max(p[k] for p in pts) for k in range(3)]
        return self.accessor(self.view(f32(flat)), 5126, len(pts), "VEC3", min=lo, max=hi)

    def indices(self, idx, ctype=5123):
        fmt = {5121: "<B", 5123: "<H", 5125: "<I"}[ctype]
        data = b"".join(struct.pack(fmt, i) for i in idx)
        return self.accessor(self.view(data), ctype, len(idx), "SCALAR")

    def gltf(self, doc, uri=True):
        doc = dict(doc)
        doc["asset"] = {"version": "2.0"}
        buf = {"byteLength": len(self.bin)}
        if uri:
            buf["uri"] = "data:application/octet-stream;base64," + base64.b64encode(self.bin).decode()
        doc["buffers"] = [buf]
        doc["bufferViews"] = self.views
        doc["accessors"] = self.accessors
        return doc


def as_gltf(doc):
    return json.dumps(doc, separators=(",", ":")).encode()


def as_glb(doc, bin_data, header_len=None, json_len=None, bin_len=None):
    """A binary glTF (doc: a dict, or JSON text as bytes); the *_len arguments override what the
    header and chunk headers claim (tests/hostile_glb.sh writes broken files with them)."""
    text = doc if isinstance(doc, bytes) else json.dumps(doc, separators=(",", ":")).encode()
    js = pad4(text, b" ")
    bn = pad4(bin_data)
    body = struct.pack("<I4s", len(js) if json_len is None else json_len, b"JSON") + js
    body += struct.pack("<I4s", len(bn) if bin_len is None else bin_len, b"BIN\0") + bn
    total = 12 + len(body)
    return struct.pack("<4sII", b"glTF", 2, total if header_len is None else header_len) + body


def tiny_png():
    """A 2x2 RGBA PNG (red, green, blue, white)."""
    raw = b"\0" + bytes([255, 0, 0, 255, 0, 255, 0, 255]) + b"\0" + bytes([0, 0, 255, 255] + [255] * 4)

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 2, 2, 8, 6, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def seeds():
    # 1. one triangle, non-indexed, no scenes array (roots are found from the nodes)
    b = Builder()
    p = b.positions([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    yield "seed_triangle.gltf", as_gltf(b.gltf({
        "nodes": [{"mesh": 0}], "meshes": [{"primitives": [{"attributes": {"POSITION": p}}]}]}))

    # 2. indexed cube, u16, normals and uvs, in a .glb with a BIN chunk, a material
    b = Builder()
    p = b.positions(CUBE_POS)
    n = b.accessor(b.view(f32([c for q in CUBE_POS for c in (q[0] * 2, q[1] * 2, q[2] * 2)])), 5126, 8, "VEC3")
    t = b.accessor(b.view(f32([c for q in CUBE_POS for c in (q[0] + 0.5, q[2] + 0.5)])), 5126, 8, "VEC2")
    i = b.indices(CUBE_IDX)
    doc = b.gltf({"scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
                  "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.3, 0.2, 1]}}],
                  "meshes": [{"name": "cube", "primitives": [{"attributes": {"POSITION": p, "NORMAL": n, "TEXCOORD_0": t},
                                                              "indices": i, "material": 0}]}]}, uri=False)
    yield "seed_cube.glb", as_glb(doc, b.bin)

    # 3. strip and fan, u8 and u32 indices, interleaved (strided) positions
    b = Builder()
    quad = [(0, 0, 0), (1, 0, 0), (0, 0, 1), (1, 0, 1)]
    inter = b"".join(f32(q) + f32([9, 9, 9]) for q in quad)  # position + 12 bytes of padding
    p = b.accessor(b.view(inter, stride=24), 5126, 4, "VEC3", min=[0, 0, 0], max=[1, 0, 1])
    strip = b.indices([0, 1, 2, 3], 5121)
    fan = b.indices([0, 1, 3, 2], 5125)
    yield "seed_modes.gltf", as_gltf(b.gltf({
        "scene": 0, "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0}, {"mesh": 1, "translation": [2, 0, 0]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": p}, "indices": strip, "mode": 5}]},
                   {"primitives": [{"attributes": {"POSITION": p}, "indices": fan, "mode": 6},
                                   {"attributes": {"POSITION": p}, "mode": 1}]}]}))

    # 4. hierarchy: matrix parent, TRS child with a quaternion, a mirrored (negative scale) child,
    #    and a camera node
    b = Builder()
    p = b.positions(CUBE_POS)
    i = b.indices(CUBE_IDX)
    yield "seed_nodes.gltf", as_gltf(b.gltf({
        "scene": 0, "scenes": [{"nodes": [0, 3]}],
        "nodes": [{"matrix": [2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 1, 0, 0, 1], "children": [1, 2]},
                  {"mesh": 0, "translation": [0, 1, 0], "rotation": [0, 0.3826834, 0, 0.9238795], "scale": [1, 0.5, 1]},
                  {"mesh": 0, "scale": [-1, 1, 1]},
                  {"camera": 0, "translation": [0, 1, 6]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1, "zfar": 100}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": p}, "indices": i}]}]}))

    # 5. sparse accessor: positions without a bufferView, all three set through sparse values
    b = Builder()
    sidx = b.view(struct.pack("<3H", 0, 1, 2))
    sval = b.view(f32([0, 0, 0, 1, 0, 0, 0, 0, -1]))
    p = b.accessor(None, 5126, 3, "VEC3", min=[0, 0, -1], max=[1, 0, 0],
                   sparse={"count": 3, "indices": {"bufferView": sidx, "componentType": 5123},
                           "values": {"bufferView": sval}})
    yield "seed_sparse.gltf", as_gltf(b.gltf({
        "nodes": [{"mesh": 0}], "meshes": [{"primitives": [{"attributes": {"POSITION": p}}]}]}))

    # 6. textured quad: an embedded PNG through a bufferView, in a .glb
    b = Builder()
    p = b.positions([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)])
    t = b.accessor(b.view(f32([0, 1, 1, 1, 1, 0, 0, 0])), 5126, 4, "VEC2")
    i = b.indices([0, 1, 2, 0, 2, 3])
    img = b.view(tiny_png())
    doc = b.gltf({"scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
                  "images": [{"bufferView": img, "mimeType": "image/png"}],
                  "samplers": [{}], "textures": [{"source": 0, "sampler": 0}],
                  "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
                  "meshes": [{"primitives": [{"attributes": {"POSITION": p, "TEXCOORD_0": t},
                                              "indices": i, "material": 0}]}]}, uri=False)
    yield "seed_textured.glb", as_glb(doc, b.bin)

    # 7. normalized integer texture coordinates (u16), and an unused extension listed as used
    b = Builder()
    p = b.positions([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    t = b.accessor(b.view(struct.pack("<6H", 0, 0, 65535, 0, 0, 65535)), 5123, 3, "VEC2", normalized=True)
    yield "seed_uv16.gltf", as_gltf(b.gltf({
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "nodes": [{"mesh": 0}], "meshes": [{"primitives": [{"attributes": {"POSITION": p, "TEXCOORD_0": t}}]}]}))


def main():
    os.makedirs(OUT, exist_ok=True)
    for name, data in seeds():
        with open(os.path.join(OUT, name), "wb") as f:
            f.write(data)
        print(f"{name}: {len(data)} bytes")


if __name__ == "__main__":
    main()
