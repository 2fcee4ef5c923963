#!/usr/bin/env python3
"""Writes a glTF binary whose nodes instance the first mesh of another one: the per-object trees'
scenes (tests/objects.sh, bench --trees). The mesh's bytes are carried over unchanged; only the
node list is new. The source (e.g. ../shared/assets/stanford-bunny-69k.glb) is read, never copied
into the project: the output goes where the caller says (a build or temporary directory).

    instances.py SRC.glb OUT.glb --grid X,Y,Z [--spacing S] [--scale I:SX,SY,SZ]...

--grid: instances on an X x Y x Z lattice, S times the mesh's largest extent apart (default 1.25:
neighbours do not touch). --scale: instance I gets that (non-uniform) scale about its own origin.
--overlap: every other instance is moved half a spacing along x, so that neighbours overlap.
"""
import argparse
import json
import struct
import sys


def read_glb(path):
    data = open(path, "rb").read()
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    if magic != b"glTF" or version != 2:
        sys.exit(f"{path}: not a glTF 2 binary")
    off, doc, bin_data = 12, None, b""
    while off < length:
        size, kind = struct.unpack_from("<I4s", data, off)
        chunk = data[off + 8:off + 8 + size]
        if kind == b"JSON":
            doc = json.loads(chunk)
        elif kind == b"BIN\0":
            bin_data = chunk
        off += 8 + size
    return doc, bin_data


def write_glb(path, doc, bin_data):
    def pad(b, fill):
        return b + fill * (-len(b) % 4)
    js = pad(json.dumps(doc, separators=(",", ":")).encode(), b" ")
    bn = pad(bin_data, b"\0")
    body = struct.pack("<I4s", len(js), b"JSON") + js + struct.pack("<I4s", len(bn), b"BIN\0") + bn
    with open(path, "wb") as f:
        f.write(struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("src")
    ap.add_argument("out")
    ap.add_argument("--grid", default="4,4,4")
    ap.add_argument("--spacing", type=float, default=1.25)
    ap.add_argument("--scale", action="append", default=[])
    ap.add_argument("--overlap", action="store_true")
    a = ap.parse_args()
    doc, bin_data = read_glb(a.src)
    gx, gy, gz = (int(v) for v in a.grid.split(","))
    # The mesh's extent from its POSITION accessors' min/max (glTF requires them).
    lo, hi = [1e30] * 3, [-1e30] * 3
    for prim in doc["meshes"][0]["primitives"]:
        acc = doc["accessors"][prim["attributes"]["POSITION"]]
        lo = [min(l, v) for l, v in zip(lo, acc["min"])]
        hi = [max(h, v) for h, v in zip(hi, acc["max"])]
    step = a.spacing * max(h - l for l, h in zip(lo, hi))
    scales = {}
    for s in a.scale:
        i, v = s.split(":")
        scales[int(i)] = [float(x) for x in v.split(",")]
    nodes = []
    for z in range(gz):
        for y in range(gy):
            for x in range(gx):
                i = len(nodes)
                shift = 0.5 * step if a.overlap and i % 2 else 0.0
                node = {"mesh": 0, "translation": [x * step + shift, y * step, z * step]}
                if i in scales:
                    node["scale"] = scales[i]
                nodes.append(node)
    doc["nodes"] = nodes
    doc["scenes"] = [{"nodes": list(range(len(nodes)))}]
    doc["scene"] = 0
    doc["meshes"] = doc["meshes"][:1]
    for key in ("cameras", "skins", "animations"):
        doc.pop(key, None)
    write_glb(a.out, doc, bin_data)


if __name__ == "__main__":
    main()
