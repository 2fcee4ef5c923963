#!/usr/bin/env bash
# A glTF as an exporter writes KHR_lights_punctual (Blender's layout: the lights on nodes of their
# own, turned by quaternions, a sun, a point with a range and a spot with both cones, names and
# colours), checked against the rules of the Khronos validator that concern it, then rendered:
#  - the extension's schema: type one of directional, point, spot; color three numbers in [0, 1];
#    intensity >= 0; range > 0 and only on point and spot; spot present exactly on a spot, with
#    0 <= innerConeAngle < outerConeAngle <= pi/2; a node's light index inside the list; the
#    extension in extensionsUsed;
#  - the core rules the file's data touches: every buffer's byteLength the length of its data, every
#    bufferView inside its buffer, every accessor inside its bufferView, POSITION with min and max
#    equal to its data's, indices inside the vertices, rotations unit quaternions.
# The checker must reject a copy with each rule broken once (so that it can fail), and penumbra must
# render the clean file with its three lights: one V per light, each kind named in the EXR header
# (sun, omni, omni with the spot's cones), the unshadowed radiance non-zero where they shine.
set -u
BIN=${PN_BIN:?PN_BIN not set}
T=${PN_TEST_TMP:-/tmp}/gltf_lights
rm -rf "$T" && mkdir -p "$T"
fail=0

python3 - "$T" <<'PY' || exit 1
import base64, copy, json, math, struct, sys
out = sys.argv[1]

# A 6 x 6 ground and a unit cube standing on it at the origin, as two meshes.
pos, idx = [], []
def quad(a, b, c, d):
    n = len(pos)
    pos.extend([a, b, c, d])
    idx.extend([n, n + 1, n + 2, n, n + 2, n + 3])
quad((-3, 0, 3), (3, 0, 3), (3, 0, -3), (-3, 0, -3))
ground_idx = len(idx)
for axis in range(3):
    for s in (-0.5, 0.5):
        def p(u, v):
            q = [0, 0, 0]
            q[axis] = s; q[(axis + 1) % 3] = u; q[(axis + 2) % 3] = v
            return (q[0], q[1] + 0.5, q[2])
        a, b, c, d = p(-.5, -.5), p(.5, -.5), p(.5, .5), p(-.5, .5)
        quad(*(a, b, c, d) if s > 0 else (a, d, c, b))
vb = b"".join(struct.pack("<3f", *v) for v in pos)
ib = b"".join(struct.pack("<H", i) for i in idx)
data = vb + ib
lo = [min(v[k] for v in pos) for k in range(3)]
hi = [max(v[k] for v in pos) for k in range(3)]
h = math.sqrt(0.5)
gltf = {
    "asset": {"version": "2.0", "generator": "Khronos glTF Blender I/O v3.6.28"},
    "extensionsUsed": ["KHR_lights_punctual"],
    "extensions": {"KHR_lights_punctual": {"lights": [
        {"name": "Sun", "type": "directional", "color": [1, 0.95, 0.9], "intensity": 3},
        {"name": "Bulb", "type": "point", "color": [1, 0.8, 0.6], "intensity": 54.35, "range": 40},
        {"name": "Spot", "type": "spot", "color": [0.6, 0.8, 1], "intensity": 80,
         "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.6}}]}},
    "scene": 0,
    "scenes": [{"name": "Scene", "nodes": [0, 1, 2, 3, 4]}],
    "nodes": [
        {"name": "Ground", "mesh": 0},
        {"name": "Cube", "mesh": 1},
        # Blender's sun turned to shine down: -Z to -Y, a quarter turn about +X.
        {"name": "Sun", "rotation": [-h, 0, 0, h], "translation": [0, 8, 0],
         "extensions": {"KHR_lights_punctual": {"light": 0}}},
        {"name": "Bulb", "translation": [2, 2.5, 1], "extensions": {"KHR_lights_punctual": {"light": 1}}},
        {"name": "Spot", "rotation": [-h, 0, 0, h], "translation": [-1.5, 3, 0],
         "extensions": {"KHR_lights_punctual": {"light": 2}}}],
    "meshes": [{"name": "Ground", "primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]},
               {"name": "Cube", "primitives": [{"attributes": {"POSITION": 0}, "indices": 2}]}],
    "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": len(pos), "type": "VEC3", "min": lo, "max": hi},
        {"bufferView": 1, "componentType": 5123, "count": ground_idx, "type": "SCALAR"},
        {"bufferView": 1, "byteOffset": 2 * ground_idx, "componentType": 5123, "count": len(idx) - ground_idx,
         "type": "SCALAR"}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(vb), "target": 34962},
                    {"buffer": 0, "byteOffset": len(vb), "byteLength": len(ib), "target": 34963}],
    "buffers": [{"byteLength": len(data),
                 "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
}

SIZE = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}

def problems(g):
    """The rules broken, as messages (the validator's, restricted to what this file uses)."""
    bad = []
    lights = g.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
    if lights and "KHR_lights_punctual" not in g.get("extensionsUsed", []):
        bad.append("KHR_lights_punctual is used but not in extensionsUsed")
    for i, l in enumerate(lights):
        t = l.get("type")
        if t not in ("directional", "point", "spot"):
            bad.append(f"light {i}: type {t!r}")
        c = l.get("color", [1, 1, 1])
        if not (isinstance(c, list) and len(c) == 3 and all(isinstance(x, (int, float)) and 0 <= x <= 1 for x in c)):
            bad.append(f"light {i}: color {c}")
        if not l.get("intensity", 1) >= 0:
            bad.append(f"light {i}: intensity {l.get('intensity')}")
        if "range" in l and (t == "directional" or not l["range"] > 0):
            bad.append(f"light {i}: range {l['range']} on a {t}")
        if (t == "spot") != ("spot" in l):
            bad.append(f"light {i}: spot properties on a {t}")
        if t == "spot":
            s = l["spot"]
            inner, outer = s.get("innerConeAngle", 0), s.get("outerConeAngle", math.pi / 4)
            if not (0 <= inner < outer <= math.pi / 2):
                bad.append(f"light {i}: cones {inner} and {outer}")
    data = [base64.b64decode(b["uri"].split(",", 1)[1]) for b in g["buffers"]]
    for i, b in enumerate(g["buffers"]):
        if b["byteLength"] != len(data[i]):
            bad.append(f"buffer {i}: byteLength {b['byteLength']}, data {len(data[i])}")
    for i, v in enumerate(g["bufferViews"]):
        if v.get("byteOffset", 0) + v["byteLength"] > g["buffers"][v["buffer"]]["byteLength"]:
            bad.append(f"bufferView {i} beyond its buffer")
    for i, a in enumerate(g["accessors"]):
        v = g["bufferViews"][a["bufferView"]]
        if a.get("byteOffset", 0) + a["count"] * SIZE[a["componentType"]] * COMPONENTS[a["type"]] > v["byteLength"]:
            bad.append(f"accessor {i} beyond its bufferView")
    def floats(a):
        v = g["bufferViews"][a["bufferView"]]
        off = v.get("byteOffset", 0) + a.get("byteOffset", 0)
        return [struct.unpack_from("<3f", data[v["buffer"]], off + 12 * k) for k in range(a["count"])]
    for m in g["meshes"]:
        for p in m["primitives"]:
            a = g["accessors"][p["attributes"]["POSITION"]]
            vs = floats(a)
            if a.get("min") != [min(v[k] for v in vs) for k in range(3)] or \
               a.get("max") != [max(v[k] for v in vs) for k in range(3)]:
                bad.append(f"mesh {m['name']}: POSITION min/max do not match its data")
            ia = g["accessors"][p["indices"]]
            iv = g["bufferViews"][ia["bufferView"]]
            off = iv.get("byteOffset", 0) + ia.get("byteOffset", 0)
            try:
                if any(struct.unpack_from("<H", data[iv["buffer"]], off + 2 * k)[0] >= a["count"] for k in range(ia["count"])):
                    bad.append(f"mesh {m['name']}: an index past its vertices")
            except struct.error:
                bad.append(f"mesh {m['name']}: indices beyond the buffer")
    for i, n in enumerate(g["nodes"]):
        q = n.get("rotation")
        if q and abs(sum(x * x for x in q) - 1) > 5e-4: # the validator's tolerance for unit quaternions
            bad.append(f"node {i}: rotation not a unit quaternion")
        e = n.get("extensions", {}).get("KHR_lights_punctual")
        if e is not None and not (isinstance(e.get("light"), int) and 0 <= e["light"] < len(lights)):
            bad.append(f"node {i}: light index {e.get('light')}")
    return bad

clean = problems(gltf)
if clean:
    print("FAIL: the exporter's file breaks rules:", clean)
    sys.exit(1)
json.dump(gltf, open(f"{out}/lights.gltf", "w"))
print("ok: the file keeps every rule checked")

# Each rule broken once: the checker must see it.
def lights(g):
    return g["extensions"]["KHR_lights_punctual"]["lights"]
breaks = {
    "type": lambda g: lights(g)[0].update(type="area"),
    "color": lambda g: lights(g)[1].update(color=[1, 2, 1]),
    "intensity": lambda g: lights(g)[1].update(intensity=-1),
    "range": lambda g: lights(g)[1].update(range=0),
    "range on a sun": lambda g: lights(g)[0].update(range=5),
    "cones": lambda g: lights(g)[2]["spot"].update(innerConeAngle=0.7),
    "spot on a point": lambda g: lights(g)[1].update(spot={"outerConeAngle": 0.5}),
    "extensionsUsed": lambda g: g.update(extensionsUsed=[]),
    "light index": lambda g: g["nodes"][3]["extensions"]["KHR_lights_punctual"].update(light=3),
    "quaternion": lambda g: g["nodes"][2].update(rotation=[-0.7, 0, 0, 0.5]),
    "min/max": lambda g: g["accessors"][0].update(max=[3, 2, 3]),
    "byteLength": lambda g: g["buffers"][0].update(byteLength=g["buffers"][0]["byteLength"] + 4),
    "accessor count": lambda g: g["accessors"][2].update(count=1000),
}
missed = []
for name, brk in breaks.items():
    g = copy.deepcopy(gltf)
    brk(g)
    if not problems(g):
        missed.append(name)
if missed:
    print("FAIL: the checker misses broken rules:", missed)
    sys.exit(1)
print(f"ok: the checker rejects each of {len(breaks)} broken copies")
PY

"$BIN" render "$T/lights.gltf" --size 160x120 --spp 4 --aovs -o "$T/lights.exr" > "$T/render.txt" 2> "$T/render.err" ||
  { echo "FAIL: render exited $?"; cat "$T/render.err"; exit 1; }
grep -qi "warn" "$T/render.err" && { echo "FAIL: the clean file drew warnings:"; cat "$T/render.err"; fail=1; }
hdr=$(exrheader "$T/lights.exr")
for c in shadow.V.0 shadow.V.1 shadow.V.2; do
  grep -q "$c" <<<"$hdr" || { echo "FAIL: no $c channel"; fail=1; }
done
grep -q "shadow.V.3" <<<"$hdr" && { echo "FAIL: a fourth light"; fail=1; }
for k in sun omni; do
  grep -q "\"$k\"" <<<"$hdr" || { echo "FAIL: the header names no $k light"; fail=1; }
done
# Every light reaches the ground: its V is above 0 somewhere, and the picture is lit.
python3 - "$T/lights.exr" <<'PY' || fail=1
import subprocess, sys
path = sys.argv[1]
for c in ("shadow.V.0", "shadow.V.1", "shadow.V.2", "R"):
    out = subprocess.run(["oiiotool", path, "--ch", c, "--printstats"], capture_output=True, text=True).stdout
    line = [l for l in out.splitlines() if "Stats Max" in l]
    mx = float(line[0].split(":")[1].split()[0]) if line else 0.0
    if not mx > 0:
        print(f"FAIL: {c} is 0 everywhere")
        sys.exit(1)
    print(f"ok: {c} max {mx:g}")
PY
[ $fail = 0 ] && echo "gltf_lights: ok"
exit $fail
