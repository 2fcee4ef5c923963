#!/usr/bin/env bash
# Hostile binary glTF through `penumbra render`: truncated and bit-flipped copies of valid .glb
# files (the dragon from $PN_ASSETS and a small textured cube written here, with a fixed seed),
# absurd counts and lengths (headers and accessors claiming 2^32 elements or bytes, a hierarchy
# 5000 deep, JSON nested 100000 deep), NaN, Inf and overflowing values in positions and
# transforms.
# Every case either renders (where the table says it may) or exits 1 with an error line that
# names the file and says what is wrong; none crashes (a signal: also how the sanitizer build
# reports a finding) or runs past the time limit; a failing run leaves the previous output file
# untouched and no temporary file behind.
set -u
BIN=${PN_BIN:?PN_BIN not set}
TMP=${PN_TEST_TMP:-/tmp}/hostile_glb
rm -rf "$TMP" && mkdir -p "$TMP"
exec python3 - "$BIN" "$TMP" "${PN_ASSETS:-}" "$(dirname "$0")/fuzz" <<'PY'
import json, os, random, re, struct, subprocess, sys, time, zlib

BIN, TMP, ASSETS, FUZZ_DIR = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
LIMIT = 60  # seconds per run; the slowest case takes well under one
PREVIOUS = b"previous output\n"
failures = []
counts = {"render": 0, "fail": 0}


# The GLB and PNG writers of the fuzz corpus generator.
sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, FUZZ_DIR)
from make_corpus import as_glb as glb, pad4, tiny_png as png_2x2  # noqa: E402


def cube(positions=None, normals=None, uvs=None, edit=None, png=None):
    """A unit cube: 24 vertices (positions, normals, uvs), 36 u16 indices, a material and a PNG
    texture, in one BIN chunk. `edit(doc)` changes the JSON before it is written."""
    faces = [((1, 0, 0), (0, 1, 0)), ((-1, 0, 0), (0, 0, 1)), ((0, 1, 0), (0, 0, 1)),
             ((0, -1, 0), (1, 0, 0)), ((0, 0, 1), (1, 0, 0)), ((0, 0, -1), (0, 1, 0))]
    P, N, U, I = [], [], [], []
    for n, u in faces:
        v = (n[1] * u[2] - n[2] * u[1], n[2] * u[0] - n[0] * u[2], n[0] * u[1] - n[1] * u[0])
        base = len(P)
        for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            P.append(tuple(0.5 * (n[k] + su * u[k] + sv * v[k]) for k in range(3)))
            N.append(n)
            U.append(((su + 1) / 2, (sv + 1) / 2))
        I += [base, base + 1, base + 2, base, base + 2, base + 3]
    P, N, U = positions or P, normals or N, uvs or U
    pos = b"".join(struct.pack("<3f", *p) for p in P)
    nrm = b"".join(struct.pack("<3f", *n) for n in N)
    uv = b"".join(struct.pack("<2f", *t) for t in U)
    idx = pad4(b"".join(struct.pack("<H", i) for i in I))
    img = png or png_2x2()
    views, data = [], b""
    for part in (pos, nrm, uv, idx, img):
        views.append({"buffer": 0, "byteOffset": len(data), "byteLength": len(part)})
        data = pad4(data + part)
    doc = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
                                    "indices": 3, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
        "textures": [{"source": 0}], "images": [{"bufferView": 4, "mimeType": "image/png"}],
        "buffers": [{"byteLength": len(data)}], "bufferViews": views,
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 24, "type": "VEC3",
             "min": [-0.5] * 3, "max": [0.5] * 3},
            {"bufferView": 1, "componentType": 5126, "count": 24, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 24, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5123, "count": 36, "type": "SCALAR"}],
    }
    if edit:
        edit(doc)
    return doc, data


def run(name, data, expect, pattern=None):
    """expect: 'ok' (renders), 'fail' (exit 1, message matching pattern) or 'any' (either)."""
    path = os.path.join(TMP, name)
    with open(path, "wb") as f:
        f.write(data)
    out = os.path.join(TMP, "out.exr")
    with open(out, "wb") as f:
        f.write(PREVIOUS)
    cmd = [BIN, "render", path, "--size", "32x32", "--mode", "none", "-o", out]
    try:
        p = subprocess.run(cmd, capture_output=True, timeout=LIMIT)
    except subprocess.TimeoutExpired:
        failures.append(f"{name}: still running after {LIMIT} s (hang?)")
        return
    rc, err = p.returncode, p.stderr.decode(errors="replace")
    problem = None
    if rc < 0 or rc >= 128:
        problem = f"crashed (exit {rc})"
    elif [f for f in os.listdir(TMP) if ".tmp-" in f]:
        problem = "left a temporary file"
    elif rc == 0:
        with open(out, "rb") as f:
            written = f.read(4)
        if expect == "fail":
            problem = "rendered, expected to fail"
        elif written != b"\x76\x2f\x31\x01":  # the EXR magic number
            problem = "exit 0 without writing the EXR"
        else:
            counts["render"] += 1
    elif rc == 1:
        line = next((l for l in err.splitlines() if l.startswith(f"penumbra: error: {path}: ")), None)
        with open(out, "rb") as f:
            kept = f.read() == PREVIOUS
        if expect == "ok":
            problem = "failed, expected to render"
        elif line is None:
            problem = "no error line naming the file"
        elif pattern and not re.search(pattern, line):
            problem = f"error line does not match /{pattern}/"
        elif not kept:
            problem = "the previous output was overwritten"
        else:
            counts["fail"] += 1
    else:
        problem = f"exit {rc}, expected 0 or 1"
    if problem:
        failures.append(f"{name}: {problem}\n    " + "\n    ".join(err.splitlines()[-12:]))
        print(f"FAIL: {name}: {problem}")
    else:
        print(f"ok: {name}: exit {rc}" + (f": {err.strip().splitlines()[-1][len('penumbra: error: ') + len(path) + 2:]}"
                                         if rc else ""))
    for f in (path, out):
        os.remove(f)


start = time.time()
doc, data = cube()
small = glb(doc, data)
run("cube.glb", small, "ok")  # the base of the mutations renders
sources = [("cube", small)]
dragon_path = os.path.join(ASSETS, "stanford-dragon-res4-11k.glb") if ASSETS else ""
if os.path.isfile(dragon_path):
    with open(dragon_path, "rb") as f:
        sources.append(("dragon", f.read()))
    run("dragon.glb", sources[-1][1], "ok")
else:
    print(f"note: {dragon_path or '$PN_ASSETS'} missing: truncating and flipping the cube only")

# --- truncated: every cut through the header, the chunk headers, the JSON and the BIN chunk
for tag, b in sources:
    json_end = 20 + struct.unpack("<I", b[12:16])[0]
    cuts = sorted({0, 1, 4, 11, 12, 16, 19, 20, 21, (20 + json_end) // 2, json_end - 1, json_end, json_end + 4,
                   json_end + 8, json_end + 9, (json_end + len(b)) // 2, len(b) - 4, len(b) - 1})
    for n in cuts:
        run(f"{tag}_cut{n}.glb", b[:n], "fail", r"empty file|truncated|shorter than")

# --- bit flips: 1 to 4 random bits, anywhere in the cube, in the header and JSON of the dragon
# (its BIN chunk is geometry: a flipped bit there makes another valid dragon)
rng = random.Random(20260808)
for tag, b, n_variants in [(t, b, 120 if t == "cube" else 30) for t, b in sources]:
    span = len(b) if tag == "cube" else 20 + struct.unpack("<I", b[12:16])[0]
    for k in range(n_variants):
        m = bytearray(b)
        for _ in range(rng.randint(1, 4)):
            i = rng.randrange(span)
            m[i] ^= 1 << rng.randrange(8)
        run(f"{tag}_flip{k}.glb", bytes(m), "any")

# --- absurd counts and lengths
def acc(i, **kv):
    return lambda d: d["accessors"][i].update(kv)

def cube_glb(**kw):
    header = {k: kw.pop(k) for k in ("header_len", "json_len", "bin_len") if k in kw}
    d, b = cube(**kw)
    return glb(d, b, **header)

run("header_length_4G.glb", cube_glb(header_len=0xFFFFFFFF), "fail", r"truncated: the header declares 4294967295")
run("json_length_4G.glb", cube_glb(json_len=0xFFFFFFF0), "fail", r"JSON chunk \(4294967280 bytes\) does not fit")
run("bin_length_4G.glb", cube_glb(bin_len=0xFFFFFFF0), "fail", r"BIN")
run("version_3.glb", b"glTF\x03\0\0\0" + small[8:], "fail", r"binary glTF version 3 is not supported")
run("indices_2e32.glb", cube_glb(edit=acc(3, count=2 ** 32)), "fail", r"count 4294967296 .*exceeds bufferView")
run("indices_2e32_minus1.glb", cube_glb(edit=acc(3, count=2 ** 32 - 1)), "fail", r"count 4294967295 .*exceeds bufferView")
run("positions_2e32.glb", cube_glb(edit=acc(0, count=2 ** 32)), "fail", r"exceeds bufferView")
run("positions_unbacked_2e32.glb",
    cube_glb(edit=lambda d: (d["accessors"][0].pop("bufferView"), d["accessors"][0].update(count=2 ** 32))),
    "fail", r"without a bufferView exceeds the limit")
run("sparse_2e31.glb", cube_glb(edit=acc(0, sparse={"count": 2 ** 31 - 1, "indices": {"bufferView": 3, "componentType": 5123},
                                                    "values": {"bufferView": 0}})), "fail", r"sparse count")
run("stride_2e31.glb", cube_glb(edit=lambda d: d["bufferViews"][0].update(byteStride=2 ** 31)), "fail",
    r"byteStride|exceeds")
run("byteoffset_2e63.glb", cube_glb(edit=acc(3, byteOffset=2 ** 63)), "fail", r"byteOffset|exceeds|accessor")
run("buffer_bytelength_4G.glb", cube_glb(edit=lambda d: d["buffers"][0].update(byteLength=2 ** 32)), "fail",
    r"buffer|byteLength|size")
run("view_past_buffer.glb", cube_glb(edit=lambda d: d["bufferViews"][1].update(byteOffset=2 ** 32 - 8)), "fail",
    r"bufferView 1|exceed")
run("hierarchy_5000_deep.glb",
    cube_glb(edit=lambda d: d.update(nodes=[{"children": [i + 1]} for i in range(5000)] + [{"mesh": 0}])),
    "fail", r"deeper than 1024 levels")
run("cycle.glb", cube_glb(edit=lambda d: d.update(nodes=[{"mesh": 0, "children": [1]}, {"children": [0]}])),
    "fail", r"reached twice")
# (tinygltf recurses over the JSON tree: 10^4 levels overflowed the stack before the loader
# learned to refuse more than 512)
d, b = cube()
text = json.dumps(d, separators=(",", ":")).encode()
run("json_nested_100000.glb", glb(text[:-1] + b',"extras":' + b"[" * 100000 + b"]" * 100000 + b"}", b),
    "fail", r"JSON nested deeper than 512 levels")
run("json_nested_500.glb", glb(text[:-1] + b',"extras":' + b"[" * 500 + b"]" * 500 + b"}", b), "ok")
big_png = bytearray(png_2x2())
big_png[16:24] = struct.pack(">II", 65535, 65535)  # IHDR claims 65535x65535 (the CRC no longer fits either)
run("png_65535x65535.glb", cube_glb(png=bytes(big_png)), "ok")  # the texture is dropped with a warning

# --- NaN, Inf and overflow in positions and transforms
nan, inf = float("nan"), float("inf")
for name, value, pattern in [("nan", nan, r"POSITION\): vertex 5 is not finite"),
                             ("inf", inf, r"POSITION\): vertex 5 is not finite"),
                             ("minus_inf", -inf, r"POSITION\): vertex 5 is not finite"),
                             ("1e30", 1e30, r"positions reach 1e\+30 from the origin; beyond 1e18")]:
    d, b = cube()
    b = bytearray(b)
    b[5 * 12 + 4:5 * 12 + 8] = struct.pack("<f", value)  # vertex 5, y
    run(f"position_{name}.glb", glb(d, bytes(b)), "fail", pattern)
d, b = cube()
b = bytearray(b)
b[24 * 12 + 7 * 12:24 * 12 + 7 * 12 + 4] = struct.pack("<f", nan)  # normal 7: repaired from the face
b[24 * 24 + 3 * 8:24 * 24 + 3 * 8 + 4] = struct.pack("<f", inf)   # uv 3: zeroed
run("normal_nan_uv_inf.glb", glb(d, bytes(b)), "ok")
d, b = cube(edit=lambda d: d["nodes"][0].update(translation=[0, 0, 0]))
text = json.dumps(d, separators=(",", ":")).encode().replace(b'"translation":[0,0,0]', b'"translation":[1e999,0,0]')
run("translation_1e999.glb", glb(text, b), "fail", r"number overflow parsing '1e999'")
# The largest doubles JSON holds, multiplied down the hierarchy: infinite world transforms.
run("scales_1e300_nested.glb", cube_glb(edit=lambda d: d.update(nodes=[{"scale": [1e300] * 3, "children": [1]},
                                                                      {"scale": [1e300] * 3, "mesh": 0}])),
    "fail", r"vertex 0 is not finite after the node transform")
run("scale_1e38.glb", cube_glb(edit=lambda d: d["nodes"][0].update(scale=[1e38, 1e38, 1e38])), "fail",
    r"positions reach 5e\+37 from the origin; beyond 1e18")
run("matrix_overflow.glb", cube_glb(edit=lambda d: d.update(nodes=[{"matrix": [3e38, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0,
                                                                                 3e38, 0, 0, 1], "mesh": 0}])),
    "fail", r"not finite after the node transform")

print(f"{counts['render']} rendered, {counts['fail']} refused as expected, {len(failures)} failures, "
      f"in {time.time() - start:.0f} s")
for f in failures:
    print("FAIL:", f)
sys.exit(1 if failures else 0)
PY
