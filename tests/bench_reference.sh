#!/usr/bin/env bash
# The bench's converged reference checked against itself (builtin:default, 96x96):
#  - exact's error against it is clearly above zero at 4 samples per pixel and falls from 4 to 16
#    to 64 (about as 1/sqrt(spp), stratified faster: the fall is asserted, not the slope), and even
#    exact at 1024 samples differs from it (its seed is its own), while exact's bias (against exact
#    with the same samples) is zero at every spp. exact's is so by construction (the bench compares
#    it with itself); exact-ls, a different shader that must give the same V, checks the bias
#    machinery for real;
#  - the reference is cached: a second run reads the file instead of rendering and measures the
#    same errors; another size gets another file; a damaged file is rendered again, with a warning.
# The cache is $PN_TEST_TMP/reference_cache (--reference-cache), which this test leaves holding the
# default scene's references at 96x96 and 64x48: the ctest fixture `reference` that bench_smoke
# requires reads them instead of rendering its own.
set -u
BIN=${PN_BIN:?PN_BIN not set}
T=${PN_TEST_TMP:-/tmp}/bench_reference
RC=${PN_TEST_TMP:-/tmp}/reference_cache
rm -rf "$T" "$RC" && mkdir -p "$T"
args=(bench --scenes builtin:default --modes exact,exact-ls --trees 5,2 --spp 4,16,64,1024 --size 96x96 --filter none --repeat 1 --warmup 0 --no-embree
      --out "$T/out" --reference-cache "$RC")
fail=0
"$BIN" "${args[@]}" > "$T/run1.txt" 2> "$T/run1.err" || { echo "FAIL: bench exited $?"; cat "$T/run1.err"; exit 1; }
grep -q "rendering the converged reference" "$T/run1.err" || { echo "FAIL: no reference rendered"; fail=1; }
files=("$RC"/*.exr)
[ ${#files[@]} = 1 ] && [ -s "${files[0]}" ] || { echo "FAIL: expected one cached reference: ${files[*]}"; exit 1; }
exrheader "${files[0]}" | grep -q "shadow.V" || { echo "FAIL: the cache lacks shadow.V"; fail=1; }
cp "$T/out/bench.json" "$T/run1.json"
"$BIN" "${args[@]}" > "$T/run2.txt" 2> "$T/run2.err" || { echo "FAIL: second bench exited $?"; exit 1; }
grep -q "from the cache" "$T/run2.err" || { echo "FAIL: the second run did not reuse the cache"; fail=1; }
grep -q "rendering the converged reference" "$T/run2.err" && { echo "FAIL: the second run rendered again"; fail=1; }
python3 - "$T/run1.json" "$T/out/bench.json" <<'PY' || fail=1
import json, sys
a, b = (json.load(open(p))["results"] for p in sys.argv[1:3])
err = {r["spp"]: r["reference"]["mae"] for r in a if r["mode"] == "exact"}
print("exact against the converged reference, MAE by spp:", err)
assert sorted(err) == [4, 16, 64, 1024], err
assert err[4] > 0.005, err                         # clearly non-zero
assert err[16] < 0.8 * err[4] and err[64] < 0.8 * err[16], err  # falls with the samples
assert err[64] < 0.5 * err[4], err                 # 1/sqrt(16) = 0.25 expected; 0.5 leaves room
assert 0 < err[1024] < err[64], err                # the reference's own seed: not the cells' image
assert sorted(r["mode"] for r in a) == ["exact"] * 4 + ["exact-ls"] * 4, a
for r in a:
    assert r["bias"]["max"] == 0 and r["bias"]["mae"] == 0, r
    if r["mode"] == "exact-ls":  # the same V, so the same reference error
        assert r["reference"] == [e for e in a if e["mode"] == "exact" and e["spp"] == r["spp"]][0]["reference"], r
# The cached reference gives the same figures (the renders are deterministic).
assert [r["reference"] for r in a] == [r["reference"] for r in b], (a, b)
print("reference machinery ok")
PY
# The same view name and size with other content: another key, another file. Two glTF files both
# named s.gltf, a ground quad under a triangle at two heights (the key must hash the scene).
for h in 0.3 0.6; do
  mkdir -p "$T/s$h"
  python3 - "$T/s$h/s.gltf" "$h" <<'PY'
import base64, json, struct, sys
h = float(sys.argv[2])
pos = [(-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1), (-0.3, h, -0.3), (0.3, h, -0.3), (0, h, 0.3)]
idx = [0, 3, 2, 0, 2, 1, 4, 6, 5]
data = b"".join(struct.pack("<3f", *p) for p in pos) + b"".join(struct.pack("<3f", 0, 1, 0) for _ in pos)
data += struct.pack("<%dI" % len(idx), *idx)
n = len(pos) * 12
uri = "data:application/octet-stream;base64," + base64.b64encode(data).decode()
json.dump({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2}]}],
  "buffers": [{"byteLength": len(data), "uri": uri}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": n}, {"buffer": 0, "byteOffset": n, "byteLength": n},
                  {"buffer": 0, "byteOffset": 2 * n, "byteLength": 4 * len(idx)}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": len(pos), "type": "VEC3", "min": [-1, 0, -1], "max": [1, h, 1]},
                {"bufferView": 1, "componentType": 5126, "count": len(pos), "type": "VEC3"},
                {"bufferView": 2, "componentType": 5125, "count": len(idx), "type": "SCALAR"}]}, open(sys.argv[1], "w"))
PY
  "$BIN" bench --scenes "$T/s$h/s.gltf" --modes exact --spp 4 --size 64x64 --filter none --repeat 1 --warmup 0 --no-embree \
    --out "$T/named" > /dev/null 2> "$T/named$h.err" || { echo "FAIL: bench of s.gltf ($h)"; fail=1; }
  grep -q "rendering the converged reference" "$T/named$h.err" || { echo "FAIL: s.gltf at $h reused another scene's reference"; fail=1; }
done
n=$(ls "$T"/named/reference/*.exr | wc -l)
[ "$n" = 2 ] || { echo "FAIL: two scenes under one name share a cache file ($n files)"; fail=1; }
# Another size: another key, another file (bench_smoke's size, which it reads from here).
"$BIN" bench --scenes builtin:default --modes exact --spp 4 --size 64x48 --filter none --repeat 1 --warmup 0 --no-embree \
  --out "$T/out" --reference-cache "$RC" > /dev/null 2> "$T/run3.err" || { echo "FAIL: 64x48 bench"; fail=1; }
n=$(ls "$RC"/*.exr | wc -l)
[ "$n" = 2 ] || { echo "FAIL: expected 2 cached references, have $n"; fail=1; }
# A damaged cache file: a warning naming it, a new render, the same figures.
printf 'not an exr' > "${files[0]}"
"$BIN" "${args[@]}" > /dev/null 2> "$T/run4.err" || { echo "FAIL: bench over a damaged cache exited $?"; fail=1; }
grep -q "cannot be read" "$T/run4.err" && grep -q "rendering the converged reference" "$T/run4.err" \
  || { echo "FAIL: a damaged cache was not rendered again"; cat "$T/run4.err"; fail=1; }
python3 - "$T/run1.json" "$T/out/bench.json" <<'PY' || fail=1
import json, sys
a, b = (json.load(open(p))["results"] for p in sys.argv[1:3])
assert [r["reference"] for r in a] == [r["reference"] for r in b], (a, b)
PY
exit $fail
